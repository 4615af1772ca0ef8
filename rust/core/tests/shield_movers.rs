//! The braking shield with moving objects, in the simulated body: pedestrians walking head-on
//! at and across the path of a cruising robot. With the mover tracker on, no contact begins
//! with the robot moving; taking every return as static, the robot drives into them.

use shieldnav_core::env::{Episode, EpisodeConfig, EpisodeSummary, Site};
use shieldnav_core::world::{MovingObstacle, Polygon, Pose2, Scenario, Segment, StaticMap, Trajectory};

/// A hall 40 × 16 m, the robot at the origin facing +x, and one 0.5 m walker through
/// `waypoints` at `speed` (m/s).
fn hall(waypoints: &[[f64; 2]], speed: f64) -> Site {
    let mut map = StaticMap::new();
    let c = [[-20.0, -8.0], [20.0, -8.0], [20.0, 8.0], [-20.0, 8.0]];
    for k in 0..4 {
        map.add_segment(Segment::new(c[k], c[(k + 1) % 4], 2.0)).unwrap();
    }
    let mut s = Scenario::new("movers", map, Pose2::new(0.0, 0.0, 0.0));
    s.obstacles.push(MovingObstacle { name: "walker".into(), shape: Polygon::rect(-0.25, -0.25, 0.25, 0.25, 1.8), trajectory: Trajectory::walk(waypoints, speed, 0.0).unwrap() });
    Site::Scenario(Box::new(s))
}

fn run(site: &Site, track: bool, action: [f64; 3], steps: usize) -> EpisodeSummary {
    let config = EpisodeConfig { track_movers: track, ..EpisodeConfig::default() };
    let mut ep = Episode::new(site.clone(), config, 0).unwrap();
    for _ in 0..steps {
        ep.step(action).unwrap();
    }
    *ep.summary()
}

/// The walks: head-on at 1.2 and 1.5 m/s, and crossing the path from either side.
fn walks() -> Vec<(&'static str, Site)> {
    vec![
        ("head-on 1.5", hall(&[[9.0, 0.1], [-19.0, 0.1]], 1.5)),
        ("head-on 1.2", hall(&[[7.0, -0.2], [-19.0, -0.2]], 1.2)),
        ("crossing from the right", hall(&[[4.0, -5.0], [4.0, 7.5]], 1.3)),
        ("crossing from the left", hall(&[[3.5, 5.0], [3.5, -7.5]], 1.5)),
    ]
}

#[test]
fn no_contact_begins_with_the_robot_moving() {
    for (name, site) in walks() {
        for action in [[0.5, 0.0, 0.0], [1.0, 0.0, 0.0]] {
            let tracked = run(&site, true, action, 600);
            assert_eq!(tracked.moving_collisions, 0, "{name}, {action:?}: {tracked:?}");
            assert!(tracked.mover_steps > 0, "{name}: the walker was never tracked: {tracked:?}");
        }
    }
}

/// Taking every return as static, the robot drives into the walkers; tracked, it mostly
/// steps out of their way: its contact steps (being pushed along at rest) are under a third.
#[test]
fn taken_as_static_the_walkers_are_driven_into() {
    let (mut moving, mut steps_static, mut steps_tracked) = (0, 0, 0);
    for (_, site) in walks() {
        for action in [[0.5, 0.0, 0.0], [1.0, 0.0, 0.0]] {
            let s = run(&site, false, action, 600);
            moving += s.moving_collisions;
            steps_static += s.contact_steps;
            steps_tracked += run(&site, true, action, 600).contact_steps;
        }
    }
    assert!(moving > 0, "the static-assumption shield was expected to drive into a walker");
    assert!(3 * steps_tracked < steps_static, "contact steps: tracked {steps_tracked}, static {steps_static}");
}

/// The hall with a chaser starting at `start`, steering at the robot at `speed`.
fn chased(start: [f64; 2], speed: f64) -> Site {
    let Site::Scenario(mut s) = hall(&[[0.0, 7.0], [1.0, 7.0]], 0.1) else { unreachable!() };
    s.map = StaticMap::new();
    s.obstacles[0].trajectory = Trajectory::fixed(Pose2::new(start[0], start[1], 0.0));
    s.chasers.push(shieldnav_core::world::Chaser { obstacle: 0, speed, start_time: 0.0 });
    Site::Scenario(s)
}

/// A chaser slower than the robot (1.0–1.4 m/s against its 1.6) in open space, from ahead,
/// behind and either side, whatever the policy holds (standing, full ahead, circling, every
/// limit at once): the robot turns and runs, and is never touched in 30 s.
#[test]
fn a_chaser_slower_than_the_robot_never_touches_it_in_open_space() {
    for (start, speed) in [([6.0, 0.0], 1.0), ([-5.0, 2.0], 1.0), ([0.0, 5.0], 1.2), ([6.0, 0.0], 1.4)] {
        for action in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.0, 0.5], [-1.0, 1.0, 1.0]] {
            let s = run(&chased(start, speed), true, action, 1500);
            assert_eq!(s.contact_steps, 0, "chaser from {start:?} at {speed} m/s, {action:?}: {s:?}");
        }
    }
}

/// A walker (2.5 m/s) shoves the unshielded robot, standing still, toward a wall 2.6 m ahead and
/// stops: the robot, coasting to rest, meets the wall still moving. That contact is the
/// walker's doing, not one the robot drove into; driving into the same wall from rest is.
#[test]
fn a_shove_into_a_wall_is_not_a_contact_begun_moving() {
    let site = |waypoints: &[[f64; 2]], speed: f64| {
        let Site::Scenario(mut s) = hall(waypoints, speed) else { unreachable!() };
        s.map.add_segment(Segment::new([3.0, -3.0], [3.0, 3.0], 0.1)).unwrap();
        Site::Scenario(s)
    };
    let config = EpisodeConfig { shield: shieldnav_core::shield::ShieldConfig { method: shieldnav_core::shield::ShieldMethod::Unfiltered, ..Default::default() }, ..EpisodeConfig::default() };
    let mut ep = Episode::new(site(&[[-3.0, 0.0], [0.4, 0.0]], 2.5), config.clone(), 0).unwrap();
    let (mut touching, mut speed_at_wall) = (false, None);
    for _ in 0..300 {
        let speed = ep.velocity()[0].hypot(ep.velocity()[1]);
        let r = ep.step([0.0, 0.0, 0.0]).unwrap();
        if r.cost > 0.0 && !touching && ep.world().true_pose().x > 1.5 {
            speed_at_wall.get_or_insert(speed);
        }
        touching = r.cost > 0.0;
    }
    let shoved = *ep.summary();
    assert_eq!(shoved.contact_events, 2, "the shove and the wall were expected: {shoved:?}");
    assert!(speed_at_wall.is_some_and(|v| v > 0.3), "the robot was expected to meet the wall coasting: {speed_at_wall:?}");
    assert_eq!(shoved.moving_collisions, 0, "{shoved:?}");
    let mut ep = Episode::new(site(&[[-15.0, 7.0], [-14.0, 7.0]], 0.1), config, 0).unwrap();
    for _ in 0..200 {
        ep.step([1.0, 0.0, 0.0]).unwrap();
    }
    assert_eq!(ep.summary().moving_collisions, 1, "{:?}", ep.summary());
}
