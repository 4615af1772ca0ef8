//! The node's decisions without the network: translation, fail-safe and parameters.

mod common;

use common::{forward, ring_scan, wall_scan, BEAMS};
use std::time::{Duration, Instant};

use shieldnav_ros2::msg::{Header, LaserScan, Odometry, PointCloud2, PointField, Twist};
use shieldnav_ros2::params::{parse_value, RawParams, Value};
use shieldnav_ros2::translate::{laser_scan_points, point_cloud_points, Mount};
use shieldnav_ros2::{Output, ShieldNode};

fn at_rest() -> Odometry {
    Odometry::default()
}

fn node(method: &str) -> ShieldNode {
    let mut raw = RawParams::default();
    raw.set("method", Value::Str(method.into()));
    ShieldNode::new(raw.build().unwrap()).unwrap()
}

/// Scan, odometry and the nominal command all at `t`: the node's answer.
fn step(n: &mut ShieldNode, scan: &LaserScan, cmd: &Twist, t: Instant) -> Output {
    n.on_scan(scan, t).unwrap();
    n.on_odometry(&at_rest(), t).unwrap();
    n.on_nominal(cmd, t)
}

#[test]
fn free_space_passes_the_command_unchanged() {
    for method in ["braking", "composite"] {
        let mut n = node(method);
        let out = step(&mut n, &wall_scan(50.0), &forward(0.5), Instant::now());
        assert!(out.state.ok, "{method}: {:?}", out.state);
        assert!((out.command.linear.x - 0.5).abs() < 1e-9, "{method}: {:?}", out.command);
        assert!(!out.state.active);
    }
}

#[test]
fn a_wall_ahead_stops_a_forward_command() {
    for method in ["braking", "composite", "hardmin"] {
        let mut n = node(method);
        let out = step(&mut n, &wall_scan(1.0), &forward(1.0), Instant::now());
        assert!(out.state.ok, "{method}: {:?}", out.state);
        assert!(out.state.active, "{method}: {:?}", out.state);
        // the braking shield lets the body (its nose 0.45 m off) creep on at its tight-space speed
        let most = if method == "braking" { 0.5 + 1e-9 } else { 0.25 };
        assert!(out.command.linear.x < most, "{method}: forward {} at a wall 1 m ahead", out.command.linear.x);
        assert!(out.state.points_used > 0 && out.state.h.is_some());
        // the state is one JSON object with the documented keys
        let json: serde_json::Value = serde_json::from_str(&out.state.to_json()).unwrap();
        for key in ["ok", "reason", "H", "h_min", "active", "feasible", "points_used", "solve_time_us", "command", "nominal"] {
            assert!(json.get(key).is_some(), "state lacks {key}: {json}");
        }
    }
}

#[test]
fn a_stale_scan_stops_the_robot() {
    let mut n = node("composite");
    let t0 = Instant::now();
    assert!(step(&mut n, &wall_scan(50.0), &forward(0.5), t0).state.ok);
    let later = t0 + Duration::from_millis(600);
    n.on_odometry(&at_rest(), later).unwrap();
    let out = n.on_nominal(&forward(0.5), later);
    assert_eq!(out.command, Twist::default());
    assert!(!out.state.ok);
    assert!(out.state.reason.as_deref().unwrap().contains("stale scan"), "{:?}", out.state.reason);
}

#[test]
fn no_scan_yet_and_stale_odometry_stop_the_robot() {
    let mut n = node("braking");
    let t0 = Instant::now();
    n.on_odometry(&at_rest(), t0).unwrap();
    let out = n.on_nominal(&forward(0.5), t0);
    assert_eq!(out.command, Twist::default());
    assert!(out.state.reason.unwrap().contains("no scan"));
    n.on_scan(&wall_scan(50.0), t0).unwrap();
    let later = t0 + Duration::from_millis(700);
    n.on_scan(&wall_scan(50.0), later).unwrap();
    let out = n.on_nominal(&forward(0.5), later);
    assert_eq!(out.command, Twist::default());
    assert!(out.state.reason.unwrap().contains("stale odometry"));
}

