//! The running world: determinism, scan timing, odometry faults, moving obstacles, contacts.

use shieldnav_core::robot::footprint_segment_distance;
#[path = "common/distance.rs"]
mod distance;
use distance::reference_distance;
use shieldnav_core::sensors::LidarConfig;
use shieldnav_core::sim::{World, WorldConfig};

fn noisy(seed: u64) -> WorldConfig {
    let mut c = WorldConfig { seed, ..Default::default() };
    c.lidar.dropout = 0.05;
    c
}

fn run(world: &mut World, steps: usize, cmd: [f64; 3]) -> Vec<u64> {
    let mut trace = Vec::new();
    for _ in 0..steps {
        let o = world.step(cmd).unwrap();
        trace.extend([o.true_pose.x, o.true_pose.y, o.true_pose.yaw, o.estimated_pose.x].map(f64::to_bits));
        if o.scanned {
            trace.extend(world.scan().ranges.iter().map(|r| r.to_bits()));
        }
    }
    trace
}

#[test]
fn same_seed_same_trajectory_and_scans_bit_for_bit_other_seed_differs() {
    let mut scenario = shieldnav_core::world::preset("dynamic_obstacles").unwrap();
    scenario.odometry.translation_noise = 0.02;
    let mk = |seed| World::new(scenario.clone(), noisy(seed)).unwrap();
    let (mut a, mut b, mut c) = (mk(3), mk(3), mk(4));
    let (ta, tb, tc) = (run(&mut a, 200, [0.6, 0.0, 0.1]), run(&mut b, 200, [0.6, 0.0, 0.1]), run(&mut c, 200, [0.6, 0.0, 0.1]));
    assert_eq!(ta, tb);
    assert_ne!(ta, tc);
}

#[test]
fn scans_come_at_the_lidar_rate_not_the_control_rate() {
    let cfg = WorldConfig { lidar: LidarConfig { rate_hz: 20.0, ..Default::default() }, dt: 0.01, ..Default::default() };
    let mut w = World::from_preset("constricted_passage", cfg).unwrap();
    let scans = (0..100).filter(|_| w.step([0.0, 0.0, 0.0]).unwrap().scanned).count();
    assert_eq!(scans, 20); // 1 s at 20 Hz
}

#[test]
fn odometry_jump_moves_the_estimate_not_the_lidar() {
    let mut w = World::from_preset("odometry_jump", WorldConfig { lidar: LidarConfig { range_noise_std: 0.0, ..Default::default() }, ..Default::default() }).unwrap();
    let mut before = None;
    for _ in 0..1100 {
        let o = w.step([0.5, 0.0, 0.0]).unwrap();
        if (o.time - 19.9).abs() < 1e-9 {
            before = Some((o, w.scan().ranges.clone()));
        }
    }
    let (b, ranges_before) = before.unwrap();
    assert!((b.estimated_pose.x - b.true_pose.x).abs() < 1e-6);
    let t = w.true_pose();
    let e = w.estimated_pose();
    assert!((e.x - t.x - 100.0).abs() < 1e-6 && (e.y - t.y + 1.5).abs() < 1e-6, "true {t:?} est {e:?}");
    // the LIDAR still sees the corridor walls 1.2 m to each side of the true pose
    let n = ranges_before.len();
    for r in [&ranges_before, &w.scan().ranges] {
        assert!((r[n / 4] - 1.2).abs() < 0.02 || r[n / 4] > 1.2, "left {}", r[n / 4]);
        assert!((r[3 * n / 4] - 1.2).abs() < 0.02 || r[3 * n / 4] > 1.2);
    }
}

