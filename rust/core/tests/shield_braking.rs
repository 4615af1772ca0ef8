//! The braking shield in the simulated body: replays of the ways a policy drives into walls
//! (full speed at a wall, a full-rate turn beside a wall, an aisle narrower than the ellipse,
//! a start within the footprint's margin) and of a doorway the body fits through, each held
//! (and passed) under `"braking"`.

use shieldnav_core::env::{Episode, EpisodeConfig, EpisodeSummary, Site};
use shieldnav_core::shield::{ShieldConfig, ShieldMethod};
use shieldnav_core::world::{Pose2, Scenario, Segment, StaticMap};

fn site(walls: &[([f64; 2], [f64; 2])], start: Pose2) -> Site {
    let mut map = StaticMap::new();
    for &(a, b) in walls {
        map.add_segment(Segment::new(a, b, 2.0)).unwrap();
    }
    Site::Scenario(Box::new(Scenario::new("replay", map, start)))
}

/// A corridor along x of `width` (m), closed by a wall at `x = end`, open behind the start.
fn corridor(width: f64, end: f64, start: Pose2) -> Site {
    let h = 0.5 * width;
    site(&[([-10.0, -h], [end, -h]), ([-10.0, h], [end, h]), ([end, -h], [end, h]), ([-10.0, -h], [-10.0, h])], start)
}

/// A room 8 × 6 m split at `x = 0` by a wall with a centred doorway `gap` wide.
fn doorway(gap: f64, start: Pose2) -> Site {
    let g = 0.5 * gap;
    site(&[([-4.0, -3.0], [4.0, -3.0]), ([4.0, -3.0], [4.0, 3.0]), ([4.0, 3.0], [-4.0, 3.0]), ([-4.0, 3.0], [-4.0, -3.0]), ([0.0, -3.0], [0.0, -g]), ([0.0, g], [0.0, 3.0])], start)
}

fn config(method: ShieldMethod) -> EpisodeConfig {
    EpisodeConfig { shield: ShieldConfig { method, ..ShieldConfig::default() }, ..EpisodeConfig::default() }
}

/// Runs `steps` of `policy(step, episode)` and returns the totals.
fn run(site: &Site, method: ShieldMethod, steps: usize, policy: impl Fn(usize, &Episode) -> [f64; 3]) -> (EpisodeSummary, Episode) {
    let mut ep = Episode::new(site.clone(), config(method), 0).unwrap();
    for k in 0..steps {
        let a = policy(k, &ep);
        ep.step(a).unwrap();
    }
    (*ep.summary(), ep)
}

/// A go-to-goal controller: full speed toward `goal`, turning toward it (body-frame action).
fn go_to(goal: [f64; 2]) -> impl Fn(usize, &Episode) -> [f64; 3] {
    move |_, ep| {
        let p = ep.world().true_pose();
        let (dx, dy) = (goal[0] - p.x, goal[1] - p.y);
        let (s, c) = p.yaw.sin_cos();
        let (bx, by) = (c * dx + s * dy, -s * dx + c * dy);
        let d = bx.hypot(by).max(1e-9);
        let k = (d / 0.5).min(1.0) / d;
        [(bx * k).clamp(-1.0, 1.0), (by * k).clamp(-1.0, 1.0), (by.atan2(bx) / 1.5).clamp(-1.0, 1.0)]
    }
}

#[test]
fn a_full_speed_approach_stops_short_of_the_wall() {
    let site = corridor(3.0, 6.0, Pose2::new(0.0, 0.0, 0.0));
    let (paper, _) = run(&site, ShieldMethod::Composite, 400, |_, _| [1.0, 0.0, 0.0]);
    assert!(paper.min_h < -0.2, "the paper's filter was expected to overrun into its ellipse at full speed: {paper:?}");
    let (safe, _) = run(&site, ShieldMethod::Braking, 400, |_, _| [1.0, 0.0, 0.0]);
    assert_eq!(safe.contact_steps, 0, "{safe:?}");
    assert!(safe.shield_braked_steps > 0 || safe.shield_active_steps > 0, "{safe:?}");
    // the footprint keeps its clearance and stops close to it: the nose may reach 6 − 0.55 m
    assert!(safe.min_clearance >= 0.035, "{safe:?}");
    assert!(safe.path_length > 6.0 - 0.55 - 0.25, "stopped {} m in", safe.path_length);
}

#[test]
fn a_full_rate_turn_beside_a_wall_is_filtered() {
    // 0.5 m from the wall at y = 1.5, driven forward, toward the wall and turning at the limits
    let site = corridor(3.0, 30.0, Pose2::new(0.0, 1.0, 0.0));
    let (paper, _) = run(&site, ShieldMethod::Composite, 300, |_, _| [1.0, 1.0, 1.0]);
    assert!(paper.contact_steps > 0, "the paper's filter was expected to touch the wall: {paper:?}");
    for spin in [1.0, -1.0] {
        let (safe, _) = run(&site, ShieldMethod::Braking, 300, |_, _| [1.0, 1.0, spin]);
        assert_eq!(safe.contact_steps, 0, "spin {spin}: {safe:?}");
        assert!(safe.min_clearance > 0.03, "spin {spin}: {safe:?}");
    }
}

