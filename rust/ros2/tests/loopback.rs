//! The node over DDS on this host: a fake robot and planner (the same client library) publish
//! scans, odometry and nominal commands and read the node's command and state. Discovery runs
//! over RustDDS's same-host loopback unicast (and multicast where the network has it), on a
//! domain of its own.

mod common;

use common::{forward, wall_scan};
use std::time::{Duration, Instant};

use ros2_client::{NodeName, NodeOptions, Publisher, Subscription};
use shieldnav_ros2::msg::{Header, LaserScan, Odometry, PointCloud2, PointField, StringMsg, Twist};
use shieldnav_ros2::params::{RawParams, Value};
use shieldnav_ros2::ros::{advertise, command_out_qos, context, sensor_qos, spawn, subscribe};

/// A wall of points across the path at `x = d`, 1 m wide, at two heights (`x`, `y`, `z` float32).
fn wall_cloud(d: f32) -> PointCloud2 {
    let field = |name: &str, offset| PointField { name: name.into(), offset, datatype: PointField::FLOAT32, count: 1 };
    let mut data = Vec::new();
    let mut n = 0;
    for k in -20..=20 {
        for z in [0.1f32, 0.5] {
            for v in [d, k as f32 * 0.025, z] {
                data.extend_from_slice(&v.to_le_bytes());
            }
            n += 1;
        }
    }
    PointCloud2 {
        header: Header { frame_id: "lidar".into(), ..Default::default() },
        height: 1,
        width: n,
        fields: vec![field("x", 0), field("y", 4), field("z", 8)],
        is_bigendian: false,
        point_step: 12,
        row_step: 12 * n,
        data,
        is_dense: true,
    }
}

struct Fake {
    scan: Publisher<LaserScan>,
    cloud: Publisher<PointCloud2>,
    bad_scan: Publisher<Twist>,
    odom: Publisher<Odometry>,
    nominal: Publisher<Twist>,
    cmd: Subscription<Twist>,
    state: Subscription<StringMsg>,
    last_cmd: Option<Twist>,
}

impl Fake {
    /// Reads what arrived; returns the states (as JSON values) in order.
    fn drain(&mut self) -> Vec<serde_json::Value> {
        while let Ok(Some((c, _))) = self.cmd.take() {
            self.last_cmd = Some(c);
        }
        let mut out = Vec::new();
        while let Ok(Some((s, _))) = self.state.take() {
            out.push(serde_json::from_str(&s.data).expect("the state is JSON"));
        }
        out
    }

    /// Publishes with `send` every 20 ms until `until` accepts a state, or `timeout`.
    fn until(&mut self, what: &str, timeout: Duration, mut send: impl FnMut(&Fake), until: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
        let start = Instant::now();
        let mut last = None;
        while start.elapsed() < timeout {
            send(self);
            std::thread::sleep(Duration::from_millis(20));
            for s in self.drain() {
                if until(&s) {
                    return s;
                }
                last = Some(s);
            }
        }
        panic!("{what}: no such state within {timeout:?}; last state {last:?}");
    }
}

fn reason(s: &serde_json::Value) -> &str {
    s["reason"].as_str().unwrap_or("")
}

