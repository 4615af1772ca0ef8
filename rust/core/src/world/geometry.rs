//! Planar primitives of the world: points, poses, wall segments and extruded polygons.
//!
//! Everything is in metres and radians, `f64`, in the world frame unless stated. Walls stand on
//! the floor (`z = 0`) and rise to their `height`.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::Real;

/// A planar point `[x, y]` (m).
pub type Point2 = [Real; 2];

/// `a × b` of two planar vectors (the z of the 3D cross product).
#[inline]
pub fn cross2(a: Point2, b: Point2) -> Real {
    a[0] * b[1] - a[1] * b[0]
}

/// `a − b`.
#[inline]
pub fn sub2(a: Point2, b: Point2) -> Point2 {
    [a[0] - b[0], a[1] - b[1]]
}

/// Euclidean norm of a planar vector.
#[inline]
pub fn norm2(a: Point2) -> Real {
    a[0].hypot(a[1])
}

/// A planar pose: position `(x, y)` (m) and heading `yaw` (rad, counter-clockwise from `+x`).
///
/// ```
/// use shieldnav_core::world::Pose2;
/// let p = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
/// let w = p.transform_point([1.0, 0.0]);
/// assert!((w[0] - 1.0).abs() < 1e-12 && (w[1] - 3.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose2 {
    /// Position x (m).
    pub x: Real,
    /// Position y (m).
    pub y: Real,
    /// Heading (rad).
    pub yaw: Real,
}

impl Pose2 {
    /// A pose from its parts.
    pub const fn new(x: Real, y: Real, yaw: Real) -> Self {
        Self { x, y, yaw }
    }

    /// Maps a point from this pose's frame to the parent frame.
    #[inline]
    pub fn transform_point(&self, p: Point2) -> Point2 {
        let (s, c) = self.yaw.sin_cos();
        [self.x + c * p[0] - s * p[1], self.y + s * p[0] + c * p[1]]
    }

    /// Maps a point from the parent frame into this pose's frame.
    #[inline]
    pub fn inverse_transform_point(&self, p: Point2) -> Point2 {
        let (s, c) = self.yaw.sin_cos();
        let d = [p[0] - self.x, p[1] - self.y];
        [c * d[0] + s * d[1], -s * d[0] + c * d[1]]
    }

    /// `self ∘ other`: `other` expressed in this pose's frame, mapped to the parent frame.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let p = self.transform_point([other.x, other.y]);
        Pose2::new(p[0], p[1], wrap_angle(self.yaw + other.yaw))
    }

    /// The pose `d` with `self ∘ d = other`.
    pub fn between(&self, other: &Pose2) -> Pose2 {
        let p = self.inverse_transform_point([other.x, other.y]);
        Pose2::new(p[0], p[1], wrap_angle(other.yaw - self.yaw))
    }

    /// Checks that every component is finite; `name` is the argument reported on error.
    pub fn validate(&self, name: &'static str) -> Result<()> {
        if self.x.is_finite() && self.y.is_finite() && self.yaw.is_finite() {
            Ok(())
        } else {
            Err(Error::invalid(name, format!("pose components must be finite, got {self:?}")))
        }
    }
}

/// Wraps an angle to `(-π, π]`.
pub fn wrap_angle(a: Real) -> Real {
    use std::f64::consts::{PI, TAU};
    let mut r = a % TAU;
    if r > PI {
        r -= TAU;
    } else if r <= -PI {
        r += TAU;
    }
    r
}

/// A wall: the vertical rectangle over the segment `a → b`, from the floor to `height` (m).
///
/// A `one_sided` wall is the face of a solid lying on its left (seen from `a` toward `b`): a
/// sensor in free space can only see it from the right, so the LIDAR skips it from the left
/// (back-face culling). Walls traced from occupancy grids are one-sided; others are not.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Segment {
    /// First end point (m).
    pub a: Point2,
    /// Second end point (m).
    pub b: Point2,
    /// Top of the wall above the floor (m).
    pub height: Real,
    /// Whether the wall bounds a solid on its left and is only seen from its right.
    #[serde(default)]
    pub one_sided: bool,
}

impl Segment {
    /// A wall seen from both sides.
    pub const fn new(a: Point2, b: Point2, height: Real) -> Self {
        Self { a, b, height, one_sided: false }
    }

    /// The face of a solid lying to the left of `a → b`.
    pub const fn one_sided(a: Point2, b: Point2, height: Real) -> Self {
        Self { a, b, height, one_sided: true }
    }

    /// Whether a sensor at `p` can see this wall at all: always for two-sided walls, from the
    /// right of `a → b` (strictly) for one-sided ones.
    #[inline]
    pub fn faces(&self, p: Point2) -> bool {
        !self.one_sided || cross2(sub2(self.b, self.a), sub2(p, self.a)) < 0.0
    }

