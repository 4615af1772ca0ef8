//! The braking shield in the simulated body: replays of the ways the paper's translational
//! filter lets a policy drive into walls (full speed at a wall, a full-rate turn between
//! walls, a start with a wall inside the ellipse), each failing under `"composite"` and held
//! under `"braking"`.

use shieldnav_core::env::{Episode, EpisodeConfig, EpisodeSummary, Site};
use shieldnav_core::shield::{ShieldConfig, ShieldMethod};
use shieldnav_core::world::{Pose2, Scenario, Segment, StaticMap};

/// A corridor along x of `width` (m), closed by a wall at `x = end`, open behind the start.
fn corridor(width: f64, end: f64, start: Pose2) -> Site {
    let mut map = StaticMap::new();
    let h = 0.5 * width;
    for s in [Segment::new([-10.0, -h], [end, -h], 2.0), Segment::new([-10.0, h], [end, h], 2.0), Segment::new([end, -h], [end, h], 2.0), Segment::new([-10.0, -h], [-10.0, h], 2.0)] {
        map.add_segment(s).unwrap();
    }
    Site::Scenario(Box::new(Scenario::new("corridor", map, start)))
}

fn config(method: ShieldMethod) -> EpisodeConfig {
    EpisodeConfig { shield: ShieldConfig { method, ..ShieldConfig::default() }, ..EpisodeConfig::default() }
}

/// Runs `steps` of `policy(step)` and returns the totals and the last report's `h_min`.
fn run(site: &Site, method: ShieldMethod, steps: usize, policy: impl Fn(usize) -> [f64; 3]) -> (EpisodeSummary, f64) {
    let mut ep = Episode::new(site.clone(), config(method), 0).unwrap();
    let mut h_min = f64::NAN;
    for k in 0..steps {
        let r = ep.step(policy(k)).unwrap();
        h_min = r.h_min;
    }
    (*ep.summary(), h_min)
}

#[test]
fn a_full_speed_approach_brakes_before_the_wall() {
    let site = corridor(3.0, 6.0, Pose2::new(0.0, 0.0, 0.0));
    let (paper, _) = run(&site, ShieldMethod::Composite, 400, |_| [1.0, 0.0, 0.0]);
    assert!(paper.min_h < -0.2, "the paper's filter was expected to overrun into its ellipse at full speed: {paper:?}");
    let (safe, h_min) = run(&site, ShieldMethod::Braking, 400, |_| [1.0, 0.0, 0.0]);
    assert_eq!(safe.contact_steps, 0, "{safe:?}");
    // the ellipse stays free, and the robot stands close to where it may (ellipse nose at the wall)
    assert!(safe.min_h >= 0.0, "the ellipse was entered: min h = {}", safe.min_h);
    assert!(safe.shield_braked_steps > 0 && h_min < 0.5, "it stopped short: h_min = {h_min}, {safe:?}");
    assert!(safe.path_length > 6.0 - 0.9 - 0.15, "stopped {} m in, the nose may reach 5.1 m", safe.path_length);
}

#[test]
fn a_full_rate_turn_beside_a_wall_is_filtered() {
    // 0.5 m from the wall at y = 1.5, driven forward, toward the wall and turning at the limits
    let site = corridor(3.0, 30.0, Pose2::new(0.0, 1.0, 0.0));
    let (paper, _) = run(&site, ShieldMethod::Composite, 300, |_| [1.0, 1.0, 1.0]);
    assert!(paper.contact_steps > 0, "the paper's filter was expected to touch the wall: {paper:?}");
    for spin in [1.0, -1.0] {
        let (safe, _) = run(&site, ShieldMethod::Braking, 300, |_| [1.0, 1.0, spin]);
        assert_eq!(safe.contact_steps, 0, "spin {spin}: {safe:?}");
        assert!(safe.min_h >= 0.0, "spin {spin}: the ellipse was entered: {safe:?}");
    }
}

#[test]
fn a_start_with_a_wall_inside_the_ellipse_recovers_instead_of_freezing() {
    // 1.1 m between the walls, the robot 0.02 m from one of them and pushed toward it
    let site = corridor(1.1, 30.0, Pose2::new(0.0, 0.28, 0.0));
    let (paper, h_paper) = run(&site, ShieldMethod::Composite, 150, |_| [0.0, 1.0, 0.0]);
    assert!(h_paper < -0.5 && paper.path_length < 0.01, "the paper's filter was expected to freeze inside: h_min = {h_paper}, {paper:?}");
    let (safe, h_safe) = run(&site, ShieldMethod::Braking, 150, |_| [0.0, 1.0, 0.0]);
    assert_eq!(safe.contact_steps, 0, "{safe:?}");
    assert!(safe.shield_recovering_steps > 0, "{safe:?}");
    assert!(h_safe >= 0.0, "it did not leave the wall: h_min = {h_safe}");
}
