//! The exact `f64` distance along a ray to a segment.

use crate::math::Real;
use crate::world::{cross2, Point2};

/// Distance `t ≥ 0` along the ray `o + t·d` to the segment `a b`, or `None` if it misses.
///
/// `d` need not be unit; `t` is in units of `|d|`. A ray collinear with the segment hits the
/// nearer end point ahead of `o`.
///
/// ```
/// use shieldnav_core::sensors::ray_segment_distance;
/// let t = ray_segment_distance([0.0, 0.0], [1.0, 0.0], [2.0, -1.0], [2.0, 1.0]).unwrap();
/// assert_eq!(t, 2.0);
/// ```
#[inline]
pub fn ray_segment_distance(o: Point2, d: Point2, a: Point2, b: Point2) -> Option<Real> {
    let e = [b[0] - a[0], b[1] - a[1]];
    let w = [a[0] - o[0], a[1] - o[1]];
    let den = cross2(d, e);
    if den == 0.0 {
        if cross2(w, d) != 0.0 {
            return None; // parallel, not collinear
        }
        let dd = d[0] * d[0] + d[1] * d[1];
        let ta = (w[0] * d[0] + w[1] * d[1]) / dd;
        let tb = ((b[0] - o[0]) * d[0] + (b[1] - o[1]) * d[1]) / dd;
        let t = match (ta >= 0.0, tb >= 0.0) {
            (true, true) => ta.min(tb),
            (false, false) => return None,
            _ => 0.0, // the origin lies on the segment
        };
        return Some(t);
    }
    let t = cross2(w, e) / den;
    let s = cross2(w, d) / den;
    (t >= 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perpendicular_hit_and_miss() {
        assert_eq!(ray_segment_distance([0.0, 0.0], [1.0, 0.0], [3.0, -1.0], [3.0, 1.0]), Some(3.0));
        assert_eq!(ray_segment_distance([0.0, 0.0], [-1.0, 0.0], [3.0, -1.0], [3.0, 1.0]), None);
        assert_eq!(ray_segment_distance([0.0, 0.0], [1.0, 0.0], [3.0, 0.5], [3.0, 1.0]), None);
    }

    #[test]
    fn collinear_ray_hits_the_nearer_end() {
        assert_eq!(ray_segment_distance([0.0, 0.0], [1.0, 0.0], [5.0, 0.0], [2.0, 0.0]), Some(2.0));
        assert_eq!(ray_segment_distance([0.0, 0.0], [1.0, 0.0], [-5.0, 0.0], [-2.0, 0.0]), None);
    }

    #[test]
    fn end_point_hit_counts() {
        assert_eq!(ray_segment_distance([0.0, 0.0], [1.0, 1.0], [1.0, 1.0], [2.0, 0.0]), Some(1.0));
    }
}
