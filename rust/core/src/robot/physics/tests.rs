use super::*;
use crate::robot::footprint::footprint_segment_distance;
use crate::world::{Polygon, Trajectory};
use rand::{Rng, SeedableRng};

fn corridor() -> Vec<Segment> {
    vec![Segment::new([-5.0, -0.6], [20.0, -0.6], 2.0), Segment::new([-5.0, 0.6], [20.0, 0.6], 2.0), Segment::new([6.0, -0.6], [6.0, 0.6], 2.0)]
}

#[test]
fn free_driving_follows_the_command_without_contacts() {
    let mut sc = PhysicsScene::new(RobotShape::default(), &corridor(), &[], Pose2::default(), 0.0).unwrap();
    for _ in 0..50 {
        let rep = sc.step([1.0, 0.0, 0.0], 0.02, &[], 0.0).unwrap();
        assert!(!rep.any());
    }
    let p = sc.robot_pose();
    assert!((p.x - 1.0).abs() < 1e-3 && p.y.abs() < 1e-4 && p.yaw.abs() < 1e-4, "{p:?}");
}

/// Free flight without the solver lands where rapier's solver puts the robot.
#[test]
fn free_steps_agree_with_the_solver_away_from_walls() {
    let walls = [Segment::new([-50.0, -20.0], [50.0, -20.0], 2.0)];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let mut a = PhysicsScene::new(RobotShape::default(), &walls, &[], Pose2::new(0.0, 0.0, 0.3), 0.0).unwrap();
    let mut b = PhysicsScene::new(RobotShape::default(), &walls, &[], Pose2::new(0.0, 0.0, 0.3), 0.0).unwrap();
    let (mut worst, mut path): (Real, Real) = (0.0, 0.0);
    for k in 0..500 {
        let before = a.robot_pose();
        let cmd = [rng.random_range(-1.6..1.6), rng.random_range(-0.8..0.8), rng.random_range(-1.5..1.5)];
        a.step(cmd, 0.02, &[], 0.0).unwrap();
        b.step_free(cmd, 0.02, &[], 0.0).unwrap();
        let (pa, pb) = (a.robot_pose(), b.robot_pose());
        path += (pa.x - before.x).hypot(pa.y - before.y);
        worst = worst.max((pa.x - pb.x).abs()).max((pa.y - pb.y).abs()).max(wrap_angle(pa.yaw - pb.yaw).abs());
        if k % 50 == 0 {
            // resynchronise, so each stretch compares fresh rounding
            b.set_robot_pose(pa).unwrap();
        }
    }
    assert!(worst < 1e-6, "free flight off the solver's pose by {worst}");
    // (the solver's velocity after a step is the command's to `f32` rounding)
    let (va, vb) = (a.robot_velocity(), b.robot_velocity());
    assert!((0..3).all(|k| (va[k] - vb[k]).abs() < 1e-6), "{va:?} vs {vb:?}");
    assert_eq!(a.achieved_velocity(), b.achieved_velocity());
    assert!(path > 5.0, "the robot moved ({path} m)");
    println!("free flight against the solver: worst {worst:e}");
}

#[test]
fn driving_into_the_end_wall_is_reported_and_stopped() {
    let walls = corridor();
    let mut sc = PhysicsScene::new(RobotShape::default(), &walls, &[], Pose2::new(4.0, 0.0, 0.0), 0.0).unwrap();
    let mut touched = false;
    for _ in 0..150 {
        let rep = sc.step([1.0, 0.0, 0.0], 0.02, &[], 0.0).unwrap();
        touched |= rep.with_walls > 0;
    }
    let p = sc.robot_pose();
    assert!(touched);
    // front at x = p.x + 0.55 must not be (much) beyond the wall at 6
    assert!(p.x + 0.55 < 6.0 + 0.05, "{p:?}");
}