#[test]
fn the_node_over_loopback_dds() {
    // a domain of this process's own: parallel test runs on the host do not meet
    let domain = 100 + (std::process::id() % 100) as i64;
    let mut raw = RawParams::default();
    raw.set("domain_id", Value::Int(domain)).set("method", Value::Str("braking".into()));
    raw.set("scan_timeout", Value::Float(0.5)).set("command_timeout", Value::Float(0.5)).set("watchdog_rate", Value::Float(20.0));
    raw.set("cloud_topic", Value::Str("/points".into()));
    let node = spawn(raw.build().expect("parameters")).expect("the node starts");

    let ctx = context(domain as u16).expect("participant");
    let mut n = ctx.new_node(NodeName::new("/", "fake_robot").unwrap(), NodeOptions::new().enable_rosout(false)).expect("node");
    let mut fake = Fake {
        scan: advertise(&mut n, "/scan", "sensor_msgs", "LaserScan", sensor_qos()).unwrap(),
        bad_scan: advertise(&mut n, "/scan", "sensor_msgs", "LaserScan", sensor_qos()).unwrap(),
        cloud: advertise(&mut n, "/points", "sensor_msgs", "PointCloud2", sensor_qos()).unwrap(),
        odom: advertise(&mut n, "/odom", "nav_msgs", "Odometry", sensor_qos()).unwrap(),
        nominal: advertise(&mut n, "/cmd_vel_nominal", "geometry_msgs", "Twist", command_out_qos()).unwrap(),
        cmd: subscribe(&mut n, "/cmd_vel", "geometry_msgs", "Twist", command_out_qos()).unwrap(),
        state: subscribe(&mut n, "/shieldnav/state", "std_msgs", "String", command_out_qos()).unwrap(),
        last_cmd: None,
    };
    let free = wall_scan(50.0);
    let wall = wall_scan(1.0);

    // discovery, then free space: the command passes (generous: discovery can take seconds)
    let s = fake.until(
        "free space passes",
        Duration::from_secs(60),
        |f| {
            let _ = f.scan.publish(free.clone());
            let _ = f.odom.publish(Odometry::default());
            let _ = f.nominal.publish(forward(0.5));
        },
        |s| s["ok"] == true,
    );
    assert!((s["command"][0].as_f64().unwrap() - 0.5).abs() < 1e-9, "{s}");

    // a wall 1 m ahead: the forward command is slowed to the tight-space speed (0.5 m/s)
    let s = fake.until(
        "a wall ahead",
        Duration::from_secs(20),
        |f| {
            let _ = f.scan.publish(wall.clone());
            let _ = f.odom.publish(Odometry::default());
            let _ = f.nominal.publish(forward(1.0));
        },
        |s| s["ok"] == true && s["nominal"][0] == 1.0 && s["points_used"].as_u64().unwrap_or(0) > 0,
    );
    assert!(s["command"][0].as_f64().unwrap() <= 0.5 + 1e-9, "forward at a wall: {s}");
    assert_eq!(s["active"], true);
    let deadline = Instant::now() + Duration::from_secs(10);
    while fake.last_cmd.is_none_or(|c| c.linear.x > 0.5 + 1e-9) && Instant::now() < deadline {
        let _ = fake.nominal.publish(forward(1.0));
        let _ = fake.scan.publish(wall.clone());
        let _ = fake.odom.publish(Odometry::default());
        std::thread::sleep(Duration::from_millis(20));
        fake.drain();
    }
    assert!(fake.last_cmd.unwrap().linear.x <= 0.5 + 1e-9, "the robot hears the slowed command: {:?}", fake.last_cmd);

    // the scan stops coming: zero, "stale scan"
    let s = fake.until(
        "a stale scan",
        Duration::from_secs(20),
        |f| {
            let _ = f.odom.publish(Odometry::default());
            let _ = f.nominal.publish(forward(0.5));
        },
        |s| reason(s).contains("stale scan"),
    );
    assert_eq!(s["ok"], false);
    assert_eq!(s["command"], serde_json::json!([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));

    // a malformed scan (NaN angles): rejected, zero
    let mut nan = free.clone();
    nan.angle_min = f32::NAN;
    let s = fake.until(
        "a malformed scan",
        Duration::from_secs(20),
        |f| {
            let _ = f.scan.publish(nan.clone());
            let _ = f.odom.publish(Odometry::default());
            let _ = f.nominal.publish(forward(0.5));
        },
        |s| reason(s).contains("scan rejected"),
    );
    assert!(reason(&s).contains("not finite"), "{s}");

    // bytes that are not a LaserScan at all (a Twist on the scan topic): rejected, zero
    let s = fake.until(
        "an undecodable scan",
        Duration::from_secs(20),
        |f| {
            let _ = f.bad_scan.publish(forward(0.1));
            let _ = f.odom.publish(Odometry::default());
            let _ = f.nominal.publish(forward(0.5));
        },
        |s| s["ok"] == false && reason(s).contains("scan rejected"),
    );
    assert_eq!(s["command"][0], 0.0);

    // a point cloud instead of the scan: read by field name, a wall ahead slows the robot
    let cloud = wall_cloud(1.0);
    let s = fake.until(
        "a point cloud",
        Duration::from_secs(20),
        |f| {
            let _ = f.cloud.publish(cloud.clone());
            let _ = f.odom.publish(Odometry::default());
            let _ = f.nominal.publish(forward(1.0));
        },
        |s| s["ok"] == true && s["scan_frame"] == "lidar",
    );
    assert_eq!(s["points_in_scan"], 82, "{s}");
    assert!(s["command"][0].as_f64().unwrap() <= 0.5 + 1e-9, "forward at a wall of points: {s}");

    // the planner goes quiet: the watchdog sends zero, "stale nominal command"
    let s = fake.until(
        "a missing command",
        Duration::from_secs(20),
        |f| {
            let _ = f.scan.publish(free.clone());
            let _ = f.odom.publish(Odometry::default());
        },
        |s| reason(s).contains("stale nominal command"),
    );
    assert_eq!(s["ok"], false);
    let _ = fake.drain();
    drop(fake);
    node.stop().expect("the node stops cleanly");
}

#[test]
fn stamped_commands_in_and_out_over_loopback_dds() {
    use shieldnav_ros2::msg::{Time, TwistStamped};
    let domain = 1 + (std::process::id() % 99) as i64;
    let mut raw = RawParams::default();
    raw.set("domain_id", Value::Int(domain)).set("nominal_stamped", Value::Bool(true)).set("cmd_stamped", Value::Bool(true));
    raw.set("base_frame", Value::Str("chassis".into())).set("watchdog_rate", Value::Float(20.0));
    let dir = std::env::temp_dir().join(format!("shieldnav-record-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let recording = dir.join("node.mcap");
    let _ = std::fs::remove_file(&recording);
    raw.set("record", Value::Str(recording.display().to_string()));
    let node = spawn(raw.build().expect("parameters")).expect("the node starts");
    // a second node may not write over the recording
    let e = spawn(raw.build().unwrap()).err().expect("an existing recording is refused");
    assert!(e.contains("node.mcap") && e.contains("cannot create"), "{e}");

    let ctx = context(domain as u16).expect("participant");
    let mut n = ctx.new_node(NodeName::new("/", "fake_planner").unwrap(), NodeOptions::new().enable_rosout(false)).expect("node");
    let scan: Publisher<LaserScan> = advertise(&mut n, "/scan", "sensor_msgs", "LaserScan", sensor_qos()).unwrap();
    let odom: Publisher<Odometry> = advertise(&mut n, "/odom", "nav_msgs", "Odometry", sensor_qos()).unwrap();
    let nominal: Publisher<TwistStamped> = advertise(&mut n, "/cmd_vel_nominal", "geometry_msgs", "TwistStamped", command_out_qos()).unwrap();
    let cmd: Subscription<TwistStamped> = subscribe(&mut n, "/cmd_vel", "geometry_msgs", "TwistStamped", command_out_qos()).unwrap();
    let stamp = Time { sec: 42, nanosec: 7 };
    let planned = TwistStamped { header: Header { stamp, frame_id: "base_link".into() }, twist: forward(0.5) };
    let free = wall_scan(50.0);

    // the answer to a stamped nominal command carries its stamp, in the body's frame
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut answer = None;
    while answer.is_none() && Instant::now() < deadline {
        let _ = scan.publish(free.clone());
        let _ = odom.publish(Odometry::default());
        let _ = nominal.publish(planned.clone());
        std::thread::sleep(Duration::from_millis(20));
        while let Ok(Some((c, _))) = cmd.take() {
            if c.header.stamp == stamp && c.twist.linear.x > 0.0 {
                answer = Some(c);
            }
        }
    }
    let c = answer.expect("a stamped command answering the stamped nominal one within 60 s");
    assert_eq!(c.header.frame_id, "chassis");
    assert!((c.twist.linear.x - 0.5).abs() < 1e-9, "{c:?}");

    // the planner goes quiet: the watchdog's zero commands are stamped at sending
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut zero = None;
    while zero.is_none() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
        while let Ok(Some((c, _))) = cmd.take() {
            if c.header.stamp != stamp {
                zero = Some(c);
            }
        }
    }
    let z = zero.expect("a zero command from the watchdog within 20 s");
    assert_eq!(z.twist, Twist::default());
    assert!(z.header.stamp.sec > 1_600_000_000 && z.header.frame_id == "chassis", "{z:?}");
    node.stop().expect("the node stops cleanly");

    // the node's recording: the ros2 profile, ros2msg schemas, CDR; what it heard and sent
    let bytes = std::fs::read(&recording).expect("the recording");
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    let mut topics: Vec<(String, String, String, String)> = summary
        .channels
        .values()
        .map(|c| {
            let s = c.schema.as_ref().unwrap();
            (c.topic.clone(), c.message_encoding.clone(), s.name.clone(), s.encoding.clone())
        })
        .collect();
    topics.sort();
    assert_eq!(
        topics,
        [
            ("/cmd_vel".into(), "cdr".into(), "geometry_msgs/msg/TwistStamped".into(), "ros2msg".into()),
            ("/cmd_vel_nominal".into(), "cdr".into(), "geometry_msgs/msg/TwistStamped".into(), "ros2msg".into()),
            ("/shieldnav/state".into(), "cdr".into(), "std_msgs/msg/String".into(), "ros2msg".into()),
        ]
    );
    let decode = |data: &[u8]| {
        assert_eq!(&data[..4], &[0, 1, 0, 0], "CDR little-endian encapsulation");
        cdr_encoding::from_bytes::<TwistStamped, byteorder::LittleEndian>(&data[4..]).unwrap().0
    };
    let (mut heard, mut sent, mut states) = (0, Vec::new(), 0);
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        match m.channel.topic.as_str() {
            "/cmd_vel_nominal" => {
                assert_eq!(decode(&m.data), planned);
                heard += 1;
            }
            "/cmd_vel" => sent.push(decode(&m.data)),
            _ => {
                let (s, _) = cdr_encoding::from_bytes::<StringMsg, byteorder::LittleEndian>(&m.data[4..]).unwrap();
                assert!(serde_json::from_str::<serde_json::Value>(&s.data).is_ok());
                states += 1;
            }
        }
    }
    assert!(heard > 0 && states == sent.len());
    assert!(sent.iter().any(|c| c.header.stamp == stamp && c.header.frame_id == "chassis" && (c.twist.linear.x - 0.5).abs() < 1e-9));
    assert!(sent.iter().any(|c| c.header.stamp != stamp && c.twist == Twist::default()), "the watchdog's zeros are recorded");
    std::fs::remove_dir_all(&dir).ok();
}
