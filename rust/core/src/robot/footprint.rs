//! The robot's true footprint and an exact footprint-to-wall distance.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::{Point2, Pose2, Scenario, Segment};

/// The body outline: a `length × width` rectangle (m, length along the heading) whose corners
/// are rounded with `corner_radius` (m; 0 for sharp corners). Default: Spot, 1.1 × 0.5 m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobotShape {
    /// Along the heading (m).
    pub length: Real,
    /// Across (m).
    pub width: Real,
    /// Corner rounding (m), at most half the width.
    pub corner_radius: Real,
}

impl Default for RobotShape {
    fn default() -> Self {
        Self { length: 1.1, width: 0.5, corner_radius: 0.0 }
    }
}

impl RobotShape {
    /// Checks the dimensions; the error names the field.
    pub fn validate(&self) -> Result<()> {
        if !(self.length.is_finite() && self.length > 0.0) {
            return Err(Error::invalid("length", format!("must be finite and > 0, got {}", self.length)));
        }
        if !(self.width.is_finite() && self.width > 0.0) {
            return Err(Error::invalid("width", format!("must be finite and > 0, got {}", self.width)));
        }
        let rmax = 0.5 * self.length.min(self.width);
        if !(self.corner_radius.is_finite() && self.corner_radius >= 0.0 && self.corner_radius <= rmax) {
            return Err(Error::invalid("corner_radius", format!("must be in [0, {rmax}], got {}", self.corner_radius)));
        }
        Ok(())
    }

    /// Half the diagonal (m): every point of the footprint lies within it of the centre.
    pub fn half_diagonal(&self) -> Real {
        0.5 * self.length.hypot(self.width)
    }

    /// How far (m) any point of the footprint can move in `dt` seconds at body velocity
    /// `(vx, vy, ω)`: its translation plus [`RobotShape::half_diagonal`] times its turn.
    pub fn step_reach(&self, velocity: [Real; 3], dt: Real) -> Real {
        (velocity[0].hypot(velocity[1]) + self.half_diagonal() * velocity[2].abs()) * dt
    }
}

/// Distance (m) between the footprint at `pose` and the wall `s`; 0 if they touch or overlap
/// ([`footprint_signed_distance`] of the wall's two ends, clipped at 0).
pub fn footprint_segment_distance(shape: &RobotShape, pose: Pose2, s: &Segment) -> Real {
    let q = [pose.inverse_transform_point(s.a), pose.inverse_transform_point(s.b)];
    (inner_rect_signed_distance(shape, &q) - shape.corner_radius).max(0.0)
}

/// Signed distance (m) between the footprint at `pose` and a convex outline `vertices` (world
/// points, either winding; two points are a wall segment): the gap when apart, minus the
/// penetration depth (the least translation that separates them) when they overlap.
///
/// Exact in `f64`: the footprint is its inner rectangle (shrunk by `corner_radius`) grown by
/// that radius, so its signed distance is the rectangle's less the radius; the rectangle's
/// is, when a separating axis exists, the least vertex-to-edge distance, and otherwise the
/// least overlap over the edge normals of both outlines (separating axes: in the plane these
/// are the only candidate axes of two convex polygons).
pub fn footprint_signed_distance(shape: &RobotShape, pose: Pose2, vertices: &[Point2]) -> Real {
    let local: Vec<Point2> = vertices.iter().map(|&p| pose.inverse_transform_point(p)).collect();
    inner_rect_signed_distance(shape, &local) - shape.corner_radius
}