#[test]
fn a_missing_or_stale_command_gives_zero_on_the_watchdog() {
    let mut n = node("composite");
    let t0 = Instant::now();
    let out = n.tick(t0).expect("no command yet: zero");
    assert_eq!(out.command, Twist::default());
    assert!(out.state.reason.unwrap().contains("no nominal command"));
    assert!(step(&mut n, &wall_scan(50.0), &forward(0.5), t0).state.ok);
    assert!(n.tick(t0 + Duration::from_millis(100)).is_none(), "a fresh command is not overridden");
    let out = n.tick(t0 + Duration::from_millis(800)).expect("stale command: zero");
    assert!(out.state.reason.unwrap().contains("stale nominal command"));
}

#[test]
fn malformed_scans_are_rejected_with_the_reason_and_stop_the_robot() {
    let t = Instant::now();
    let good = wall_scan(2.0);
    let cases: Vec<(LaserScan, &str)> = vec![
        (LaserScan { angle_min: f32::NAN, ..good.clone() }, "not finite"),
        (LaserScan { angle_increment: 0.0, ..good.clone() }, "angle_increment is 0"),
        (LaserScan { ranges: good.ranges[..500].to_vec(), ..good.clone() }, "give"),
        (LaserScan { intensities: vec![1.0; 3], ..good.clone() }, "intensities"),
        (LaserScan { range_min: 5.0, range_max: 1.0, ..good.clone() }, "range_min"),
        (LaserScan { ranges: vec![], ..good.clone() }, "no ranges"),
        (LaserScan { ranges: vec![f32::NAN; BEAMS], ..good.clone() }, "NaN (invalid)"),
    ];
    for (scan, why) in cases {
        let mut n = node("composite");
        assert!(step(&mut n, &good, &forward(0.3), t).state.ok);
        let err = n.on_scan(&scan, t).unwrap_err();
        assert!(err.contains(why), "{err:?} should say {why:?}");
        let out = n.on_nominal(&forward(0.3), t);
        assert_eq!(out.command, Twist::default());
        assert!(out.state.reason.unwrap().contains(why));
        // a valid scan restores the filter
        n.on_scan(&good, t).unwrap();
        assert!(n.on_nominal(&forward(0.3), t).state.ok);
    }
}

#[test]
fn a_non_finite_command_or_odometry_is_rejected() {
    let t = Instant::now();
    let mut n = node("braking");
    assert!(step(&mut n, &wall_scan(50.0), &forward(0.3), t).state.ok);
    let out = n.on_nominal(&forward(f64::NAN), t);
    assert_eq!(out.command, Twist::default());
    assert!(out.state.reason.unwrap().contains("not finite"));
    let mut odom = at_rest();
    odom.twist.twist.angular.z = f64::INFINITY;
    assert!(n.on_odometry(&odom, t).is_err());
    let out = n.on_nominal(&forward(0.3), t);
    assert!(out.state.reason.unwrap().contains("odometry rejected"));
}

#[test]
fn laser_scan_nan_and_inf_ranges() {
    let scan = LaserScan {
        angle_min: 0.0,
        angle_max: 0.5,
        angle_increment: 0.1,
        range_min: 0.1,
        range_max: 10.0,
        ranges: vec![1.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.05, 20.0],
        ..Default::default()
    };
    let mut pts = Vec::new();
    let n = laser_scan_points(&scan, &Mount::default(), &mut pts).unwrap();
    // 1.0 at 0 rad, and −inf (too close) at range_min; NaN, +inf, below min, above max dropped
    assert_eq!(n, 2);
    assert!((pts[0] - 1.0).abs() < 1e-12 && pts[1].abs() < 1e-12);
    let a = 0.3f32 as f64;
    assert!((pts[3] - 0.1 * a.cos()).abs() < 1e-6 && (pts[4] - 0.1 * a.sin()).abs() < 1e-6);
}