/// Pressed into the walls and obstacles of `dynamic_obstacles` (and a pedestrian walking
/// into it) as the physics bench presses it, at 1.06 cm a step: the steps the split would
/// cut in two are taken as one rapier step and kept, and the walls stay as rigid as with
/// every step split.
#[test]
fn pressed_steps_are_taken_coarse_and_the_walls_stay_rigid() {
    let s = crate::world::preset("dynamic_obstacles").unwrap();
    let mut obstacles = s.obstacles.clone();
    obstacles.push(MovingObstacle { name: "pedestrian".into(), shape: Polygon::rect(-0.2, -0.25, 0.2, 0.25, 1.8), trajectory: Trajectory::walk(&[[25.0, 0.3], [2.0, 0.3]], 1.2, 0.0).unwrap() });
    let drive = |coarse_split: usize| {
        let mut sc = PhysicsScene::new(RobotShape::default(), &s.map.segments, &obstacles, s.start, 0.0).unwrap();
        sc.coarse_split = coarse_split;
        let (mut deepest, mut touching): (Real, usize) = (0.0, 0);
        for k in 1..=1500 {
            let rep = sc.step([0.5, 0.0, 0.05], 0.02, &obstacles, k as Real * 0.02).unwrap();
            deepest = deepest.max(rep.max_penetration);
            touching += rep.any() as usize;
        }
        (sc.rapier_steps() as Real / 1500.0, deepest, touching, sc.stats().coarse_kept)
    };
    let (split_steps, split_deepest, split_touching, _) = drive(1);
    let (steps, deepest, touching, kept) = drive(COARSE_SPLIT);
    assert!(split_touching > 1000 && touching > 1000, "{split_touching} / {touching} steps in contact");
    assert!(split_steps > 1.9 && steps < 1.4 && kept > 900, "{split_steps} → {steps} rapier steps per step, {kept} kept coarse");
    assert!(split_deepest < 0.01 && deepest < 0.01, "{split_deepest} / {deepest} m deep");
}

/// Turning into a corridor's wall at 0.01 s steps, a coarse step that ends deeper than
/// `DEEP_CONTACT` is taken again from its start, split: the footprint never ends a step
/// that deep.
#[test]
fn a_coarse_step_that_sinks_in_is_taken_again_split() {
    let mut sc = PhysicsScene::new(RobotShape::default(), &corridor(), &[], Pose2::new(0.0, 0.0, 0.0), 0.0).unwrap();
    let mut deepest: Real = 0.0;
    for k in 1..=200 {
        let rep = sc.step([0.3, 0.0, 1.5], 0.01, &[], k as Real * 0.01).unwrap();
        deepest = deepest.max(rep.max_penetration);
    }
    assert!(
        sc.stats().coarse_kept > 100 && sc.stats().coarse_redone > 0 && deepest > 0.001 && deepest <= DEEP_CONTACT,
        "{} kept, {} taken again, {deepest} m deep",
        sc.stats().coarse_kept,
        sc.stats().coarse_redone
    );
}

/// Fast robots stop at the end wall: at 4 m/s (0.4 m per 0.1 s step, 40 rapier steps of
/// 1 cm) within 1 cm of it; at 8 and 16 m/s (`MAX_SUBSTEPS` rapier steps of 1.25 and 2.5 cm,
/// the walls' broad-phase boxes still pairing them with the robot in time) they sink in
/// deeper (2.7 and 5.5 cm) but stop.
#[test]
fn a_fast_robot_stops_at_a_wall() {
    for (speed, rigid) in [(4.0, 0.01), (8.0, 0.03), (16.0, 0.06)] {
        let mut sc = PhysicsScene::new(RobotShape::default(), &corridor(), &[], Pose2::new(-4.0, 0.0, 0.0), 0.0).unwrap();
        let mut deepest: Real = 0.0;
        for k in 1..=40 {
            let rep = sc.step([speed, 0.0, 0.0], 0.1, &[], k as Real * 0.1).unwrap();
            deepest = deepest.max(rep.max_penetration);
        }
        let front = sc.robot_pose().x + 0.55;
        assert!(deepest > 0.0 && deepest < rigid && (front - 6.0).abs() <= deepest + 1e-9, "{speed} m/s: front at {front}, deepest penetration {deepest}");
    }
}