    /// Length (m).
    pub fn length(&self) -> Real {
        norm2(sub2(self.b, self.a))
    }

    /// Distance from `p` to the closest point of the segment (m).
    #[inline]
    pub fn distance_to_point(&self, p: Point2) -> Real {
        self.distance2_to_point(p).sqrt()
    }

    /// Squared distance from `p` to the closest point of the segment (m²).
    #[inline]
    pub fn distance2_to_point(&self, p: Point2) -> Real {
        let e = sub2(self.b, self.a);
        let w = sub2(p, self.a);
        let l2 = e[0] * e[0] + e[1] * e[1];
        let t = if l2 > 0.0 { ((w[0] * e[0] + w[1] * e[1]) / l2).clamp(0.0, 1.0) } else { 0.0 };
        let (dx, dy) = (w[0] - t * e[0], w[1] - t * e[1]);
        dx * dx + dy * dy
    }

    /// Checks finiteness, a positive height and distinct end points.
    pub fn validate(&self, name: &'static str) -> Result<()> {
        let finite = self.a.iter().chain(self.b.iter()).all(|v| v.is_finite());
        if !finite {
            return Err(Error::invalid(name, format!("end points must be finite, got {self:?}")));
        }
        if !(self.height.is_finite() && self.height > 0.0) {
            return Err(Error::invalid(name, format!("height must be finite and > 0, got {}", self.height)));
        }
        if self.a == self.b {
            return Err(Error::invalid(name, format!("end points coincide at {:?}", self.a)));
        }
        Ok(())
    }
}

/// A simple polygon (a piece of furniture, a pillar) extruded from the floor to `height`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Polygon {
    /// Vertices in order (either orientation), at least three, not repeated at the end.
    pub vertices: Vec<Point2>,
    /// Top above the floor (m).
    pub height: Real,
}

impl Polygon {
    /// The axis-aligned box `[x0, x1] × [y0, y1]`.
    pub fn rect(x0: Real, y0: Real, x1: Real, y1: Real, height: Real) -> Self {
        Self { vertices: vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]], height }
    }

    /// A `length × width` box centred on `pose`, its length along the pose's heading.
    pub fn oriented_box(pose: Pose2, length: Real, width: Real, height: Real) -> Self {
        let (hl, hw) = (0.5 * length, 0.5 * width);
        let vertices = [[-hl, -hw], [hl, -hw], [hl, hw], [-hl, hw]].iter().map(|&p| pose.transform_point(p)).collect();
        Self { vertices, height }
    }

    /// Signed area (m²): positive when the vertices run counter-clockwise.
    pub fn signed_area(&self) -> Real {
        let n = self.vertices.len();
        0.5 * (0..n).map(|i| cross2(self.vertices[i], self.vertices[(i + 1) % n])).sum::<Real>()
    }

    /// The closed boundary as one-sided walls, the solid inside on each wall's left (the
    /// polygon must be simple).
    pub fn edges(&self) -> impl Iterator<Item = Segment> + '_ {
        solid_edges(&self.vertices, self.height, self.signed_area() >= 0.0)
    }

    /// Whether `p` is strictly inside (even–odd rule).
    pub fn contains(&self, p: Point2) -> bool {
        let n = self.vertices.len();
        let mut inside = false;
        for i in 0..n {
            let a = self.vertices[i];
            let b = self.vertices[(i + 1) % n];
            if (a[1] > p[1]) != (b[1] > p[1]) {
                let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                if p[0] < x {
                    inside = !inside;
                }
            }
        }
        inside
    }

    /// Checks vertex count, finiteness and height, and that the outline is simple (no two
    /// edges but neighbours meet: a crossed outline has no inside to face).
    pub fn validate(&self, name: &'static str) -> Result<()> {
        let n = self.vertices.len();
        if n < 3 {
            return Err(Error::invalid(name, format!("needs at least 3 vertices, got {n}")));
        }
        for e in self.edges() {
            e.validate(name)?;
        }
        let v = &self.vertices;
        for i in 0..n {
            for j in i + 2..n {
                if i == 0 && j == n - 1 {
                    continue; // neighbours across the closing edge
                }
                if segments_cross(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n]) {
                    return Err(Error::invalid(name, format!("must be a simple polygon: its edges {i} and {j} meet ({:?} → {:?} and {:?} → {:?})", v[i], v[(i + 1) % n], v[j], v[(j + 1) % n])));
                }
            }
        }
        Ok(())
    }

    /// Whether the outline is convex (every turn the same way; straight corners allowed).
    pub fn is_convex(&self) -> bool {
        let v = &self.vertices;
        let n = v.len();
        let turns = (0..n).map(|i| cross2(sub2(v[(i + 1) % n], v[i]), sub2(v[(i + 2) % n], v[(i + 1) % n])));
        let (mut left, mut right) = (false, false);
        for t in turns {
            left |= t > 0.0;
            right |= t < 0.0;
        }
        !(left && right)
    }
}

