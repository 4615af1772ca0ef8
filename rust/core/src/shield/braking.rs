//! The braking check of the `"braking"` shield: a command is sent only if, after one control
//! period of it, the robot can still brake to a stop with its ellipse free of every point.
//!
//! The body does not take the command as its velocity: the tracker follows it through a
//! first-order lag with acceleration limits ([`TrackerConfig::next_velocity`]), so from
//! 1.6 m/s the robot needs about 0.66 m to stop. The check is a backup-set argument on that
//! model, with braking (the command `0`) as the backup:
//!
//! 1. From the measured body velocity `v₀`, replay one period of the candidate command and
//!    then the brake until the robot stands, pose by pose as the body integrates
//!    (translation at the heading of the period's start, then the turn): poses `P₀ = 0, P₁,
//!    …, P_M` in the current body frame.
//! 2. Cover the ellipse along that path by one convex set: the ellipse turned to the path's
//!    middle heading `θ_ref`, grown by `ρ` (the path's largest distance `δ` from its chord
//!    `P₀P_M`, plus `2 r sin(φ/2)` for a turn of at most `φ` either side of `θ_ref`, `r` the
//!    longest semi-axis, plus the [`BrakingModel::brake_margin`]), swept along the chord. A disc of radius `ρ` added to an ellipse lies
//!    inside the ellipse with semi-axes [`grow`]`(a, b, ρ)`.
//! 3. The check value is the least `h` of the points against that swept ellipse, in closed
//!    form per point: with `q` and `S = P_M` in the `θ_ref` frame and `Q` the grown ellipse's
//!    shape, `t* = clamp(qᵀQS / SᵀQS, 0, 1)`, `h = (q − t*S)ᵀQ(q − t*S) − 1`.
//!
//! The candidate passes when the value is ≥ 0, or, when a point already lies within the
//! margin of the standing robot's ellipse (noise, a moving obstacle), when it is no lower
//! than that point's value there (up to [`WORSE`]): moving away stays allowed. Otherwise
//! the shield brakes, which is safe by induction: the state it brakes from passed the check one period earlier, the brake's
//! path from there is the tail of the path then checked, and static points do not move.
//! What the argument assumes: the body follows the tracker model (it does away from contact),
//! the points are static and were seen (the swept set is convex and holds the LIDAR, so
//! anything in it is in line of sight), and the control period and the tracker parameters
//! are the body's own.

use crate::error::{Error, Result};
use crate::robot::TrackerConfig;

use super::composite::Motion;
use super::lane::Lane;
use crate::simd::SimdLevel;

/// Longest brake replayed (control periods); the remaining displacement is bounded and added
/// to the growth beyond it.
const MAX_BRAKE_STEPS: usize = 20_000;
/// How much lower than the standing robot's value a candidate's may be while a point lies
/// within the margin (`h` units; about 2 mm at the default ellipse): the sweep of a robot
/// moving straight away starts at its current pose grown by the margin and the lag's tail.
pub const WORSE: f64 = 0.01;
/// The replay stops once what the lag can still move the robot is below this (m, rad).
const TAIL: f64 = 5e-4;

/// The tracker the shield protects, and its control period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrakingModel {
    /// Lag, speed and acceleration limits of the body's velocity tracker.
    pub tracker: TrackerConfig,
    /// Control period (s): a command is held this long.
    pub dt: f64,
    /// Clearance (m) the check keeps beyond the swept ellipse, for what the scan does not
    /// show exactly: range noise (3σ of the default LIDAR's 1 cm) and the gaps between beams.
    pub brake_margin: f64,
}

impl Default for BrakingModel {
    fn default() -> Self {
        Self { tracker: TrackerConfig::default(), dt: 0.02, brake_margin: 0.03 }
    }
}