#[test]
fn pushed_chair_and_opening_door_appear_in_the_scan() {
    let cfg = WorldConfig { lidar: LidarConfig { range_noise_std: 0.0, ..Default::default() }, ..Default::default() };
    let mut w = World::from_preset("dynamic_obstacles", cfg).unwrap();
    // the robot waits at (1, 0) facing +x; beam 5 (1.76° left) looks down the corridor at the chair
    let mut ahead = Vec::new();
    for _ in 0..(24.0 / 0.02) as usize {
        let o = w.step([0.0, 0.0, 0.0]).unwrap();
        if o.scanned {
            ahead.push((o.time, w.scan().ranges[5]));
        }
    }
    let at = |t: f64| ahead.iter().find(|(s, _)| (*s - t).abs() < 0.051).unwrap().1;
    // the 0.5 m chair slides from x = 16.6 to 14.6 (y 0.6 -> 0.45) between 9 and 11 s: the beam
    // meets its near face, 2 m closer afterwards
    let az = 5.0 * std::f64::consts::TAU / 1024.0;
    assert!((at(8.0) - (16.35 - 1.0) / az.cos()).abs() < 1e-6, "{}", at(8.0));
    assert!((at(12.0) - (14.35 - 1.0) / az.cos()).abs() < 1e-6, "{}", at(12.0));
}

#[test]
fn driving_into_the_cabinet_is_a_contact_judged_on_the_footprint() {
    let cfg = WorldConfig { lidar: LidarConfig { range_noise_std: 0.0, ..Default::default() }, ..Default::default() };
    let mut w = World::from_preset("constricted_passage", cfg).unwrap();
    // from (1, 0) head diagonally up-right into the cabinet at x in [4.2, 5], y >= 0.3
    let mut first_contact = None;
    for k in 0..600 {
        let o = w.step([1.0, 0.2, 0.0]).unwrap();
        let exact = w.walls_now().iter().map(|s| reference_distance(&w.config().robot, o.true_pose, s)).fold(f64::INFINITY, f64::min);
        if o.contacts.any() {
            assert!(exact < 2e-3, "step {k}: rapier contact but the footprint is {exact} m clear");
            first_contact.get_or_insert(k);
        } else {
            assert!(exact > 0.0, "step {k}: footprint touches a wall, no contact reported");
        }
    }
    assert!(first_contact.is_some(), "never reached the cabinet");
}

/// A world asked for its clearance each step skips the contact solver far from walls: the
/// trajectory is the solver's to rounding, every free step ends clear of walls and of the
/// pushed chair and opening door of `dynamic_obstacles`, contacts are found as often, and
/// near walls the solver runs.
#[test]
fn free_steps_far_from_walls_change_nothing_but_rounding() {
    let cfg = WorldConfig { lidar: LidarConfig { range_noise_std: 0.0, ..Default::default() }, ..Default::default() };
    for (preset, steps) in [("constricted_passage", 600), ("dynamic_obstacles", 1500)] {
        let mut solver = World::from_preset(preset, cfg).unwrap();
        let mut free = World::from_preset(preset, cfg).unwrap();
        let (mut contacts_a, mut contacts_b, mut worst) = (0, 0, 0.0f64);
        for k in 0..steps {
            let t = k as f64 * 0.02;
            let cmd = if preset == "constricted_passage" { [1.0, 0.2, 0.4 * (2.5 * t).sin()] } else { [0.3 * (0.7 * t).cos(), 0.6 * (0.45 * t).sin(), 1.4 * (0.9 * t).sin()] };
            let a = solver.step(cmd).unwrap();
            let before = free.free_steps();
            let b = free.step(cmd).unwrap();
            free.clearance();
            worst = worst.max((a.true_pose.x - b.true_pose.x).abs()).max((a.true_pose.y - b.true_pose.y).abs()).max((a.true_pose.yaw - b.true_pose.yaw).abs());
            if free.free_steps() > before {
                // a free step ends clear of everything by most of the margin
                let exact = free.walls_now().iter().map(|s| footprint_segment_distance(&free.config().robot, b.true_pose, s)).fold(f64::INFINITY, f64::min);
                assert!(!b.contacts.any() && exact > 0.04, "{preset} step {k}: a free step ended {exact} m from a wall");
            }
            contacts_a += a.contacts.any() as i32;
            contacts_b += b.contacts.any() as i32;
        }
        assert_eq!(solver.free_steps(), 0);
        let n = free.free_steps();
        assert!(n > 100 && n < steps as u64 - 50, "{preset}: {n} free steps of {steps}");
        assert!(contacts_a > 20 && (contacts_a - contacts_b).abs() <= 2, "{preset}: contact steps {contacts_a} vs {contacts_b}");
        assert!(worst < 1e-4, "{preset}: trajectories apart by {worst}");
    }
}