#[test]
fn an_aisle_narrower_than_the_ellipse_is_driven_through_without_contact() {
    // 0.8 m between the walls (the ellipse is 0.9 m wide, the body 0.5 m), full forward held
    let site = corridor(0.8, 30.0, Pose2::new(0.0, 0.0, 0.0));
    for action in [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, -1.0, 1.0], [1.0, 0.3, -1.0], [-1.0, 1.0, 1.0]] {
        let (safe, _) = run(&site, ShieldMethod::Braking, 500, |_, _| action);
        assert_eq!(safe.contact_steps, 0, "{action:?}: {safe:?}");
        assert!(safe.min_clearance > 0.0, "{action:?}: {safe:?}");
        if action == [1.0, 0.0, 0.0] {
            // and it is not frozen: the body drives on at the tight-space speed
            assert!(safe.path_length > 3.0 && safe.shield_tight_steps > 0, "{safe:?}");
        }
    }
}

#[test]
fn a_doorway_the_body_fits_through_is_passed() {
    // 0.75 m: the body (0.5 m) fits, the ellipse (0.9 m) does not
    let site = doorway(0.75, Pose2::new(-2.5, 0.0, 0.0));
    let goal = [2.5, 0.0];
    let reached = |ep: &Episode| {
        let p = ep.world().true_pose();
        (p.x - goal[0]).hypot(p.y - goal[1]) < 0.5
    };
    let (free, free_ep) = run(&site, ShieldMethod::Unfiltered, 1000, go_to(goal));
    assert!(reached(&free_ep) && free.contact_steps == 0, "the unshielded controller was expected to pass: {free:?}");
    let (safe, ep) = run(&site, ShieldMethod::Braking, 1000, go_to(goal));
    assert_eq!(safe.contact_steps, 0, "{safe:?}");
    assert!(reached(&ep), "the braking shield closed the door: stopped at {:?}, {safe:?}", ep.world().true_pose());
}

#[test]
fn a_start_within_the_margin_escapes_without_coming_nearer() {
    // 1.1 m between the walls, the body 0.02 m from one of them and pushed toward it
    let site = corridor(1.1, 30.0, Pose2::new(0.0, 0.28, 0.0));
    let (paper, _) = run(&site, ShieldMethod::Composite, 150, |_, _| [0.0, 1.0, 0.0]);
    assert!(paper.path_length < 0.01, "the paper's filter was expected to freeze inside: {paper:?}");
    for action in [[0.0, 1.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, -1.0], [-1.0, 1.0, 0.5]] {
        let (safe, ep) = run(&site, ShieldMethod::Braking, 150, |_, _| action);
        assert_eq!(safe.contact_steps, 0, "{action:?}: {safe:?}");
        assert!(safe.min_clearance >= 0.02 - 1e-3, "{action:?}: it came nearer: {safe:?}");
        if action == [0.0, 1.0, 0.0] {
            assert!(ep.last_report().clearance > 0.03, "{action:?}: it did not leave the wall");
        }
    }
}

#[test]
fn within_the_margin_at_a_corner_the_body_does_not_move_toward_either_edge() {
    // a point 0.01 m off the rear-right corner, within the 0.04 m clearance: which edge it lies
    // against is only known up to the range noise, so neither backward nor rightward passes
    use shieldnav_core::shield::{BodyState, Scan, Shield};
    let mut sh = Shield::new(ShieldConfig { method: ShieldMethod::Braking, ..ShieldConfig::default() }).unwrap();
    let pts = [-0.545, -0.26];
    let st = BodyState::planar(0.0, 0.0).unwrap().with_velocity([0.0; 3]).unwrap();
    for u in [[-1.0, 0.0], [0.0, -0.8], [-1.0, -0.8], [-1.0, 0.8]] {
        let out = sh.filter(&Scan::new_f64(&pts, 2).unwrap(), &st, &u).unwrap();
        assert!(out.u[0] >= -1e-12 && out.u[1] >= -1e-12, "{u:?} moved toward the corner point: {:?}", out.u);
    }
    // away from it passes
    let out = sh.filter(&Scan::new_f64(&pts, 2).unwrap(), &st, &[1.0, 0.8]).unwrap();
    assert!(out.u[0] > 0.0 && out.u[1] > 0.0, "{:?}", out.u);
}

/// With the odometry's velocity (`odometry_velocity`): a full-speed approach to a wall while
/// the odometry freezes (it reads the robot at rest) and through the OdometryJump scenario's
/// 100 m jump, at the limits, still stops short of the walls; the frozen readings are not
/// believed.
#[test]
fn the_odometrys_velocity_is_checked_against_the_model() {
    use shieldnav_core::world::OdometryFault;
    let Site::Scenario(mut s) = corridor(3.0, 6.0, Pose2::new(0.0, 0.0, 0.0)) else { unreachable!() };
    s.odometry.faults.push(OdometryFault::Freeze { start: 0.5, end: 30.0 });
    let site = Site::Scenario(s);
    let config = EpisodeConfig { odometry_velocity: true, ..config(ShieldMethod::Braking) };
    let mut ep = Episode::new(site, config.clone(), 0).unwrap();
    for _ in 0..400 {
        ep.step([1.0, 0.0, 0.0]).unwrap();
    }
    let frozen = *ep.summary();
    assert_eq!(frozen.contact_steps, 0, "{frozen:?}");
    assert!(frozen.odometry_distrusted_steps > 0 && frozen.path_length > 4.0, "{frozen:?}");
    for action in [[1.0, 0.0, 0.0], [1.0, 1.0, 1.0], [-1.0, -1.0, 1.0]] {
        let mut ep = Episode::new(Site::Preset("odometry_jump".into()), config.clone(), 0).unwrap();
        for k in 0..1500 {
            let a = if k % 100 < 50 { action } else { action.map(|v| -v) };
            ep.step(a).unwrap();
        }
        let s = *ep.summary();
        assert_eq!(s.contact_steps, 0, "{action:?}: {s:?}");
        assert!(s.odometry_distrusted_steps >= 1, "the jump was believed: {s:?}");
    }
}