/// The signed distance between the footprint's inner rectangle (centred at the origin, axis
/// aligned, half extents `length / 2 − r`, `width / 2 − r`) and the convex outline `q` given in
/// the body frame (see [`footprint_signed_distance`]; the corner radius is not subtracted).
pub(crate) fn inner_rect_signed_distance(shape: &RobotShape, q: &[Point2]) -> Real {
    let r = shape.corner_radius;
    let (hx, hy) = ((0.5 * shape.length - r).max(0.0), (0.5 * shape.width - r).max(0.0));
    let n = q.len();
    if n == 0 {
        return Real::INFINITY;
    }
    // the rectangle's own axes
    let (mut x0, mut x1, mut y0, mut y1) = (Real::INFINITY, Real::NEG_INFINITY, Real::INFINITY, Real::NEG_INFINITY);
    for p in q {
        x0 = x0.min(p[0]);
        x1 = x1.max(p[0]);
        y0 = y0.min(p[1]);
        y1 = y1.max(p[1]);
    }
    let mut best = (x0 - hx).max(-hx - x1).max((y0 - hy).max(-hy - y1));
    // the outline's edge normals (a segment has one)
    let edges = if n == 2 {
        1
    } else if n == 1 {
        0
    } else {
        n
    };
    for i in 0..edges {
        let (a, b) = (q[i], q[(i + 1) % n]);
        let e = [b[0] - a[0], b[1] - a[1]];
        let len = (e[0] * e[0] + e[1] * e[1]).sqrt();
        if len == 0.0 {
            continue;
        }
        let u = [-e[1] / len, e[0] / len];
        let ext = hx * u[0].abs() + hy * u[1].abs();
        let (mut lo, mut hi) = (Real::INFINITY, Real::NEG_INFINITY);
        for p in q {
            let d = p[0] * u[0] + p[1] * u[1];
            lo = lo.min(d);
            hi = hi.max(d);
        }
        best = best.max((lo - ext).max(-ext - hi));
    }
    if best <= 0.0 {
        return best;
    }
    // apart: the distance is between a vertex of one and an edge of the other
    let to_rect2 = |p: &Point2| {
        let dx = (p[0].abs() - hx).max(0.0);
        let dy = (p[1].abs() - hy).max(0.0);
        dx * dx + dy * dy
    };
    let mut d2 = q.iter().map(to_rect2).fold(Real::INFINITY, Real::min);
    let corners = [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]];
    for i in 0..edges.max(1).min(n) {
        let (a, b) = (q[i], q[(i + 1) % n]);
        let e = [b[0] - a[0], b[1] - a[1]];
        let l2 = e[0] * e[0] + e[1] * e[1];
        for c in corners {
            let w = [c[0] - a[0], c[1] - a[1]];
            let t = if l2 > 0.0 { ((w[0] * e[0] + w[1] * e[1]) / l2).clamp(0.0, 1.0) } else { 0.0 };
            let (x, y) = (w[0] - t * e[0], w[1] - t * e[1]);
            d2 = d2.min(x * x + y * y);
        }
    }
    d2.sqrt()
}

/// That the robot's footprint `shape` at the `scenario`'s start is in free space: it crosses or
/// touches no wall (of the map or of an obstacle where it is at time 0) and stands inside
/// no polygon or obstacle (whose walls it would then not touch). The error names `start`.
pub fn check_start(shape: &RobotShape, scenario: &Scenario) -> Result<()> {
    let p = scenario.start;
    let reach = shape.half_diagonal();
    let size = format!("robot_length × robot_width = {} × {} m", shape.length, shape.width);
    let at = |what: String| Error::invalid("start", format!("the robot's footprint ({size}) at ({}, {}, yaw {}) {what}", p.x, p.y, p.yaw));
    let mut moving = Vec::new();
    for o in &scenario.obstacles {
        o.segments_at(0.0, &mut moving);
    }
    for w in scenario.map.segments.iter().chain(&moving) {
        if w.distance_to_point([p.x, p.y]) <= reach && footprint_segment_distance(shape, p, w) <= 0.0 {
            return Err(at(format!("crosses or touches the wall {:?} → {:?}", w.a, w.b)));
        }
    }
    if let Some(i) = scenario.map.polygons.iter().position(|q| q.contains([p.x, p.y])) {
        return Err(at(format!("stands inside polygons[{i}]")));
    }
    for o in &scenario.obstacles {
        let pose = o.trajectory.pose_at(0.0);
        if o.shape.contains(pose.inverse_transform_point([p.x, p.y])) {
            return Err(at(format!("stands inside the obstacle `{}` (at time 0)", o.name)));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_to_a_parallel_wall_is_the_gap() {
        let s = Segment::new([-5.0, 0.6], [5.0, 0.6], 2.0);
        let d = footprint_segment_distance(&RobotShape::default(), Pose2::default(), &s);
        assert!((d - 0.35).abs() < 1e-12);
        let turned = footprint_segment_distance(&RobotShape::default(), Pose2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2), &s);
        assert!((turned - 0.05).abs() < 1e-12);
    }

    #[test]
    fn crossing_wall_has_zero_distance_and_corner_rounding_adds_clearance() {
        let s = Segment::new([0.5, -1.0], [0.5, 1.0], 2.0);
        assert_eq!(footprint_segment_distance(&RobotShape::default(), Pose2::default(), &s), 0.0);
        // a wall diagonal to a corner at (0.55, 0.25)
        let diag = Segment::new([0.65, 0.35], [0.75, 0.25], 2.0);
        let sharp = footprint_segment_distance(&RobotShape::default(), Pose2::default(), &diag);
        let round = footprint_segment_distance(&RobotShape { corner_radius: 0.1, ..Default::default() }, Pose2::default(), &diag);
        assert!(round > sharp + 0.02, "{sharp} {round}");
    }

    #[test]
    fn bad_shape_is_rejected() {
        assert!(RobotShape { corner_radius: 0.3, ..Default::default() }.validate().is_err());
        assert!(RobotShape { width: 0.0, ..Default::default() }.validate().is_err());
    }
}