/// `World::clearance` (an index search, then a kept set of walls while the robot moves
/// within a budget) equals the brute-force minimum over every wall, step after step.
#[test]
fn clearance_equals_brute_force_along_trajectories() {
    use shieldnav_core::world::generate::GeneratorConfig;
    use shieldnav_core::world::RosMapOptions;
    let map = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../envs/shieldnav/maps/mit_building31/building_31.yaml");
    let worlds = vec![
        World::from_preset("dynamic_obstacles", WorldConfig::default()).unwrap(),
        World::from_procedural(3, &GeneratorConfig::default(), WorldConfig::default()).unwrap(),
        World::from_ros_map(&map, &RosMapOptions::default(), WorldConfig::default()).unwrap(),
    ];
    for mut w in worlds {
        let shape = w.config().robot;
        let mut checked = 0;
        for k in 0..1500 {
            // sweep, turn and back off, so that the robot meets walls and rotates near them
            let t = k as f64 * 0.02;
            let cmd = [1.2 * (0.7 * t).cos(), 0.6 * (0.45 * t).sin(), 1.4 * (0.9 * t).sin()];
            w.step(cmd).unwrap();
            let pose = w.true_pose();
            let brute = w.walls_now().iter().map(|s| footprint_segment_distance(&shape, pose, s)).fold(f64::INFINITY, f64::min);
            let got = w.clearance();
            assert!((got - brute).abs() < 1e-12, "{}: step {k}: clearance {got} vs brute force {brute}", w.scenario().name);
            checked += (brute < 1.0) as usize;
        }
        assert!(checked > 50, "{}: the trajectory should come near walls ({checked} steps within 1 m)", w.scenario().name);
    }
}

/// A world of few walls is scanned by sweeping every wall, not through its bucket index (see
/// `SCAN_ALL_WALLS_MAX`): its scans are the indexed scan's, bit for bit, while the robot turns
/// and the chair and the door move.
#[test]
fn small_worlds_scan_as_the_index_does() {
    use rand::SeedableRng;
    use shieldnav_core::sensors::{Lidar, Scan};
    use shieldnav_core::sim::SCAN_ALL_WALLS_MAX;
    use shieldnav_core::world::SegmentIndex;
    let cfg = WorldConfig { lidar: LidarConfig { range_noise_std: 0.0, ..Default::default() }, ..Default::default() };
    let mut w = World::from_preset("dynamic_obstacles", cfg).unwrap();
    assert!(w.scenario().map.segments.len() <= SCAN_ALL_WALLS_MAX && !w.scenario().obstacles.is_empty());
    let index = SegmentIndex::new(w.scenario().map.segments.clone(), 2.0).unwrap();
    let mut lidar = Lidar::new(cfg.lidar).unwrap();
    let (mut scan, mut moving, mut rng) = (Scan::default(), Vec::new(), rand_chacha::ChaCha8Rng::seed_from_u64(0));
    let bits = |s: &Scan| s.ranges.iter().chain(s.points.iter().flatten()).map(|v| v.to_bits()).collect::<Vec<_>>();
    let mut scans = 0;
    for k in 0..(24.0 / 0.02) as usize {
        let o = w.step([0.2 * (k as f64 * 0.01).sin(), 0.0, 0.3]).unwrap();
        if o.scanned {
            moving.clear();
            for ob in &w.scenario().obstacles {
                ob.segments_at(w.scan().stamp, &mut moving);
            }
            lidar.scan_indexed_into(&index, &moving, w.scan_body_pose(), w.scan().stamp, &mut rng, &mut scan).unwrap();
            assert_eq!(bits(w.scan()), bits(&scan), "scan at {} s", w.scan().stamp);
            scans += 1;
        }
    }
    assert!(scans >= 200, "{scans} scans");
}

