//! An independent reference for the footprint's distance to a wall: the rounded rectangle's
//! inner rectangle tested for crossing the segment (orientation tests), else the least of the
//! segment's ends to the rectangle and the rectangle's corners to the segment, less the corner
//! radius. The library measures it by separating axes instead (`footprint_segment_distance`).
#![allow(dead_code)]

use shieldnav_core::robot::RobotShape;
use shieldnav_core::world::{Pose2, Segment};

/// Whether the closed segments `pq` and `ab` meet.
fn segments_meet(p: [f64; 2], q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> bool {
    let o = |u: [f64; 2], v: [f64; 2], w: [f64; 2]| (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0]);
    let (d1, d2, d3, d4) = (o(a, b, p), o(a, b, q), o(p, q, a), o(p, q, b));
    let within = |u: [f64; 2], v: [f64; 2], w: [f64; 2]| w[0] >= u[0].min(v[0]) && w[0] <= u[0].max(v[0]) && w[1] >= u[1].min(v[1]) && w[1] <= u[1].max(v[1]);
    if d1 == 0.0 && d2 == 0.0 {
        return within(a, b, p) || within(a, b, q) || within(p, q, a);
    }
    ((d1 > 0.0) != (d2 > 0.0) || d1 == 0.0 || d2 == 0.0) && ((d3 > 0.0) != (d4 > 0.0) || d3 == 0.0 || d4 == 0.0)
}

/// Distance (m) from the footprint at `pose` to the wall `s`; 0 if they touch or overlap.
pub fn reference_distance(shape: &RobotShape, pose: Pose2, s: &Segment) -> f64 {
    let r = shape.corner_radius;
    let (hx, hy) = (0.5 * shape.length - r, 0.5 * shape.width - r);
    let (a, b) = (pose.inverse_transform_point(s.a), pose.inverse_transform_point(s.b));
    let inside = |p: [f64; 2]| p[0].abs() <= hx && p[1].abs() <= hy;
    let corners = [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]];
    if inside(a) || inside(b) || (0..4).any(|k| segments_meet(corners[k], corners[(k + 1) % 4], a, b)) {
        return 0.0;
    }
    let to_rect = |p: [f64; 2]| ((p[0].abs() - hx).max(0.0)).hypot((p[1].abs() - hy).max(0.0));
    let e = [b[0] - a[0], b[1] - a[1]];
    let l2 = e[0] * e[0] + e[1] * e[1];
    let to_seg = |c: [f64; 2]| {
        let w = [c[0] - a[0], c[1] - a[1]];
        let t = if l2 > 0.0 { ((w[0] * e[0] + w[1] * e[1]) / l2).clamp(0.0, 1.0) } else { 0.0 };
        (w[0] - t * e[0]).hypot(w[1] - t * e[1])
    };
    let d = [to_rect(a), to_rect(b)].into_iter().chain(corners.iter().map(|&c| to_seg(c))).fold(f64::INFINITY, f64::min);
    (d - r).max(0.0)
}