impl BrakingModel {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<()> {
        self.tracker.validate()?;
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt <= 1.0) {
            return Err(Error::invalid("dt", format!("the control period must be in (0, 1] s, got {}", self.dt)));
        }
        if !(self.brake_margin.is_finite() && (0.0..=10.0).contains(&self.brake_margin)) {
            return Err(Error::invalid("brake_margin", format!("must be from 0 to 10 m, got {}", self.brake_margin)));
        }
        Ok(())
    }

    /// The region the ellipse covers while the robot, at body velocity `v0`, holds
    /// `command` for one period and then brakes to a stop (current body frame).
    pub fn sweep(&self, v0: [f64; 3], command: [f64; 3], semi_axes: [f64; 2]) -> Sweep {
        self.sweep_with(v0, command, semi_axes, &mut Vec::new())
    }

    /// [`BrakingModel::sweep`] with the replayed path kept in `path` (cleared first), a buffer
    /// the caller reuses from call to call.
    pub fn sweep_with(&self, v0: [f64; 3], command: [f64; 3], semi_axes: [f64; 2], path: &mut Vec<[f64; 2]>) -> Sweep {
        let t = &self.tracker;
        let dt = self.dt;
        let gain = t.gain(dt);
        let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
        path.clear();
        path.push([0.0, 0.0]);
        let (mut th_lo, mut th_hi) = (0.0f64, 0.0f64);
        let first_velocity = t.next_velocity(v0, command, gain, dt).0;
        let mut v = first_velocity;
        let mut steps = 0;
        // what the lag alone can still add once the acceleration limits no longer bind:
        // a geometric tail of `|v| dt (1 − gain) / gain`, bounded by `|v| dt / gain`
        let tail = |v: &[f64; 3]| (v[0].hypot(v[1]) * dt / gain, v[2].abs() * dt / gain);
        loop {
            let (s, c) = th.sin_cos();
            x += dt * (c * v[0] - s * v[1]);
            y += dt * (s * v[0] + c * v[1]);
            th += dt * v[2];
            path.push([x, y]);
            th_lo = th_lo.min(th);
            th_hi = th_hi.max(th);
            steps += 1;
            v = t.next_velocity(v, [0.0; 3], gain, dt).0;
            let lagging = (0..2).all(|k| v[k].abs() * gain <= t.a_max[k] * dt) && v[2].abs() * gain <= t.alpha_max * dt;
            let (rest, turn) = tail(&v);
            if (lagging && rest <= TAIL && turn <= TAIL) || steps >= MAX_BRAKE_STEPS {
                break;
            }
        }
        // beyond the replay: the lag's tail, or (cut short) the stopping distance at the
        // acceleration limit plus the lag's
        let (rest, turn) = if steps >= MAX_BRAKE_STEPS {
            let d = |v: f64, a: f64| v * v / (2.0 * a) + v.abs() * dt / gain;
            (d(v[0], t.a_max[0]).hypot(d(v[1], t.a_max[1])), d(v[2], t.alpha_max))
        } else {
            tail(&v)
        };
        let end = [x, y];
        let len2 = end[0] * end[0] + end[1] * end[1];
        let off_chord = |p: &[f64; 2]| {
            let s = if len2 > 0.0 { ((p[0] * end[0] + p[1] * end[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
            (p[0] - s * end[0]).hypot(p[1] - s * end[1])
        };
        let delta = path.iter().map(off_chord).fold(0.0, f64::max) + rest;
        let heading = 0.5 * (th_lo + th_hi);
        let half_turn = (0.5 * (th_hi - th_lo) + turn).min(std::f64::consts::PI);
        let r = semi_axes[0].max(semi_axes[1]);
        let rho = delta + 2.0 * r * (0.5 * half_turn).sin() + self.brake_margin;
        let grown = grow(semi_axes[0], semi_axes[1], rho);
        let (s, c) = heading.sin_cos();
        Sweep { chord: [c * end[0] + s * end[1], -s * end[0] + c * end[1]], heading, semi_axes: grown, growth: rho, here: grow(semi_axes[0], semi_axes[1], self.brake_margin), first_velocity, steps }
    }
}

/// Semi-axes of an ellipse that holds the ellipse `(a, b)` grown by a disc of radius `rho`.
///
/// With `m = min(a, b)`, the support function bound `2√X ≤ X/m + m` shows that
/// `(a + k_a ρ, b + k_b ρ)` holds the sum when `k` solves `k²ρ + 2ak = a²/m + m + ρ` for the
/// long axis (`k = 1` for the short one): the sum's support `√(a²c² + b²s²) + ρ` never
/// exceeds the grown ellipse's `√(a'²c² + b'²s²)` in any direction `(c, s)`.
pub fn grow(a: f64, b: f64, rho: f64) -> [f64; 2] {
    if rho <= 0.0 {
        return [a, b];
    }
    let m = a.min(b);
    let k = |l: f64| {
        // k²ρ + 2lk − (l²/m + m + ρ) = 0, the positive root (written to avoid cancellation)
        let c = l * l / m + m + rho;
        2.0 * c / (2.0 * l + (4.0 * l * l + 4.0 * rho * c).sqrt())
    };
    [a + k(a) * rho, b + k(b) * rho]
}

/// The ellipse swept from the robot's current pose to where it stands after braking, grown
/// to cover the path's bends and turns (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sweep {
    /// The chord from the current position to the stopping point, in the `heading` frame (m).
    pub chord: [f64; 2],
    /// The frame the grown ellipse is turned to (rad, from the current heading).
    pub heading: f64,
    /// The grown ellipse's semi-axes (m).
    pub semi_axes: [f64; 2],
    /// How much the path's bends and turns and the margin grew the ellipse by (m).
    pub growth: f64,
    /// The ellipse at the current pose grown by the margin alone: the standing robot's.
    pub here: [f64; 2],
    /// The body velocity after the candidate's period.
    pub first_velocity: [f64; 3],
    /// Control periods replayed.
    pub steps: usize,
}

impl Sweep {
    /// The least `h` of `pts` (rows of `stride`, moved by `motion` first, those farther than
    /// `crop` or outside the height band skipped, as the composite skips them) against the
    /// swept ellipse, and against the standing robot's ([`Sweep::here`]); `f64::MAX` without
    /// points.
    pub fn least_h<T: Lane>(&self, pts: &[T], stride: usize, motion: Option<Motion>, crop: f64, band: Option<(f64, f64)>) -> (f64, f64) {
        let ([least], here) = least_h_of(&[*self], pts, stride, motion, crop, band, SimdLevel::detect());
        (least, here)
    }
}

/// Points handled together by [`least_h_of`]: independent minima per lane, which the compiler
/// keeps in vector registers.
const LANES: usize = 8;

/// [`Sweep::least_h`] for `K` sweeps of one check in one pass over the points: the least `h`
/// against each sweep, and against the standing robot's ellipse (the first sweep's
/// [`Sweep::here`]; every sweep of one check has the same). Skipped points count as `f64::MAX`,
/// selected rather than branched over, so the loop vectorises (in AVX2 where `level` allows).
pub fn least_h_of<T: Lane, const K: usize>(sweeps: &[Sweep; K], pts: &[T], stride: usize, motion: Option<Motion>, crop: f64, band: Option<(f64, f64)>, level: SimdLevel) -> ([f64; K], f64) {
    #[cfg(target_arch = "x86_64")]
    if level != SimdLevel::Portable && SimdLevel::Avx2.is_supported() {
        // SAFETY: the CPU reports AVX2 and FMA, which this build enables.
        return unsafe { least_h_avx2(sweeps, pts, stride, motion, crop, band) };
    }
    let _ = level;
    least_h_body(sweeps, pts, stride, motion, crop, band)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn least_h_avx2<T: Lane, const K: usize>(sweeps: &[Sweep; K], pts: &[T], stride: usize, motion: Option<Motion>, crop: f64, band: Option<(f64, f64)>) -> ([f64; K], f64) {
    least_h_body(sweeps, pts, stride, motion, crop, band)
}

#[inline(always)]
fn least_h_body<T: Lane, const K: usize>(sweeps: &[Sweep; K], pts: &[T], stride: usize, motion: Option<Motion>, crop: f64, band: Option<(f64, f64)>) -> ([f64; K], f64) {
    // per sweep: heading (cos, sin), 1/a², 1/b², the chord and 1 / (chordᵀ A chord)
    let coeffs: [[f64; 7]; K] = std::array::from_fn(|k| {
        let sw = &sweeps[k];
        let (s, c) = sw.heading.sin_cos();
        let (ia, ib) = (1.0 / (sw.semi_axes[0] * sw.semi_axes[0]), 1.0 / (sw.semi_axes[1] * sw.semi_axes[1]));
        let (sx, sy) = (sw.chord[0], sw.chord[1]);
        let qs = sx * sx * ia + sy * sy * ib;
        [c, s, ia, ib, sx, sy, if qs > 0.0 { 1.0 / qs } else { 0.0 }]
    });
    let m = motion.unwrap_or(Motion { cos: 1.0, sin: 0.0, tx: 0.0, ty: 0.0 });
    let crop2 = crop * crop;
    let (z_lo, z_hi) = band.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    let here_axes = sweeps.first().map_or([1.0; 2], |s| s.here);
    let (ha, hb) = (1.0 / (here_axes[0] * here_axes[0]), 1.0 / (here_axes[1] * here_axes[1]));
    let value = |p: &[T]| -> ([f64; K], f64) {
        let (x, y) = m.apply(p[0], p[1]);
        let (x, y) = (x.to_f64(), y.to_f64());
        let z = if stride == 3 { p[2].to_f64() } else { 0.0 };
        let skip = x * x + y * y > crop2 || z < z_lo || z > z_hi;
        let least = std::array::from_fn(|k| {
            let [c, s, ia, ib, sx, sy, inv_qs] = coeffs[k];
            let (qx, qy) = (c * x + s * y, -s * x + c * y);
            let t = ((qx * sx * ia + qy * sy * ib) * inv_qs).clamp(0.0, 1.0);
            let (dx, dy) = (qx - t * sx, qy - t * sy);
            let h = dx * dx * ia + dy * dy * ib - 1.0;
            if skip {
                f64::MAX
            } else {
                h
            }
        });
        let here = x * x * ha + y * y * hb - 1.0;
        (least, if skip { f64::MAX } else { here })
    };
    let mut least = [[f64::MAX; LANES]; K];
    let mut here = [f64::MAX; LANES];
    let mut blocks = pts.chunks_exact(stride * LANES);
    for block in &mut blocks {
        for lane in 0..LANES {
            let (l, h) = value(&block[lane * stride..(lane + 1) * stride]);
            for k in 0..K {
                least[k][lane] = least[k][lane].min(l[k]);
            }
            here[lane] = here[lane].min(h);
        }
    }
    for p in blocks.remainder().chunks_exact(stride) {
        let (l, h) = value(p);
        for k in 0..K {
            least[k][0] = least[k][0].min(l[k]);
        }
        here[0] = here[0].min(h);
    }
    let fold = |v: &[f64; LANES]| v.iter().copied().fold(f64::MAX, f64::min);
    (std::array::from_fn(|k| fold(&least[k])), fold(&here))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grown_ellipse_holds_the_disc_sum_in_every_direction() {
        for (a, b) in [(0.9, 0.45), (0.45, 0.9), (1.0, 0.1), (0.5, 0.5), (2.0, 0.3)] {
            for rho in [1e-4, 0.01, 0.15, 1.0, 5.0] {
                let [ga, gb] = grow(a, b, rho);
                for k in 0..3600 {
                    let th = k as f64 * std::f64::consts::TAU / 3600.0;
                    let (s, c) = th.sin_cos();
                    let sum = (a * a * c * c + b * b * s * s).sqrt() + rho;
                    let big = (ga * ga * c * c + gb * gb * s * s).sqrt();
                    assert!(big >= sum - 1e-12, "({a}, {b}) + {rho}: {big} < {sum} at {th}");
                }
            }
        }
    }

    #[test]
    fn a_straight_brake_from_full_speed_ends_where_the_tracker_stops() {
        let model = BrakingModel { brake_margin: 0.0, ..BrakingModel::default() };
        let sw = model.sweep([1.6, 0.0, 0.0], [1.6, 0.0, 0.0], [0.9, 0.45]);
        // replay the tracker itself: one period of the command, then the brake
        let mut t = crate::robot::Tracker::new(model.tracker).unwrap();
        t.set_velocity([1.6, 0.0, 0.0]);
        let mut x = 0.0;
        x += t.step([1.6, 0.0, 0.0], model.dt).unwrap().velocity[0] * model.dt;
        for _ in 0..2000 {
            x += t.step([0.0; 3], model.dt).unwrap().velocity[0] * model.dt;
        }
        assert!(x > 0.6 && x < 0.75, "stopping distance {x}");
        assert!(sw.chord[0] <= x && sw.chord[0] >= x - 2.0 * TAIL, "{} vs {x}", sw.chord[0]);
        assert!(sw.chord[1].abs() < 1e-12 && sw.heading == 0.0);
        assert!(sw.growth <= TAIL + 1e-12, "a straight brake grows only by the tail: {}", sw.growth);
        // a wall point just past the stopping ellipse's nose passes, one inside fails
        let nose = x + 0.9;
        assert!(sw.least_h(&[nose + 0.01, 0.0], 2, None, f64::INFINITY, None).0 > 0.0);
        assert!(sw.least_h(&[nose - 0.01, 0.0], 2, None, f64::INFINITY, None).0 < 0.0);
    }

    #[test]
    fn turning_grows_the_ellipse_and_the_path_stays_inside() {
        let model = BrakingModel::default();
        let (a, b) = (0.9, 0.45);
        let sw = model.sweep([1.2, 0.3, 1.5], [1.6, 0.8, 1.5], [a, b]);
        assert!(sw.growth > 0.05, "{sw:?}");
        // every ellipse point of every replayed pose lies inside the swept, grown ellipse
        let mut t = crate::robot::Tracker::new(model.tracker).unwrap();
        t.set_velocity([1.2, 0.3, 1.5]);
        let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
        let mut cmd = [1.6, 0.8, 1.5];
        for _ in 0..400 {
            let v = t.step(cmd, model.dt).unwrap().velocity;
            cmd = [0.0; 3];
            let (s, c) = th.sin_cos();
            x += model.dt * (c * v[0] - s * v[1]);
            y += model.dt * (s * v[0] + c * v[1]);
            th += model.dt * v[2];
            let (s, c) = th.sin_cos();
            for k in 0..72 {
                let e = k as f64 * std::f64::consts::TAU / 72.0;
                let (ex, ey) = (0.999 * a * e.cos(), 0.999 * b * e.sin());
                let p = [x + c * ex - s * ey, y + s * ex + c * ey];
                assert!(sw.least_h(&p, 2, None, f64::INFINITY, None).0 < 0.0, "pose ({x}, {y}, {th}) leaves the sweep at {p:?}");
            }
        }
    }
}
