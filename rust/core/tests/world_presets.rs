//! The scenario presets have the gaps, lengths and timings of the paper's Sec. IV.

use shieldnav_core::sensors::OdometryFault;
use shieldnav_core::world::{preset, Polygon, Segment};
use shieldnav_core::Error;

fn seg_seg_distance(p: &Segment, q: &Segment) -> f64 {
    let d = [p.distance_to_point(q.a), p.distance_to_point(q.b), q.distance_to_point(p.a), q.distance_to_point(p.b)];
    d.into_iter().fold(f64::INFINITY, f64::min) // non-crossing segments
}

fn poly_distance(a: &Polygon, b: &Polygon) -> f64 {
    a.edges().flat_map(|e| b.edges().map(move |f| seg_seg_distance(&e, &f))).fold(f64::INFINITY, f64::min)
}

#[test]
fn constricted_passage_gap_admits_the_robot_but_not_the_sphere() {
    let s = preset("constricted_passage").unwrap();
    // polygons: lower door jamb, upper door jamb, cabinet
    let jamb_low = &s.map.polygons[0];
    let cabinet = &s.map.polygons[2];
    let gap = poly_distance(jamb_low, cabinet);
    assert!((1.0..=1.2).contains(&gap), "gap {gap}");
    assert!(gap > 0.5 + 2.0 * 0.2, "robot width 0.5 m plus 0.2 m each side must fit, gap {gap}");
    assert!(gap < 2.0 * 0.8, "a 0.8 m-radius sphere must not fit, gap {gap}");
    // the cabinet closes the upper side of the doorway completely
    let jamb_high = &s.map.polygons[1];
    assert!(poly_distance(jamb_high, cabinet) < 1e-12);
    // start and goal on opposite sides of the dividing wall
    assert!(s.start.x < 5.0 && s.goal.unwrap().x > 5.1);
}

#[test]
fn odometry_jump_corridor_is_long_with_side_doorways_and_a_100m_jump() {
    let s = preset("odometry_jump").unwrap();
    let (lo, hi) = s.map.bounds().unwrap();
    assert!(hi[0] - lo[0] >= 120.0);
    let jump = s.odometry.faults.iter().find_map(|f| match *f {
        OdometryFault::Jump { time, dx, dy } => Some((time, dx.hypot(dy))),
        _ => None,
    });
    let (time, size) = jump.expect("a jump fault");
    assert!(size >= 100.0 && time > 0.0);
    // doorways: gaps in the corridor wall lines y = ±1.2, each 0.8–1.4 m wide
    for y in [1.2, -1.2] {
        let mut spans: Vec<(f64, f64)> = s.map.segments.iter().filter(|w| (w.a[1] - y).abs() < 1e-9 && (w.b[1] - y).abs() < 1e-9).map(|w| (w.a[0].min(w.b[0]), w.a[0].max(w.b[0]))).collect();
        spans.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
        let gaps: Vec<f64> = spans.windows(2).map(|w| w[1].0 - w[0].1).filter(|g| *g > 1e-9).collect();
        assert!(gaps.len() >= 4, "side y={y}: {} doorways", gaps.len());
        assert!(gaps.iter().all(|g| (0.8..=1.4).contains(g)), "{gaps:?}");
    }
}

#[test]
fn dynamic_obstacles_chair_at_9s_and_door_at_20s() {
    let s = preset("dynamic_obstacles").unwrap();
    let chair = s.obstacles.iter().find(|o| o.name == "chair").unwrap();
    let door = s.obstacles.iter().find(|o| o.name == "door").unwrap();
    let d_start = |t: f64| {
        let p = chair.trajectory.pose_at(t);
        (p.x - s.start.x).hypot(p.y - s.start.y)
    };
    assert_eq!(d_start(0.0), d_start(8.9));
    assert!(d_start(10.0) < d_start(9.0) - 0.5, "chair pushed toward the robot");
    assert!(d_start(9.5) < d_start(9.0));
    let min_y = |t: f64| {
        let mut v = Vec::new();
        door.segments_at(t, &mut v);
        v.iter().flat_map(|w| [w.a[1], w.b[1]]).fold(f64::NEG_INFINITY, f64::max)
    };
    // closed until 20 s: the leaf stays in the wall line (y <= -0.9); open: across the lane,
    // leaving 1.05 m of the 1.8 m corridor
    assert!(min_y(19.9) <= -0.9 + 1e-9);
    assert!(min_y(20.5) > -0.9 + 0.1);
    assert!((min_y(22.0) - (-0.15)).abs() < 1e-9);
    // the corridor is narrow, with clutter on both sides
    let clutter_sides = (s.map.polygons.iter().filter(|p| p.vertices.iter().all(|v| v[1] > 0.0)).count(), s.map.polygons.iter().filter(|p| p.vertices.iter().all(|v| v[1] < 0.0)).count());
    assert!(clutter_sides.0 >= 2 && clutter_sides.1 >= 2);
}

#[test]
fn unknown_preset_is_a_typed_error() {
    match preset("warehouse") {
        Err(Error::UnknownPreset { name, known }) => {
            assert_eq!(name, "warehouse");
            assert!(known.contains("constricted_passage"));
        }
        other => panic!("expected UnknownPreset, got {other:?}"),
    }
}