#[test]
fn the_mount_moves_and_turns_the_points() {
    let scan = LaserScan { angle_min: 0.0, angle_max: 0.0, angle_increment: 0.1, range_min: 0.0, range_max: 10.0, ranges: vec![1.0], ..Default::default() };
    let mount = Mount::new(0.2, -0.1, 0.3, std::f64::consts::FRAC_PI_2).unwrap();
    let mut pts = Vec::new();
    laser_scan_points(&scan, &mount, &mut pts).unwrap();
    // a return 1 m ahead of a sensor turned left is 1 m to the body's left
    assert!((pts[0] - 0.2).abs() < 1e-12 && (pts[1] - 0.9).abs() < 1e-12 && (pts[2] - 0.3).abs() < 1e-12, "{pts:?}");
    // and a sensor turned backwards sees the wall behind
    let mut n = {
        let mut raw = RawParams::default();
        raw.set("method", Value::Str("composite".into())).set("mount_yaw", Value::Float(std::f64::consts::PI));
        ShieldNode::new(raw.build().unwrap()).unwrap()
    };
    let t = Instant::now();
    let out = step(&mut n, &wall_scan(1.0), &forward(-1.0), t);
    assert!(out.command.linear.x > -0.25, "backing into the wall seen by a rear sensor: {:?}", out.command);
}

fn cloud(points: &[[f32; 3]], big: bool) -> PointCloud2 {
    let field = |name: &str, offset| PointField { name: name.into(), offset, datatype: PointField::FLOAT32, count: 1 };
    // x y z with 4 bytes of intensity between y and z: found by name, not position
    let fields = vec![field("intensity", 8), field("x", 0), field("y", 4), field("z", 12)];
    let mut data = Vec::new();
    for p in points {
        for v in [p[0], p[1], 7.0, p[2]] {
            data.extend_from_slice(&if big { v.to_be_bytes() } else { v.to_le_bytes() });
        }
    }
    PointCloud2 {
        header: Header { frame_id: "lidar".into(), ..Default::default() },
        height: 1,
        width: points.len() as u32,
        fields,
        is_bigendian: big,
        point_step: 16,
        row_step: 16 * points.len() as u32,
        data,
        is_dense: false,
    }
}

#[test]
fn point_clouds_are_read_by_field_name_and_offset() {
    for big in [false, true] {
        let c = cloud(&[[1.0, 2.0, 0.5], [f32::NAN, 0.0, 0.0], [3.0, -1.0, -0.2]], big);
        let mut pts = Vec::new();
        let n = point_cloud_points(&c, &Mount::default(), &mut pts).unwrap();
        assert_eq!(n, 2);
        assert_eq!(pts, vec![1.0, 2.0, 0.5, 3.0, -1.0, (-0.2f32) as f64]);
    }
}

#[test]
fn malformed_point_clouds_are_rejected() {
    let good = cloud(&[[1.0, 2.0, 0.5]; 4], false);
    let mut no_x = good.clone();
    no_x.fields.retain(|f| f.name != "x");
    let mut int_x = good.clone();
    int_x.fields[1].datatype = PointField::INT32;
    let mut outside = good.clone();
    outside.fields[3].offset = 14;
    let short = PointCloud2 { data: good.data[..40].to_vec(), ..good.clone() };
    let bad_row = PointCloud2 { row_step: 8, ..good.clone() };
    let huge = PointCloud2 { width: u32::MAX, height: u32::MAX, ..good.clone() };
    for (c, why) in [(no_x, "no field \"x\""), (int_x, "datatype"), (outside, "does not fit"), (short, "data holds"), (bad_row, "row_step"), (huge, "larger than")] {
        let err = point_cloud_points(&c, &Mount::default(), &mut Vec::new()).unwrap_err();
        assert!(err.contains(why), "{err:?} should say {why:?}");
    }
}

