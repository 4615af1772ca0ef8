//! One physics step: the robot, the preset's walls and three moving obstacles.
//!
//! `cargo bench -p shieldnav-core --bench physics`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use shieldnav_core::robot::{PhysicsScene, RobotShape, Tracker, TrackerConfig};
use shieldnav_core::world::{preset, MovingObstacle, Polygon, Pose2, Trajectory};

fn bench(c: &mut Criterion) {
    let s = preset("dynamic_obstacles").unwrap();
    let mut obstacles = s.obstacles.clone();
    obstacles.push(MovingObstacle { name: "pedestrian".into(), shape: Polygon::rect(-0.2, -0.25, 0.2, 0.25, 1.8), trajectory: Trajectory::walk(&[[25.0, 0.3], [2.0, 0.3]], 1.2, 0.0).unwrap() });
    let mut scene = PhysicsScene::new(RobotShape::default(), &s.map.segments, &obstacles, s.start, 0.0).unwrap();
    let mut t = 0.0;
    c.bench_function(&format!("physics_step_robot_{}walls_{}movers", s.map.segments.len(), obstacles.len()), |b| {
        b.iter(|| {
            t += 0.02;
            if t > 30.0 {
                t = 0.0;
                scene.set_robot_pose(Pose2::new(1.0, 0.0, 0.0)).unwrap();
            }
            black_box(scene.step(black_box([0.5, 0.0, 0.05]), 0.02, &obstacles, t).unwrap());
        })
    });
    c.bench_function("physics_contacts_query_only", |b| b.iter(|| black_box(scene.contacts())));
    // the same drive as an episode steps the robot (`World::step`): the command through the
    // low-level tracker, which goes on from the velocity the body achieved, so that a robot held
    // by a wall presses on from rest within its acceleration limits instead of at the full
    // command (about 1.4 rapier steps per step; in contact three steps in four)
    let mut scene = PhysicsScene::new(RobotShape::default(), &s.map.segments, &obstacles, s.start, 0.0).unwrap();
    let mut tracker = Tracker::new(TrackerConfig::default()).unwrap();
    let mut t = 0.0;
    c.bench_function("physics_step_robot_tracked_into_walls", |b| {
        b.iter(|| {
            t += 0.02;
            if t > 30.0 {
                t = 0.0;
                scene.set_robot_pose(Pose2::new(1.0, 0.0, 0.0)).unwrap();
                tracker.set_velocity([0.0; 3]);
            }
            let v = tracker.step(black_box([0.5, 0.0, 0.05]), 0.02).unwrap().velocity;
            let rep = black_box(scene.step(v, 0.02, &obstacles, t).unwrap());
            tracker.set_velocity(scene.achieved_velocity());
            rep
        })
    });
    // the same scene, the robot driving straight down the lane for 10 s (nothing within reach
    // of a step: one rapier step per step), where the steps above press it into walls and
    // obstacles most of the time (steps near them split or taken coarse and checked: 1.27
    // rapier steps per step held at the command)
    let mut scene = PhysicsScene::new(RobotShape::default(), &s.map.segments, &obstacles, s.start, 0.0).unwrap();
    let mut t = 0.0;
    c.bench_function("physics_step_robot_free_driving", |b| {
        b.iter(|| {
            t += 0.02;
            if t > 10.0 {
                t = 0.0;
                scene.set_robot_pose(s.start).unwrap();
            }
            black_box(scene.step(black_box([0.5, 0.0, 0.0]), 0.02, &obstacles, t).unwrap());
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