/// Whether the segments `p → q` and `a → b` cross or touch (collinear ones if they overlap).
pub(crate) fn segments_cross(p: Point2, q: Point2, a: Point2, b: Point2) -> bool {
    let o = |u: Point2, v: Point2, w: Point2| (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0]);
    let (d1, d2, d3, d4) = (o(a, b, p), o(a, b, q), o(p, q, a), o(p, q, b));
    ((d1 > 0.0) != (d2 > 0.0) || d1 == 0.0 || d2 == 0.0) && ((d3 > 0.0) != (d4 > 0.0) || d3 == 0.0 || d4 == 0.0) && {
        // exclude parallel non-overlapping cases with a zero orientation
        let within = |u: Point2, v: Point2, w: Point2| w[0] >= u[0].min(v[0]) - 1e-15 && w[0] <= u[0].max(v[0]) + 1e-15 && w[1] >= u[1].min(v[1]) - 1e-15 && w[1] <= u[1].max(v[1]) + 1e-15;
        if d1 == 0.0 && d2 == 0.0 {
            within(a, b, p) || within(a, b, q) || within(p, q, a)
        } else {
            true
        }
    }
}

/// One-sided walls around the solid polygon `v` (counter-clockwise if `ccw`), solid on the left.
pub(crate) fn solid_edges(v: &[Point2], height: Real, ccw: bool) -> impl Iterator<Item = Segment> + '_ {
    let n = v.len();
    (0..n).map(move |i| {
        let (a, b) = (v[i], v[(i + 1) % n]);
        if ccw {
            Segment::one_sided(a, b, height)
        } else {
            Segment::one_sided(b, a, height)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_then_between_round_trips() {
        let a = Pose2::new(1.0, -2.0, 0.7);
        let b = Pose2::new(-3.0, 0.5, -2.9);
        let d = a.between(&b);
        let c = a.compose(&d);
        assert!((c.x - b.x).abs() < 1e-12 && (c.y - b.y).abs() < 1e-12);
        assert!(wrap_angle(c.yaw - b.yaw).abs() < 1e-12);
    }

    #[test]
    fn wrap_angle_lands_in_half_open_interval() {
        use std::f64::consts::PI;
        assert_eq!(wrap_angle(PI), PI);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-15);
        assert!((wrap_angle(3.0 * PI + 0.1) - (-PI + 0.1)).abs() < 1e-12);
    }

    #[test]
    fn segment_point_distance_uses_end_points_beyond_the_span() {
        let s = Segment::new([0.0, 0.0], [2.0, 0.0], 1.0);
        assert!((s.distance_to_point([1.0, 0.5]) - 0.5).abs() < 1e-15);
        assert!((s.distance_to_point([3.0, 0.0]) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn polygon_edges_face_outward_whatever_the_vertex_order() {
        for p in [Polygon::rect(0.0, 0.0, 1.0, 2.0, 1.0), Polygon { vertices: Polygon::rect(0.0, 0.0, 1.0, 2.0, 1.0).vertices.into_iter().rev().collect(), height: 1.0 }] {
            for e in p.edges() {
                let m = [0.5 * (e.a[0] + e.b[0]), 0.5 * (e.a[1] + e.b[1])];
                let out = [m[0] + 0.01 * (m[0] - 0.5).signum() * ((m[0] - 0.5).abs() > 0.4) as i32 as Real, m[1] + 0.01 * (m[1] - 1.0).signum() * ((m[1] - 1.0).abs() > 0.9) as i32 as Real];
                assert!(e.one_sided && e.faces(out) && !e.faces([0.5, 1.0]), "{e:?}");
            }
        }
    }

    #[test]
    fn polygon_contains_and_rejects() {
        let p = Polygon::rect(0.0, 0.0, 1.0, 2.0, 1.0);
        assert!(p.contains([0.5, 1.0]));
        assert!(!p.contains([1.5, 1.0]));
        assert_eq!(p.edges().count(), 4);
    }

    #[test]
    fn bad_segment_is_an_error() {
        assert!(Segment::new([0.0, 0.0], [0.0, 0.0], 1.0).validate("s").is_err());
        assert!(Segment::new([0.0, 0.0], [1.0, 0.0], 0.0).validate("s").is_err());
        assert!(Segment::new([f64::NAN, 0.0], [1.0, 0.0], 1.0).validate("s").is_err());
    }
}