#[test]
fn the_sensor_frame_is_checked() {
    let mut raw = RawParams::default();
    raw.set("method", Value::Str("composite".into())).set("sensor_frame", Value::Str("base_scan".into()));
    let mut n = ShieldNode::new(raw.build().unwrap()).unwrap();
    let err = n.on_scan(&wall_scan(2.0), Instant::now()).unwrap_err();
    assert!(err.contains("base_scan"), "{err}");
}

#[test]
fn parameter_file_and_overrides() {
    let yaml = "shieldnav_shield:\n  ros__parameters:\n    method: composite\n    semi_axes: [0.6, 0.3]\n    gamma: 0.5\n    u_max: [1.0, 0.5]\n    crop_radius: null\n    angular_bins: 360\n    scan_topic: /front/scan\n    mount_x: 0.25\n/**:\n  ros__parameters:\n    domain_id: 7\n";
    let mut raw = RawParams::default();
    raw.load_yaml(yaml, "test.yaml", "shieldnav_shield").unwrap();
    let p = raw.build().unwrap();
    assert_eq!(p.shield.semi_axes, vec![0.6, 0.3]);
    assert_eq!(p.shield.gamma, 0.5);
    assert_eq!(p.shield.scan.crop_radius, None);
    assert_eq!(p.shield.scan.angular_bins, Some(360));
    assert_eq!(p.shield.u_max, Some(vec![1.0, 0.5]));
    assert_eq!(p.topics.scan.as_deref(), Some("/front/scan"));
    assert_eq!(p.mount.translation[0], 0.25);
    assert_eq!(p.domain_id, 7);
    // the command line wins, remaps apply to topic names
    let path = std::env::temp_dir().join(format!("shieldnav-ros2-test-{}.yaml", std::process::id()));
    std::fs::write(&path, yaml).unwrap();
    let args = ["--params", path.to_str().unwrap(), "--ros-args", "-p", "gamma:=0.7", "-p", "method:=braking", "-r", "/front/scan:=/robot/scan", "-r", "/odom:=/robot/odom"];
    let p = RawParams::from_args(args.iter().map(|s| s.to_string())).unwrap().build().unwrap();
    std::fs::remove_file(&path).ok();
    assert_eq!(p.shield.gamma, 0.7);
    assert_eq!(p.shield.method.name(), "braking");
    assert_eq!(p.topics.scan.as_deref(), Some("/robot/scan"));
    assert_eq!(p.topics.odom.as_deref(), Some("/robot/odom"));
}

#[test]
fn bad_parameters_are_named() {
    let cases: &[(&str, Value, &str)] = &[
        ("gamma", Value::Float(-1.0), "gamma"),
        ("kappa", Value::Str("high".into()), "kappa"),
        ("semi_axes", Value::List(vec![Value::Float(0.9)]), "semi_axes"),
        ("u_max", Value::List(vec![Value::Float(1.0), Value::Float(1.0), Value::Float(1.0)]), "u_max"),
        ("method", Value::Str("magic".into()), "method"),
        ("voxel_size", Value::Float(0.0), "voxel_size"),
        ("angular_bins", Value::Int(2), "angular_bins"),
        ("dt", Value::Float(5.0), "dt"),
        ("brake_margin", Value::Float(-0.1), "brake_margin"),
        ("scan_timeout", Value::Float(0.0), "scan_timeout"),
        ("mount_yaw", Value::Float(f64::NAN), "mount_yaw"),
        ("domain_id", Value::Int(999), "domain_id"),
        ("gama", Value::Float(1.0), "gama"),
    ];
    for (name, value, named) in cases {
        let mut raw = RawParams::default();
        raw.set(name, value.clone());
        let err = raw.build().unwrap_err();
        assert_eq!(&err.name, named, "{name} = {value}: {err}");
    }
    // the braking shield needs odometry
    let mut raw = RawParams::default();
    raw.set("odom_topic", Value::Str(String::new()));
    assert_eq!(raw.build().unwrap_err().name, "odom_topic");
    assert!(RawParams::default().load_yaml("other_node:\n  ros__parameters: {}\n", "f.yaml", "shieldnav_shield").is_err());
}

