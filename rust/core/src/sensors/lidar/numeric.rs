//! Small numeric helpers of the beam sweeps: fast angle and rounding, the per-beam tests.

use super::super::ray_segment::ray_segment_distance;
use crate::math::Real;

/// One beam `(dc, ds)` of `Beams::sweep_flat` against the wall from `a` along `e` (`ae =
/// a × e`), nearest range so far `cur`: the new nearest range (the same test and quotient as
/// `Beams::sweep`), and whether the beam is parallel to the wall (then left unchanged).
#[inline(always)]
pub(crate) fn flat_beam(a: [Real; 2], e: [Real; 2], ae: Real, dc: Real, ds: Real, cur: Real) -> (Real, bool) {
    let den = dc * e[1] - ds * e[0];
    let sn = a[0] * ds - a[1] * dc;
    let hit = (den > 0.0) & (ae >= 0.0) & (sn >= 0.0) & (sn <= den) | (den < 0.0) & (ae <= 0.0) & (sn <= 0.0) & (sn >= den);
    let t = ae / den;
    (if hit & (t < cur) { t } else { cur }, den == 0.0)
}

/// The nearest range of beam `(dc, ds)` so far, `cur`, after the general hit test against the
/// wall `a b` if the beam is parallel to it (which the division-free test of
/// `Beams::sweep_flat` and its vector kernels leave unchanged); `cur` if not parallel.
#[inline]
pub(crate) fn parallel_beam(a: [Real; 2], b: [Real; 2], dc: Real, ds: Real, cur: Real) -> Real {
    let e = [b[0] - a[0], b[1] - a[1]];
    if dc * e[1] - ds * e[0] != 0.0 {
        return cur;
    }
    ray_segment_distance([0.0, 0.0], [dc, ds], a, b).map_or(cur, |t| cur.min(t))
}

/// Distance from the origin to the segment `a b`.
#[inline]
pub(crate) fn seg_origin_distance(a: [Real; 2], b: [Real; 2]) -> Real {
    let e = [b[0] - a[0], b[1] - a[1]];
    let l2 = e[0] * e[0] + e[1] * e[1];
    let t = if l2 > 0.0 { (-(a[0] * e[0] + a[1] * e[1]) / l2).clamp(0.0, 1.0) } else { 0.0 };
    let (x, y) = (a[0] + t * e[0], a[1] + t * e[1]);
    (x * x + y * y).sqrt()
}

/// `1.5 · 2^52`: for `|x| < 2^51`, `x + ROUND` is `x` rounded to an integer `n`, and its bits
/// less `ROUND`'s are `n`.
const ROUND: Real = 6_755_399_441_055_744.0;

/// `x.floor()` as an integer, for `|x| < 2^51`, without a libm call or a float–integer
/// conversion (`as` saturates and checks for NaN; `cvtsi2sd` waits on its register).
#[inline]
pub(crate) fn ifloor(x: Real) -> i64 {
    let y = x + ROUND;
    (y.to_bits() as i64 - ROUND.to_bits() as i64) - ((y - ROUND) > x) as i64
}

/// `x.ceil()` as an integer, for `|x| < 2^51`, like [`ifloor`].
#[inline]
pub(crate) fn iceil(x: Real) -> i64 {
    let y = x + ROUND;
    (y.to_bits() as i64 - ROUND.to_bits() as i64) + ((y - ROUND) < x) as i64
}

/// How far (rad) `Beams::wall_beams` widens a wall's angular interval: five times the error
/// bound of [`fast_atan2`] (tested), far below a beam step (3.1e-3 rad at 2048 columns).
pub(crate) const ANGLE_SLACK: Real = 1e-4;

/// Whether none of the `count` ranges from column `j0` (modulo their number, a power of two)
/// exceeds `d`.
#[inline]
pub(crate) fn none_beyond(ranges: &[Real], j0: i64, count: usize, d: Real) -> bool {
    let n = ranges.len();
    let i = (j0 & (n as i64 - 1)) as usize;
    let beyond = |s: &[Real]| s.iter().fold(false, |acc, &r| acc | (r > d));
    if i + count <= n {
        !beyond(&ranges[i..i + count])
    } else {
        !beyond(&ranges[i..]) && !beyond(&ranges[..i + count - n])
    }
}

/// The lesser of `a` and `b` (finite), as one instruction (`f64::min` also orders NaNs).
#[inline(always)]
pub(crate) fn min(a: Real, b: Real) -> Real {
    if a < b {
        a
    } else {
        b
    }
}

/// The greater of `a` and `b` (finite), as one instruction (`f64::max` also orders NaNs).
#[inline(always)]
pub(crate) fn max(a: Real, b: Real) -> Real {
    if a > b {
        a
    } else {
        b
    }
}

/// `atan2` to about 1e-5 rad: only used to pick the beams to test, with [`ANGLE_SLACK`] of
/// margin; the ranges themselves are exact. Written as selects, not
/// branches, so that the two end points of a wall are computed side by side.
#[inline]
pub(crate) fn fast_atan2(y: Real, x: Real) -> Real {
    atan2_by(y, x, |n, d| n / d)
}

/// [`fast_atan2`] with `quotient(n, d)` for the one division `n / d` (`0 <= n <= d`, `d > 0`):
/// a quotient within a relative `e` of it moves the angle by at most `e` rad more.
#[inline(always)]
pub(crate) fn atan2_by(y: Real, x: Real, quotient: impl Fn(Real, Real) -> Real) -> Real {
    use std::f64::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let steep = ay > ax;
    // (as selects, one instruction each: `f64::min` and `max` would also order NaNs)
    let (mn, mx) = if steep { (ax, ay) } else { (ay, ax) };
    // 0 at the origin (0 / MIN_POSITIVE)
    let q = quotient(mn, max(mx, Real::MIN_POSITIVE));
    let s = q * q;
    let mut r = ((0.020_845_09 * s - 0.085_156_31) * s + 0.180_159_28) * s - 0.330_304_79;
    r = (r * s + 0.999_866_33) * q;
    r = if steep { FRAC_PI_2 - r } else { r };
    r = if x < 0.0 { PI - r } else { r };
    if y < 0.0 {
        -r
    } else {
        r
    }
}