#[test]
fn contact_report_agrees_with_the_exact_footprint_distance() {
    let walls = corridor();
    // overlapping the end wall by 3 cm, then clear of it by 3 cm
    for (x, expect_contact) in [(6.0 - 0.55 + 0.03, true), (6.0 - 0.55 - 0.03, false)] {
        let pose = Pose2::new(x, 0.0, 0.0);
        let exact = walls.iter().map(|s| footprint_segment_distance(&RobotShape::default(), pose, s)).fold(f64::INFINITY, f64::min);
        let mut sc = PhysicsScene::new(RobotShape::default(), &walls, &[], pose, 0.0).unwrap();
        let rep = sc.step([0.0, 0.0, 0.0], 1e-4, &[], 0.0).unwrap();
        assert_eq!(rep.with_walls > 0, expect_contact, "x {x}: {rep:?}");
        assert_eq!(exact == 0.0, expect_contact);
        if expect_contact {
            assert!((rep.max_penetration - 0.03).abs() < 2e-3, "{rep:?}");
        }
    }
}

#[test]
fn moving_obstacle_hits_the_robot() {
    let chair =
        MovingObstacle { name: "chair".into(), shape: Polygon::rect(-0.25, -0.25, 0.25, 0.25, 0.9), trajectory: Trajectory::linear(Pose2::new(3.0, 0.0, 0.0), Pose2::new(0.0, 0.0, 0.0), 0.0, 2.0) };
    let obstacles = [chair];
    let mut sc = PhysicsScene::new(RobotShape::default(), &corridor(), &obstacles, Pose2::default(), 0.0).unwrap();
    let mut hit = false;
    for k in 1..=100 {
        let rep = sc.step([0.0, 0.0, 0.0], 0.02, &obstacles, k as Real * 0.02).unwrap();
        hit |= rep.with_obstacles > 0;
    }
    assert!(hit);
    assert!(sc.robot_pose().x < -0.5, "the chair pushed the robot back: {:?}", sc.robot_pose());
}

/// Steps `cached` (reading the distances the last step measured at its end) and `fresh`
/// (measuring afresh) alike for `steps` steps of random commands held `hold` steps, at
/// 0.02 s and every third hundred at 0.1 s, and checks that they agree bit for bit.
/// Returns how many steps read the distances and how many touched something.
fn cached_and_fresh_agree(walls: &[Segment], obstacles: &[MovingObstacle], steps: usize, hold: usize, speed: Real) -> (PhysicsScene, usize, usize) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut cached = PhysicsScene::new(RobotShape::default(), walls, obstacles, Pose2::default(), 0.0).unwrap();
    let mut fresh = PhysicsScene::new(RobotShape::default(), walls, obstacles, Pose2::default(), 0.0).unwrap();
    let (mut t, mut read, mut touching) = (0.0, 0, 0);
    let mut cmd = [0.0; 3];
    for k in 0..steps {
        if k % hold == 0 {
            cmd = [speed * rng.random_range(-1.6..1.6), speed * rng.random_range(-0.8..0.8), rng.random_range(-1.5..1.5)];
        }
        let dt = if (k / 100) % 3 == 2 { 0.1 } else { 0.02 };
        t += dt;
        read += cached.near_valid as usize;
        fresh.near_valid = false;
        let a = cached.step(cmd, dt, obstacles, t).unwrap();
        let b = fresh.step(cmd, dt, obstacles, t).unwrap();
        assert_eq!(a, b, "step {k}");
        assert_eq!(cached.world.bodies[cached.robot].position(), fresh.world.bodies[fresh.robot].position(), "step {k}");
        assert_eq!(cached.achieved_velocity(), fresh.achieved_velocity(), "step {k}");
        touching += a.any() as usize;
    }
    assert_eq!(cached.rapier_steps(), fresh.rapier_steps());
    (cached, read, touching)
}