#[test]
fn command_line_values_read_as_yaml() {
    assert_eq!(parse_value("1.5"), Value::Float(1.5));
    assert_eq!(parse_value("3"), Value::Int(3));
    assert_eq!(parse_value("true"), Value::Bool(true));
    assert_eq!(parse_value("[0.9, 0.45]"), Value::List(vec![Value::Float(0.9), Value::Float(0.45)]));
    assert_eq!(parse_value("null"), Value::None);
    assert_eq!(parse_value("/scan"), Value::Str("/scan".into()));
}

#[test]
fn the_example_parameter_file_holds_the_defaults() {
    let mut raw = RawParams::default();
    raw.load_yaml(include_str!("../examples/shieldnav_shield.yaml"), "shieldnav_shield.yaml", "shieldnav_shield").unwrap();
    let p = raw.build().unwrap();
    let d = RawParams::default().build().unwrap();
    assert_eq!(p.shield, d.shield);
    assert_eq!(p.topics, d.topics);
    assert_eq!((p.scan_timeout, p.command_timeout, p.odom_timeout, p.watchdog_period), (d.scan_timeout, d.command_timeout, d.odom_timeout, d.watchdog_period));
    assert_eq!(p.mount, d.mount);
    assert_eq!((p.cmd_stamped, &p.base_frame), (d.cmd_stamped, &d.base_frame));
}