/// The paper's jump at 20 s comes at the step whose time is 20 s (with 0.02 s steps added up
/// the time was 19.999… there and the jump came a step late), and a fault scheduled at or
/// before the start applies from it (one at 0 s never fired).
#[test]
fn odometry_faults_fire_at_their_step_and_from_the_start() {
    use shieldnav_core::sensors::{OdometryConfig, OdometryFault};
    use shieldnav_core::world::{Pose2, Scenario, StaticMap};
    let at = |faults: Vec<OdometryFault>| {
        let mut s = Scenario::new("open", StaticMap::new(), Pose2::default());
        s.odometry = OdometryConfig { faults, ..Default::default() };
        World::new(s, WorldConfig { dt: 0.02, ..Default::default() }).unwrap()
    };
    let mut w = at(vec![OdometryFault::Jump { time: 20.0, dx: 100.0, dy: 0.0 }]);
    for k in 1..=1000 {
        let o = w.step([0.0, 0.0, 0.0]).unwrap();
        let jumped = (o.estimated_pose.x - o.true_pose.x - 100.0).abs() < 1e-9;
        assert_eq!(jumped, k == 1000, "step {k} at {}", o.time);
    }
    assert_eq!(w.time(), 20.0);
    for time in [0.0, -3.0] {
        let w = at(vec![OdometryFault::Jump { time, dx: 5.0, dy: 1.0 }, OdometryFault::YawJump { time, dyaw: 0.5 }]);
        let e = w.estimated_pose();
        assert!(e.x == 5.0 && e.y == 1.0 && e.yaw == 0.5, "{time}: {e:?}");
    }
}

/// A start where the robot cannot stand is an error naming `start`: crossing a wall, or
/// inside a polygon or an obstacle (whose walls it then does not touch: no contact was
/// reported and the LIDAR saw through the box).
#[test]
fn impossible_starts_are_errors() {
    use shieldnav_core::world::{MovingObstacle, Polygon, Pose2, Scenario, Segment, StaticMap, Trajectory};
    let mut map = StaticMap::new();
    map.add_segment(Segment::new([-5.0, 1.0], [5.0, 1.0], 2.0)).unwrap();
    map.add_polygon(Polygon::rect(3.0, -2.0, 5.0, 0.0, 1.0)).unwrap();
    let chair = MovingObstacle { name: "chair".into(), shape: Polygon::rect(-1.0, -1.0, 1.0, 1.0, 1.0), trajectory: Trajectory::fixed(Pose2::new(-4.0, -3.0, 0.0)) };
    let world = |start: Pose2| {
        let mut s = Scenario::new("s", map.clone(), start);
        s.obstacles.push(chair.clone());
        World::new(s, WorldConfig::default())
    };
    world(Pose2::new(0.0, 0.0, 0.0)).unwrap();
    for (start, what) in [
        (Pose2::new(0.0, 0.9, 0.0), "crosses or touches the wall"),
        (Pose2::new(0.0, 0.5, 1.5), "crosses or touches the wall"),
        (Pose2::new(4.0, -1.0, 0.0), "inside polygons[0]"),
        (Pose2::new(-4.0, -3.0, 0.3), "inside the obstacle `chair`"),
    ] {
        let e = world(start).unwrap_err().to_string();
        assert!(e.contains("`start`") && e.contains(what), "{start:?}: {e}");
    }
}