/// The distances a step measures at its end, read by the next step instead of measuring
/// again, give the same steps bit for bit as measuring afresh: a random drive through a
/// corridor with a box pushed into it, at 0.02 s (distances read) and 0.1 s (at speed
/// measured again), splitting steps near the walls.
#[test]
fn steps_from_the_last_steps_distances_are_the_steps_measured_afresh() {
    let pushed =
        MovingObstacle { name: "box".into(), shape: Polygon::rect(-0.3, -0.3, 0.3, 0.3, 1.0), trajectory: Trajectory::linear(Pose2::new(8.0, 0.0, 0.0), Pose2::new(1.0, 0.1, 0.5), 2.0, 12.0) };
    let (sc, read, touching) = cached_and_fresh_agree(&corridor(), &[pushed], 1500, 25, 1.0);
    assert!(sc.rapier_steps() > 1500 + 500, "{} rapier steps for 1500", sc.rapier_steps());
    assert!(read > 1000 && touching > 100, "{read} steps read the distances, {touching} touching");
}

/// Far obstacles are measured by a bound, and exactly where a step may reach them, with the
/// same steps as measuring each exactly: a robot dithering about in the open while
/// pedestrians circle it at 1.5 m/s, passing within reach and bumping into it.
#[test]
fn far_obstacles_bounds_give_the_steps_measured_exactly() {
    let ring = |r: Real, phase: Real| -> Vec<Point2> { (0..=40).map(|i| phase + i as Real * std::f64::consts::PI / 5.0).map(|a| [r * a.cos(), r * a.sin()]).collect() };
    let walker = |name: &str, path: Vec<Point2>| MovingObstacle { name: name.into(), shape: Polygon::rect(-0.2, -0.25, 0.2, 0.25, 1.8), trajectory: Trajectory::walk(&path, 1.5, 0.0).unwrap() };
    let obstacles = [walker("near", ring(0.95, 0.0)), walker("passing", ring(1.05, 1.0)), walker("far", ring(3.0, 2.0))];
    let walls = [Segment::new([-20.0, -20.0], [20.0, -20.0], 2.0)];
    let (sc, read, touching) = cached_and_fresh_agree(&walls, &obstacles, 1500, 5, 0.1);
    assert!(read > 1000 && touching > 50, "{read} steps read the distances, {touching} touching");
    assert!(sc.stats().bounds_measured > 50, "{} bounds measured exactly", sc.stats().bounds_measured);
}

/// A placed robot reads exactly where it was placed (rapier's `f32` pose is up to about
/// 1e-6 m off), at the start and after `set_robot_pose`, and from the first step on where
/// rapier moved it.
#[test]
fn a_placed_robot_reads_exactly_where_it_was_placed() {
    let walls = [Segment::new([0.0, 30.0], [40.0, 30.0], 2.0), Segment::new([0.0, 45.0], [40.0, 45.0], 2.0)];
    let start = Pose2::new(20.05, 38.05, 0.3);
    let mut sc = PhysicsScene::new(RobotShape::default(), &walls, &[], start, 0.0).unwrap();
    assert_eq!(sc.robot_pose(), start);
    let b = &sc.world.bodies[sc.robot];
    let rapier = [b.translation().x as Real + sc.origin[0], b.translation().y as Real + sc.origin[1]];
    assert_ne!(rapier, [start.x, start.y], "the start lies on the f32 grid: the test proves nothing");
    sc.step([0.5, 0.0, 0.0], 0.02, &[], 0.02).unwrap();
    let p = sc.robot_pose();
    assert!((p.x - start.x - 0.01 * start.yaw.cos()).abs() < 1e-5 && p.x != start.x, "{p:?}");
    let again = Pose2::new(12.3456789, 37.1, -2.0);
    sc.set_robot_pose(again).unwrap();
    assert_eq!(sc.robot_pose(), again);
    // an unwrapped yaw reads wrapped
    sc.set_robot_pose(Pose2::new(12.0, 37.0, 7.0)).unwrap();
    assert_eq!(sc.robot_pose().yaw, wrap_angle(7.0));
}