/// A 1024-beam scan from `x` on the axis of a corridor 2 m wide, closed 6 m ahead of the start
/// and 3 m behind: range noise of ±1 cm, every 37th beam a NaN dropout, 8 m range.
fn corridor_scan(x: f64, seed: &mut u64) -> LaserScan {
    let mut beam = 0usize;
    ring_scan(8.0, |a| {
        beam += 1;
        if (beam - 1).is_multiple_of(37) {
            return f32::NAN;
        }
        let (s, c) = a.sin_cos();
        let mut r = f64::INFINITY;
        if s.abs() > 1e-9 {
            r = r.min(1.0 / s.abs());
        }
        if c > 1e-9 {
            r = r.min((6.0 - x) / c);
        } else if c < -1e-9 {
            r = r.min((x + 3.0) / -c);
        }
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let noise = ((*seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.02;
        if r > 8.0 {
            f32::INFINITY
        } else {
            (r + noise) as f32
        }
    })
}

#[test]
fn a_scan_sequence_down_a_corridor_passes_and_the_robot_stops_before_the_end_wall() {
    // closed loop at the braking model's 50 Hz: the body is the tracker the model describes
    let mut n = node("braking");
    let tracker = shieldnav_core::robot::TrackerConfig::default();
    let dt = 0.02;
    let gain = tracker.gain(dt);
    let (mut x, mut v, mut seed) = (0.0f64, [0.0f64; 3], 7u64);
    let t0 = Instant::now();
    let mut braked_or_slowed = 0;
    for k in 0..500 {
        let t = t0 + Duration::from_secs_f64(k as f64 * dt);
        n.on_scan(&corridor_scan(x, &mut seed), t).unwrap();
        let mut odom = Odometry::default();
        odom.twist.twist.linear.x = v[0];
        odom.twist.twist.linear.y = v[1];
        odom.twist.twist.angular.z = v[2];
        n.on_odometry(&odom, t).unwrap();
        let out = n.on_nominal(&forward(1.5), t);
        assert!(out.state.ok, "step {k} at x = {x:.3}: {:?}", out.state.reason);
        braked_or_slowed += (out.command.linear.x < 1.5 - 1e-9) as usize;
        let (next, _) = tracker.next_velocity(v, [out.command.linear.x, out.command.linear.y, out.command.angular.z], gain, dt);
        v = next;
        x += v[0] * dt;
        // the footprint (its nose 0.55 m ahead of the centre) keeps off the end wall by the
        // check's clearance less the scan's ±1 cm noise
        assert!(x + 0.55 < 6.0 - 0.025, "step {k}: the footprint reaches the wall at x = {x:.3}");
    }
    assert!(x > 3.5, "the robot drives down the corridor (x = {x:.3})");
    assert!(v[0].abs() < 0.05, "and stands before the end wall (v = {:.3})", v[0]);
    assert!(braked_or_slowed > 0);
}

#[test]
fn the_footprint_is_read_in_nav2s_convention_and_decides_what_passes() {
    let build = |v: Value| {
        let mut raw = RawParams::default();
        raw.set("footprint", v);
        raw.build()
    };
    let nav2 = build(Value::Str("[[0.55, 0.25], [-0.55, 0.25], [-0.55, -0.25], [0.55, -0.25]]".into())).unwrap();
    assert_eq!(nav2.shield.braking.footprint, RawParams::default().build().unwrap().shield.braking.footprint);
    let list = Value::List([[0.7, 0.0], [0.0, 0.4], [-0.5, 0.0], [0.0, -0.4]].iter().map(|p| Value::List(vec![Value::Float(p[0]), Value::Float(p[1])])).collect());
    assert_eq!(build(list).unwrap().shield.braking.footprint.vertices().len(), 4);
    for bad in ["[[0.5, 0.2], [0.5, -0.2]]", "[[1, 1], [2, 1], [2, 2]]", "0.5", "[[0.5, 0.2, 1], [-0.5, 0.2], [0, -1]]", "[[a, b]]"] {
        let e = build(Value::Str(bad.into())).unwrap_err().to_string();
        assert!(e.contains("footprint"), "{bad}: {e}");
    }
    // a wall 0.58 m ahead: 0.03 m from the default footprint's nose, within its 0.04 m clearance
    let mut n = node("braking");
    let out = step(&mut n, &wall_scan(0.58), &forward(1.0), Instant::now());
    assert!(out.state.ok && out.command.linear.x <= 1e-9, "{:?} {:?}", out.command, out.state);
    // a shorter footprint lets the same command pass
    let mut raw = RawParams::default();
    raw.set("method", Value::Str("braking".into())).set("footprint", Value::Str("[[0.3, 0.25], [-0.55, 0.25], [-0.55, -0.25], [0.3, -0.25]]".into()));
    let mut short = ShieldNode::new(raw.build().unwrap()).unwrap();
    let out = step(&mut short, &wall_scan(0.58), &forward(1.0), Instant::now());
    assert!(out.state.ok && out.command.linear.x > 0.0, "{:?}", out.command);
}

#[test]
fn an_imus_yaw_rate_replaces_odometrys_and_the_translation_stays_odometrys() {
    use shieldnav_ros2::msg::{Imu, Vector3};
    let moving = |wz: f64| {
        let mut o = Odometry::default();
        o.twist.twist.linear.x = 0.8;
        o.twist.twist.angular.z = wz;
        o
    };
    let answer = |imu: Option<f64>, odom_wz: f64| {
        let mut raw = RawParams::default();
        if imu.is_some() {
            raw.set("imu_topic", Value::Str("/imu".into()));
        }
        let mut n = ShieldNode::new(raw.build().unwrap()).unwrap();
        let t = Instant::now();
        // a wall along the left side, 0.12 m off the body's flank
        let side = ring_scan(30.0, |a| if a.sin() > 0.05 { (0.37 / a.sin()).min(1e3) as f32 } else { f32::INFINITY });
        n.on_scan(&side, t).unwrap();
        n.on_odometry(&moving(odom_wz), t).unwrap();
        if let Some(wz) = imu {
            n.on_imu(&Imu { angular_velocity: Vector3 { x: 0.0, y: 0.0, z: wz }, ..Default::default() }, t).unwrap();
        }
        let out = n.on_nominal(&forward(1.0), t);
        assert!(out.state.ok, "{:?}", out.state);
        out.command
    };
    let with_imu = answer(Some(1.4), 0.0);
    assert_eq!(with_imu, answer(None, 1.4), "the IMU's yaw rate is the one the braking check takes");
    assert_ne!(with_imu, answer(None, 0.0), "the yaw rate changes the command here (the test can tell)");
}

#[test]
fn the_held_scan_is_moved_by_the_odometry_since_it_arrived() {
    // h_min, the nearest point's barrier: the scans' beams fall elsewhere on the moved wall
    let h = |out: &Output| out.state.h_min.unwrap_or_else(|| panic!("no h_min: {:?}", out.state));
    let at_rest = |scan: &LaserScan| {
        let mut n = node("composite");
        h(&step(&mut n, scan, &forward(0.2), Instant::now()))
    };
    let t0 = Instant::now();
    // 0.3 s at 1 m/s: the wall 1.5 m ahead when the scan arrived is 1.2 m ahead
    let mut n = node("composite");
    let mut odom = Odometry::default();
    odom.twist.twist.linear.x = 1.0;
    n.on_odometry(&odom, t0).unwrap();
    n.on_scan(&wall_scan(1.5), t0).unwrap();
    n.on_odometry(&odom, t0 + Duration::from_millis(200)).unwrap();
    let moved = h(&n.on_nominal(&forward(0.2), t0 + Duration::from_millis(300)));
    let (near, far) = (at_rest(&wall_scan(1.2)), at_rest(&wall_scan(1.5)));
    assert!((moved - near).abs() < 1e-3 * (far - near).abs(), "h_min {moved}: the wall at 1.2 m gives {near}, at 1.5 m {far}");
    // turning at 0.5 rad/s for 0.4 s: the wall is turned by −0.2 rad about the body
    let mut n = node("composite");
    let mut turning = Odometry::default();
    turning.twist.twist.angular.z = 0.5;
    n.on_odometry(&turning, t0).unwrap();
    n.on_scan(&wall_scan(1.5), t0).unwrap();
    let moved = h(&n.on_nominal(&forward(0.2), t0 + Duration::from_millis(400)));
    let turned = at_rest(&ring_scan(30.0, |a| if (a + 0.2).cos() > 0.05 { (1.5 / (a + 0.2).cos()).min(1e3) as f32 } else { f32::INFINITY }));
    assert!((moved - turned).abs() < 0.02 * (far - turned).abs(), "h_min {moved}: the turned wall gives {turned}, the wall as scanned {far}");
}

#[test]
fn a_mover_coming_at_the_robot_is_tracked_and_slows_it_more_than_a_wall_would() {
    // a 0.3 m object coming head-on at 1.5 m/s from 5 m, scans at 10 Hz, the robot asked for
    // 1 m/s forward
    let disc = |d: f64| {
        ring_scan(30.0, move |a| {
            // the ray (r cos a, r sin a) against the circle of radius 0.15 about (d, 0)
            let b = d * a.cos();
            let disc = b * b - (d * d - 0.15 * 0.15);
            if disc >= 0.0 && b > 0.0 {
                (b - disc.sqrt()) as f32
            } else {
                f32::INFINITY
            }
        })
    };
    let run = |track: bool| {
        let mut raw = RawParams::default();
        raw.set("track_movers", Value::Bool(track));
        let mut n = ShieldNode::new(raw.build().unwrap()).unwrap();
        let t0 = Instant::now();
        let mut last = None;
        for k in 0..8 {
            let t = t0 + Duration::from_millis(100 * k);
            n.on_scan(&disc(5.0 - 0.15 * k as f64), t).unwrap();
            n.on_odometry(&at_rest(), t).unwrap();
            last = Some(n.on_nominal(&forward(1.0), t));
        }
        last.unwrap()
    };
    let (tracked, static_) = (run(true), run(false));
    assert!(tracked.state.ok && static_.state.ok);
    assert_eq!((tracked.state.movers, static_.state.movers), (1, 0), "{:?}", tracked.state);
    assert!(tracked.command.linear.x < static_.command.linear.x - 0.1, "tracked {:?}, as static {:?}", tracked.command, static_.command);
}
