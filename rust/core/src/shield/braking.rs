//! The braking check of the `"braking"` shield: a command is sent only if, after one control
//! period of it, the robot can still brake to a stop with its *footprint* (a convex polygon,
//! grown by the clearance the check keeps) free of every point.
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
//! 2. Cover the footprint along that path by one convex set: the footprint turned to the
//!    path's middle heading `θ_ref`, swept along the chord `P₀P_M` (a polygon `F ⊕ [0, S]`),
//!    grown by `ρ`: the path's largest distance `δ` from its chord plus `2 r sin(φ/2)` for a
//!    turn of at most `φ` either side of `θ_ref`, `r` the footprint's largest vertex radius.
//! 3. The check value is the least clearance of the points to that set, each in closed form:
//!    the largest of the set's half-plane distances `nᵀq − h(n)` (the footprint's edge
//!    normals with `h(n) = h_F(n) + max(0, nᵀS)`, and the two normals across the chord), less
//!    `ρ`. Inside the polygon it is the exact signed distance; outside it is at most the true
//!    distance, so the test is conservative at the polygon's corners.
//!
//! A candidate passes when that value is at least the clearance required, the
//! [`BrakingModel::clearance`] (`brake_margin` plus three standard deviations of the range
//! noise). When a point already lies closer than that to the standing footprint (noise, a
//! start beside a wall, something that moved), only commands that bring no point nearer than
//! the nearest one is pass: the swept polygon's clearance is at least the standing one and
//! the growth at most [`TOLERANCE`]. The least clearance then never shrinks, so no sequence
//! of small steps can ratchet the footprint onto a point. Braking is safe by
//! induction: the state it brakes from passed the check one period earlier, the brake's path
//! from there is the tail of the path then checked, and static points do not move.
//! What the argument assumes: the body follows the tracker model (it does away from contact),
//! the points are static and were seen (the swept set is convex and holds the LIDAR, so
//! anything in it is in line of sight), the footprint holds the body, and the control period
//! and the tracker parameters are the body's own.

use crate::error::{Error, Result};
use crate::robot::TrackerConfig;
use crate::sensors::Mover;

use super::composite::Motion;
use super::lane::Lane;
use crate::simd::SimdLevel;

/// Longest brake replayed (control periods); the remaining displacement is bounded and added
/// to the growth beyond it.
const MAX_BRAKE_STEPS: usize = 20_000;
/// How far (m) the growth of a candidate's sweep (the path's bends, the turn either side of
/// the middle heading, the lag's tail) may reach while a point lies within the required
/// clearance: a straight motion away from the point passes, a turn toward it does not.
pub const TOLERANCE: f64 = 1e-3;
/// Most vertices a footprint polygon may have.
pub const MAX_FOOTPRINT_VERTICES: usize = 16;
/// Half-planes of one swept footprint: its edges and the two across the chord.
const MAX_PLANES: usize = MAX_FOOTPRINT_VERTICES + 2;

/// The robot's footprint: a convex polygon in the body frame (m, x along the heading)
/// holding the body's origin, counter-clockwise. The braking check keeps it, grown by the
/// required clearance, off every point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    vertices: [[f64; 2]; MAX_FOOTPRINT_VERTICES],
    len: usize,
    /// Outward unit edge normals and their offsets `h(n)`, and the largest vertex radius.
    normals: [[f64; 2]; MAX_FOOTPRINT_VERTICES],
    offsets: [f64; MAX_FOOTPRINT_VERTICES],
    radius: f64,
}

impl Default for Footprint {
    /// The default body: a 1.1 × 0.5 m rectangle (Spot).
    fn default() -> Self {
        Self::rectangle(1.1, 0.5).expect("the default rectangle is valid")
    }
}

impl Footprint {
    /// A `length × width` rectangle (m) centred on the body's origin, length along the heading.
    pub fn rectangle(length: f64, width: f64) -> Result<Self> {
        if !(length.is_finite() && length > 0.0 && width.is_finite() && width > 0.0) {
            return Err(Error::invalid("footprint", format!("the rectangle's length and width must be finite and > 0, got {length} × {width}")));
        }
        let (l, w) = (0.5 * length, 0.5 * width);
        Self::polygon(&[[l, w], [-l, w], [-l, -w], [l, -w]])
    }

    /// A convex polygon of 3 to [`MAX_FOOTPRINT_VERTICES`] vertices (either winding, as Nav2's
    /// `footprint` lists them) that holds the origin strictly inside.
    pub fn polygon(vertices: &[[f64; 2]]) -> Result<Self> {
        let bad = |msg: String| Err(Error::invalid("footprint", msg));
        let n = vertices.len();
        if !(3..=MAX_FOOTPRINT_VERTICES).contains(&n) {
            return bad(format!("a polygon of 3 to {MAX_FOOTPRINT_VERTICES} vertices is needed, got {n}"));
        }
        if !vertices.iter().flatten().all(|v| v.is_finite() && v.abs() <= 100.0) {
            return bad(format!("vertices must be finite and within 100 m of the origin, got {vertices:?}"));
        }
        let cross = |k: usize| {
            let (a, b, c) = (vertices[k], vertices[(k + 1) % n], vertices[(k + 2) % n]);
            (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
        };
        let area2: f64 = (0..n).map(|k| vertices[k][0] * vertices[(k + 1) % n][1] - vertices[(k + 1) % n][0] * vertices[k][1]).sum();
        let sign = area2.signum();
        if area2.abs() < 1e-6 || (0..n).any(|k| cross(k) * sign <= 0.0) {
            return bad(format!("the polygon must be convex with no repeated or collinear vertices, got {vertices:?}"));
        }
        let mut out = Self { vertices: [[0.0; 2]; MAX_FOOTPRINT_VERTICES], len: n, normals: [[0.0; 2]; MAX_FOOTPRINT_VERTICES], offsets: [0.0; MAX_FOOTPRINT_VERTICES], radius: 0.0 };
        for k in 0..n {
            // counter-clockwise
            out.vertices[k] = if sign > 0.0 { vertices[k] } else { vertices[n - 1 - k] };
        }
        for k in 0..n {
            let (a, b) = (out.vertices[k], out.vertices[(k + 1) % n]);
            let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
            let l = ex.hypot(ey);
            out.normals[k] = [ey / l, -ex / l];
            out.offsets[k] = out.normals[k][0] * a[0] + out.normals[k][1] * a[1];
        }
        out.radius = out.vertices().iter().map(|v| v[0].hypot(v[1])).fold(0.0, f64::max);
        if out.edges().any(|(nrm, off)| off <= 1e-6 || !(nrm[0].is_finite() && nrm[1].is_finite())) {
            return bad(format!("the polygon must hold the robot's origin strictly inside, got {vertices:?}"));
        }
        Ok(out)
    }

    /// The vertices, counter-clockwise (m, body frame).
    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.vertices[..self.len]
    }

    /// The largest distance of a vertex from the origin (m): every point of the footprint
    /// lies within it.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The outward unit normals of the edges and their offsets `h(n) = max_v nᵀv`.
    pub fn edges(&self) -> impl Iterator<Item = ([f64; 2], f64)> + '_ {
        (0..self.len).map(move |k| (self.normals[k], self.offsets[k]))
    }

    /// The support function `h(n) = max_v nᵀv`.
    pub fn support(&self, n: [f64; 2]) -> f64 {
        self.vertices().iter().map(|v| n[0] * v[0] + n[1] * v[1]).fold(f64::NEG_INFINITY, f64::max)
    }

    /// The clearance (m) of the point `q` (body frame) to the footprint: the largest edge
    /// distance `nᵀq − h(n)`, the signed distance inside, at most the distance outside.
    pub fn clearance(&self, q: [f64; 2]) -> f64 {
        self.edges().map(|(n, off)| n[0] * q[0] + n[1] * q[1] - off).fold(f64::NEG_INFINITY, f64::max)
    }
}

/// The tracker the shield protects, its control period, and its footprint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrakingModel {
    /// Lag, speed and acceleration limits of the body's velocity tracker.
    pub tracker: TrackerConfig,
    /// Control period (s): a command is held this long.
    pub dt: f64,
    /// Clearance (m) the check keeps between the footprint and every point beyond the range
    /// noise's: the gaps between beams and what the footprint does not model.
    pub brake_margin: f64,
    /// Standard deviation (m) of the LIDAR's range noise: the check keeps three of them more.
    pub lidar_noise_std: f64,
    /// The body's outline (body frame).
    pub footprint: Footprint,
}

impl Default for BrakingModel {
    fn default() -> Self {
        Self { tracker: TrackerConfig::default(), dt: 0.02, brake_margin: 0.01, lidar_noise_std: 0.01, footprint: Footprint::default() }
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
        if !(self.lidar_noise_std.is_finite() && (0.0..=1.0).contains(&self.lidar_noise_std)) {
            return Err(Error::invalid("lidar_noise_std", format!("must be from 0 to 1 m, got {}", self.lidar_noise_std)));
        }
        Ok(())
    }

    /// The clearance (m) the check keeps: `brake_margin + 3 lidar_noise_std`.
    pub fn clearance(&self) -> f64 {
        self.brake_margin + 3.0 * self.lidar_noise_std
    }

    /// The region the footprint covers while the robot, at body velocity `v0`, holds
    /// `command` for one period and then brakes to a stop (current body frame).
    pub fn sweep(&self, v0: [f64; 3], command: [f64; 3]) -> Sweep {
        self.sweep_with(v0, command, &mut Vec::new())
    }

    /// [`BrakingModel::sweep`] with the replayed path kept in `path` (cleared first), a buffer
    /// the caller reuses from call to call.
    pub fn sweep_with(&self, v0: [f64; 3], command: [f64; 3], path: &mut Vec<[f64; 2]>) -> Sweep {
        self.sweep_steered(v0, 1, path, |_, _, _| command)
    }

    /// [`BrakingModel::sweep_with`] with the command held `hold` periods (at least one) before
    /// the brake, each period's given by `steer` from the heading reached (rad, from the
    /// current one) and its sine and cosine.
    pub fn sweep_steered(&self, v0: [f64; 3], hold: usize, path: &mut Vec<[f64; 2]>, steer: impl Fn(f64, f64, f64) -> [f64; 3]) -> Sweep {
        let command = steer(0.0, 0.0, 1.0);
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
        let tail = |v: &[f64; 3]| ((v[0] * v[0] + v[1] * v[1]).sqrt() * dt / gain, v[2].abs() * dt / gain);
        let (mut s, mut c) = (0.0f64, 1.0f64);
        loop {
            x += dt * (c * v[0] - s * v[1]);
            y += dt * (s * v[0] + c * v[1]);
            let turn = dt * v[2];
            th += turn;
            (s, c) = turned(s, c, turn, th);
            path.push([x, y]);
            th_lo = th_lo.min(th);
            th_hi = th_hi.max(th);
            steps += 1;
            let held = steps < hold;
            v = t.next_velocity(v, if held { steer(th, s, c) } else { [0.0; 3] }, gain, dt).0;
            // once the acceleration limits no longer bind, every component decays by the same
            // factor `1 − gain` per period: the rest of the path is summed in closed form below
            let lagging = !held && (0..2).all(|k| v[k].abs() * gain <= t.a_max[k] * dt) && v[2].abs() * gain <= t.alpha_max * dt;
            if lagging || steps >= MAX_BRAKE_STEPS {
                break;
            }
        }
        let (rest, turn) = if steps >= MAX_BRAKE_STEPS {
            // cut short: the stopping distance at the acceleration limit plus the lag's
            let d = |v: f64, a: f64| v * v / (2.0 * a) + v.abs() * dt / gain;
            (d(v[0], t.a_max[0]).hypot(d(v[1], t.a_max[1])), d(v[2], t.alpha_max))
        } else {
            // the geometric tail `Σ dt v (1 − gain)ⁿ = dt v / gain`, straight at the current
            // heading; the tail's own turn `φ = dt |ω| / gain` bends it by at most its length
            // times φ
            let (len, phi) = tail(&v);
            let k = dt / gain;
            x += k * (c * v[0] - s * v[1]);
            y += k * (s * v[0] + c * v[1]);
            path.push([x, y]);
            (len * phi, phi)
        };
        let end = [x, y];
        let len2 = end[0] * end[0] + end[1] * end[1];
        let inv = if len2 > 0.0 { 1.0 / len2 } else { 0.0 };
        let off_chord2 = |p: &[f64; 2]| {
            let s = ((p[0] * end[0] + p[1] * end[1]) * inv).clamp(0.0, 1.0);
            let (dx, dy) = (p[0] - s * end[0], p[1] - s * end[1]);
            dx * dx + dy * dy
        };
        let delta = path.iter().map(off_chord2).fold(0.0, f64::max).sqrt() + rest;
        let heading = 0.5 * (th_lo + th_hi);
        let half_turn = (0.5 * (th_hi - th_lo) + turn).min(std::f64::consts::PI);
        let growth = delta + 2.0 * self.footprint.radius() * (0.5 * half_turn).sin();
        Sweep::new(&self.footprint, end, heading, growth, first_velocity, steps)
    }
}

/// Speed (m/s) below which the replayed body counts as standing: a mover reaching it later
/// reaches a robot at rest.
pub const REST_SPEED: f64 = 0.02;

impl BrakingModel {
    /// The least margin (m) between the standing footprint and the movers over the next
    /// `horizon` seconds (checked every period), with the same growth as
    /// [`BrakingModel::mover_margin`]: below the clearance, a mover is coming at the robot.
    pub fn standing_mover_margin(&self, movers: &[Mover], accel: f64, horizon: f64) -> f64 {
        let mut worst = f64::INFINITY;
        let steps = (horizon / self.dt).ceil() as usize;
        for k in 0..=steps {
            let time = k as f64 * self.dt;
            for m in movers {
                let q = [m.centre[0] + time * m.velocity[0], m.centre[1] + time * m.velocity[1]];
                let spread = m.velocity_std * time + 0.5 * accel * time * time + 0.5 * self.dt * m.velocity[0].hypot(m.velocity[1]);
                worst = worst.min(self.footprint.clearance(q) - m.radius - spread);
            }
        }
        worst
    }

    /// The least margin (m) between the footprint and the movers along the replay of
    /// `command` (one period) and the brake, over the periods in which the body still moves
    /// (faster than [`REST_SPEED`]): the footprint's clearance of each mover's centre,
    /// predicted along its velocity, less its radius, less what its velocity's error and an
    /// acceleration up to `accel` (m/s²) can add by then (`σ_v t + a t²/2`), less half of
    /// what body and mover move within a period (the poses are checked once per period).
    /// `f64::INFINITY` when the body stands throughout. A candidate whose margin is at least
    /// [`BrakingModel::clearance`] leaves the robot at rest before any mover that keeps to
    /// those bounds reaches it: passive safety.
    pub fn mover_margin(&self, v0: [f64; 3], command: [f64; 3], movers: &[Mover], accel: f64) -> f64 {
        self.mover_margin_steered(v0, 1, movers, accel, |_, _, _| command)
    }

    /// [`BrakingModel::mover_margin`] with the command held `hold` periods (at least one)
    /// before the brake, each period's given by `steer` from the heading reached (rad, from
    /// the current one) and its sine and cosine.
    pub fn mover_margin_steered(&self, v0: [f64; 3], hold: usize, movers: &[Mover], accel: f64, steer: impl Fn(f64, f64, f64) -> [f64; 3]) -> f64 {
        let command = steer(0.0, 0.0, 1.0);
        if movers.is_empty() {
            return f64::INFINITY;
        }
        let t = &self.tracker;
        let dt = self.dt;
        let gain = t.gain(dt);
        let fp = &self.footprint;
        let r = fp.radius();
        let speed = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1]).sqrt() + r * v[2].abs();
        let moving = |v: &[f64; 3]| speed(v) > REST_SPEED;
        let mut worst = f64::INFINITY;
        let mut check = |time: f64, x: f64, y: f64, s: f64, c: f64, v: &[f64; 3]| {
            let own = 0.5 * dt * speed(v);
            for m in movers {
                let (dx, dy) = (m.centre[0] + time * m.velocity[0] - x, m.centre[1] + time * m.velocity[1] - y);
                let q = [c * dx + s * dy, -s * dx + c * dy];
                // (`sqrt`, not `hypot`: this runs per replayed period and mover)
                let half = 0.5 * dt * (m.velocity[0] * m.velocity[0] + m.velocity[1] * m.velocity[1]).sqrt();
                let spread = m.velocity_std * time + 0.5 * accel * time * time + own + half;
                worst = worst.min(fp.clearance(q) - m.radius - spread);
            }
        };
        if moving(&v0) {
            check(0.0, 0.0, 0.0, 0.0, 1.0, &v0);
        }
        let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
        let (mut s, mut c) = (0.0f64, 1.0f64);
        let mut v = t.next_velocity(v0, command, gain, dt).0;
        let mut steps = 0;
        while (steps + 1 < hold || moving(&v)) && steps < MAX_BRAKE_STEPS {
            x += dt * (c * v[0] - s * v[1]);
            y += dt * (s * v[0] + c * v[1]);
            let turn = dt * v[2];
            th += turn;
            (s, c) = turned(s, c, turn, th);
            steps += 1;
            check(steps as f64 * dt, x, y, s, c, &v);
            v = t.next_velocity(v, if steps < hold { steer(th, s, c) } else { [0.0; 3] }, gain, dt).0;
        }
        worst
    }
}

/// `(sin, cos)` of `θ + δ` from those of `θ`, the new angle being `th`: by the rotation's
/// Taylor series where `|δ| ≤ 0.1` (terms to `δ⁷`: exact to rounding), else by `sin_cos`. The
/// replay turns by `ω dt` per step, a few hundredths of a radian, so this spares a `sin_cos`
/// per step, most of the replay's cost.
#[inline(always)]
fn turned(s: f64, c: f64, delta: f64, th: f64) -> (f64, f64) {
    if delta.abs() > 0.1 {
        return th.sin_cos();
    }
    let d2 = delta * delta;
    let sd = delta * (1.0 - d2 * (1.0 / 6.0) * (1.0 - d2 * (1.0 / 20.0) * (1.0 - d2 * (1.0 / 42.0))));
    let cd = 1.0 - d2 * 0.5 * (1.0 - d2 * (1.0 / 12.0) * (1.0 - d2 * (1.0 / 30.0) * (1.0 - d2 * (1.0 / 56.0))));
    (s * cd + c * sd, c * cd - s * sd)
}

/// Half-planes `nᵀq ≤ off` of a convex set, in the current body frame: a point's clearance to
/// the set is at least the largest `nᵀq − off`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planes {
    len: usize,
    nx: [f64; MAX_PLANES],
    ny: [f64; MAX_PLANES],
    off: [f64; MAX_PLANES],
    /// A circle holding the set (grown by the sweep's growth): points farther than `cull`
    /// beyond it are not near it, whatever their half-plane values.
    center: [f64; 2],
    radius: f64,
}

impl Planes {
    /// The footprint's own edges: the standing robot (never culled: its clearance is reported
    /// for every point within reach).
    pub fn of_footprint(fp: &Footprint) -> Self {
        let mut p = Self { len: 0, nx: [0.0; MAX_PLANES], ny: [0.0; MAX_PLANES], off: [0.0; MAX_PLANES], center: [0.0; 2], radius: f64::INFINITY };
        for (n, off) in fp.edges() {
            p.push(n, off);
        }
        p
    }

    fn push(&mut self, n: [f64; 2], off: f64) {
        (self.nx[self.len], self.ny[self.len], self.off[self.len]) = (n[0], n[1], off);
        self.len += 1;
    }

    /// The largest `nᵀq − off` (the clearance of `q`, exact inside the set).
    pub fn clearance(&self, q: [f64; 2]) -> f64 {
        (0..self.len).map(|k| self.nx[k] * q[0] + self.ny[k] * q[1] - self.off[k]).fold(f64::NEG_INFINITY, f64::max)
    }

    /// [`Planes::clearance`] of a point within `cull` of the set's circle, `f64::MAX` for one
    /// farther (it is more than `cull` from the set): what [`clearances_of`] computes.
    pub fn culled_clearance(&self, q: [f64; 2], cull: f64) -> f64 {
        let (dx, dy) = (q[0] - self.center[0], q[1] - self.center[1]);
        let r = self.radius + cull;
        if dx * dx + dy * dy <= r * r {
            self.clearance(q)
        } else {
            f64::MAX
        }
    }
}

/// The footprint swept from the robot's current pose to where it stands after braking, and
/// the growth that covers the path's bends and turns (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sweep {
    /// The chord from the current position to the stopping point (m, current body frame).
    pub chord: [f64; 2],
    /// The heading the footprint is turned to (rad, from the current heading).
    pub heading: f64,
    /// How far the path's bends and turns can take the footprint beyond the swept polygon (m).
    pub growth: f64,
    /// The farthest any point of the swept set lies from the current position (m).
    pub extent: f64,
    /// The body velocity after the candidate's period.
    pub first_velocity: [f64; 3],
    /// Control periods replayed.
    pub steps: usize,
    /// The swept polygon `R(θ)F ⊕ [0, chord]`.
    pub planes: Planes,
}

impl Sweep {
    fn new(fp: &Footprint, chord: [f64; 2], heading: f64, growth: f64, first_velocity: [f64; 3], steps: usize) -> Self {
        let (s, c) = heading.sin_cos();
        let turn = |n: [f64; 2]| [c * n[0] - s * n[1], s * n[0] + c * n[1]];
        let len = chord[0].hypot(chord[1]);
        let center = [0.5 * chord[0], 0.5 * chord[1]];
        let mut planes = Planes { len: 0, nx: [0.0; MAX_PLANES], ny: [0.0; MAX_PLANES], off: [0.0; MAX_PLANES], center, radius: 0.5 * len + fp.radius() + growth };
        for (n, off) in fp.edges() {
            let n = turn(n);
            planes.push(n, off + (n[0] * chord[0] + n[1] * chord[1]).max(0.0));
        }
        if len > 1e-9 {
            for sign in [1.0, -1.0] {
                let n = [-sign * chord[1] / len, sign * chord[0] / len];
                // the footprint's support across the chord, in its turned frame
                let back = [c * n[0] + s * n[1], -s * n[0] + c * n[1]];
                planes.push(n, fp.support(back));
            }
        }
        Self { chord, heading, growth, extent: len + fp.radius() + growth, first_velocity, steps, planes }
    }

    /// The clearance (m) of the point `q` (current body frame) to the swept set: the swept
    /// polygon's half-plane clearance less the growth.
    pub fn clearance(&self, q: [f64; 2]) -> f64 {
        self.planes.clearance(q) - self.growth
    }
}

/// Points handled together by [`clearances_of`].
const LANES: usize = 16;

/// Where [`clearances_of`] takes its points from and which it keeps.
#[derive(Debug, Clone, Copy)]
pub struct PointSet<'a, T> {
    /// Rows of `stride` (2 or 3) coordinates, in the scan's frame.
    pub pts: &'a [T],
    /// Coordinates per point.
    pub stride: usize,
    /// Moves the points into the current body frame first.
    pub motion: Option<Motion>,
    /// Points farther than this (m, after the motion) are ignored: the shield's crop and the
    /// sweeps' reach.
    pub reach: f64,
    /// For 3-D points: only `z_lo ≤ z ≤ z_hi` count.
    pub band: Option<(f64, f64)>,
}

/// The least [`Planes::culled_clearance`] of the points of `set` to each of `K` convex sets,
/// and to the standing footprint `here` (`f64::MAX` without points), in one pass in lanes of
/// `T`; the points within the reach, moved, are appended to `near` (rows of 2) when given.
/// Blocks of points all beyond the reach, or all farther than `cull` from a set's circle, skip
/// that set's half-planes. Runs the AVX-512 or AVX2 build where `level` and the CPU allow.
pub fn clearances_of<T: Lane, const K: usize>(sets: [&Planes; K], here: &Planes, set: PointSet<'_, T>, near: Option<&mut Vec<T>>, cull: f64, level: SimdLevel) -> ([f64; K], f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if level == SimdLevel::Avx512 && SimdLevel::Avx512.is_supported() {
            // SAFETY: the CPU reports AVX-512 F/VL/DQ, AVX2 and FMA.
            return unsafe { clearances_avx512(sets, here, set, near, cull) };
        }
        if level != SimdLevel::Portable && SimdLevel::Avx2.is_supported() {
            // SAFETY: the CPU reports AVX2 and FMA.
            return unsafe { clearances_avx2(sets, here, set, near, cull) };
        }
    }
    let _ = level;
    clearances_body(sets, here, set, near, cull)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn clearances_avx2<T: Lane, const K: usize>(sets: [&Planes; K], here: &Planes, set: PointSet<'_, T>, near: Option<&mut Vec<T>>, cull: f64) -> ([f64; K], f64) {
    clearances_body(sets, here, set, near, cull)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
fn clearances_avx512<T: Lane, const K: usize>(sets: [&Planes; K], here: &Planes, set: PointSet<'_, T>, near: Option<&mut Vec<T>>, cull: f64) -> ([f64; K], f64) {
    clearances_body(sets, here, set, near, cull)
}

/// Half-planes in `T`.
struct LanePlanes<T> {
    len: usize,
    nx: [T; MAX_PLANES],
    ny: [T; MAX_PLANES],
    off: [T; MAX_PLANES],
    cx: T,
    cy: T,
    r2: T,
}

impl<T: Lane> LanePlanes<T> {
    fn of(p: &Planes, cull: f64) -> Self {
        let r = p.radius + cull;
        Self { len: p.len, nx: p.nx.map(T::from_f64), ny: p.ny.map(T::from_f64), off: p.off.map(T::from_f64), cx: T::from_f64(p.center[0]), cy: T::from_f64(p.center[1]), r2: T::from_f64(r * r) }
    }

    /// The least over the lanes kept in `ok` and within the circle of the largest
    /// `nᵀq − off`, folded into `acc`.
    #[inline(always)]
    fn fold(&self, xs: &[T; LANES], ys: &[T; LANES], ok: &[bool; LANES], acc: &mut [T; LANES]) {
        let mut inside = [false; LANES];
        for l in 0..LANES {
            let (dx, dy) = (xs[l] - self.cx, ys[l] - self.cy);
            inside[l] = ok[l] & (dx * dx + dy * dy <= self.r2);
        }
        if !inside.iter().any(|&b| b) {
            return;
        }
        let ok = &inside;
        let mut m = [-T::INF; LANES];
        for k in 0..self.len {
            let (nx, ny, off) = (self.nx[k], self.ny[k], self.off[k]);
            for l in 0..LANES {
                let v = nx * xs[l] + ny * ys[l] - off;
                m[l] = if v > m[l] { v } else { m[l] };
            }
        }
        for l in 0..LANES {
            let v = if ok[l] { m[l] } else { T::INF };
            acc[l] = if v < acc[l] { v } else { acc[l] };
        }
    }
}

/// Where a block's points come from: their motion ([`Motion::apply`]'s formula), the reach
/// and the height band, in `T`.
struct Bounds<T> {
    mc: T,
    ms: T,
    tx: T,
    ty: T,
    reach2: T,
    z_lo: T,
    z_hi: T,
}

/// One block of points, moved, and which are kept.
struct Lanes<T> {
    xs: [T; LANES],
    ys: [T; LANES],
    ok: [bool; LANES],
}

/// Loads one block of [`LANES`] rows of `S` coordinates into `out`, moved and masked; whether
/// any is kept. A function of a constant stride, not a closure, so that it vectorises inside
/// the kernel's AVX builds.
#[inline(always)]
fn block<T: Lane, const S: usize>(rows: &[T], b: &Bounds<T>, out: &mut Lanes<T>) -> bool {
    let rows = &rows[..S * LANES];
    for l in 0..LANES {
        let (px, py) = (rows[S * l], rows[S * l + 1]);
        let x = b.tx + (b.mc * px - b.ms * py);
        let y = b.ty + (b.ms * px + b.mc * py);
        out.xs[l] = x;
        out.ys[l] = y;
        let in_band = if S == 3 { (rows[S * l + 2] >= b.z_lo) & (rows[S * l + 2] <= b.z_hi) } else { true };
        out.ok[l] = (x * x + y * y <= b.reach2) & in_band;
    }
    out.ok.iter().fold(false, |a, &o| a | o)
}

#[inline(always)]
fn clearances_body<T: Lane, const K: usize>(sets: [&Planes; K], here: &Planes, set: PointSet<'_, T>, mut near: Option<&mut Vec<T>>, cull: f64) -> ([f64; K], f64) {
    let lanes: [LanePlanes<T>; K] = sets.map(|p| LanePlanes::of(p, cull));
    let here_lanes = LanePlanes::of(here, cull);
    let m = set.motion.unwrap_or(Motion { cos: 1.0, sin: 0.0, tx: 0.0, ty: 0.0 });
    let reach2 = T::from_f64(if set.reach.is_finite() { set.reach * set.reach } else { f64::INFINITY });
    let (z_lo, z_hi) = set.band.filter(|_| set.stride == 3).map_or((-T::INF, T::INF), |(a, b)| (T::from_f64(a), T::from_f64(b)));
    let mut least = [[T::INF; LANES]; K];
    let mut here_least = [T::INF; LANES];
    let stride = set.stride;
    let bounds = Bounds { mc: T::from_f64(m.cos), ms: T::from_f64(m.sin), tx: T::from_f64(m.tx), ty: T::from_f64(m.ty), reach2, z_lo, z_hi };
    let mut run = |block: fn(&[T], &Bounds<T>, &mut Lanes<T>) -> bool| {
        let mut blocks = set.pts.chunks_exact(stride * LANES);
        let mut lanes_buf = Lanes { xs: [T::ZERO; LANES], ys: [T::ZERO; LANES], ok: [false; LANES] };
        let mut fold = |l: &Lanes<T>| {
            for k in 0..K {
                lanes[k].fold(&l.xs, &l.ys, &l.ok, &mut least[k]);
            }
            here_lanes.fold(&l.xs, &l.ys, &l.ok, &mut here_least);
            if let Some(out) = near.as_deref_mut() {
                // every lane written, only the kept ones advance (no branches)
                let mut n = out.len();
                out.resize(n + 2 * LANES, T::ZERO);
                for j in 0..LANES {
                    out[n] = l.xs[j];
                    out[n + 1] = l.ys[j];
                    n += 2 * l.ok[j] as usize;
                }
                out.truncate(n);
            }
        };
        for b in &mut blocks {
            if block(b, &bounds, &mut lanes_buf) {
                fold(&lanes_buf);
            }
        }
        let rest = blocks.remainder();
        if !rest.is_empty() {
            // the last, partial block: padded with points that are never kept
            let mut padded = [T::ZERO; 3 * LANES];
            padded[..rest.len()].copy_from_slice(rest);
            let kept = rest.len() / stride;
            if block(&padded[..stride * LANES], &bounds, &mut lanes_buf) {
                lanes_buf.ok[kept..].iter_mut().for_each(|o| *o = false);
                fold(&lanes_buf);
            }
        }
    };
    if stride == 3 {
        run(block::<T, 3>);
    } else {
        run(block::<T, 2>);
    }
    let fold = |v: &[T; LANES]| {
        let m = v.iter().map(|x| x.to_f64()).fold(f64::INFINITY, f64::min);
        if m.is_finite() {
            m
        } else {
            f64::MAX
        }
    };
    (std::array::from_fn(|k| fold(&least[k])), fold(&here_least))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect() -> Footprint {
        Footprint::rectangle(1.1, 0.5).unwrap()
    }

    /// The plain scalar transcription of the check: each point's clearance to the swept set
    /// (`f64::MAX` beyond `cull` of its circle), the least over the points within the reach.
    fn scalar(sw: &Sweep, fp: &Footprint, pts: &[[f64; 2]], reach: f64, cull: f64) -> (f64, f64) {
        let (mut c, mut here) = (f64::MAX, f64::MAX);
        let standing = Planes::of_footprint(fp);
        for &p in pts.iter().filter(|p| p[0].hypot(p[1]) <= reach) {
            c = c.min(sw.planes.culled_clearance(p, cull));
            here = here.min(standing.culled_clearance(p, cull));
        }
        (c, here)
    }

    #[test]
    fn the_lane_kernel_equals_the_scalar_check_on_random_inputs() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let model = BrakingModel::default();
        let fp = model.footprint;
        let here = Planes::of_footprint(&fp);
        for case in 0..300 {
            let v0 = [rng.random_range(-1.6..1.6), rng.random_range(-0.8..0.8), rng.random_range(-1.5..1.5)];
            let cmd = [rng.random_range(-1.6..1.6), rng.random_range(-0.8..0.8), rng.random_range(-1.5..1.5)];
            let sw = model.sweep(v0, cmd);
            let n = rng.random_range(0..200);
            let pts: Vec<[f64; 2]> = (0..n).map(|_| [rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)]).collect();
            let flat: Vec<f64> = pts.iter().flatten().copied().collect();
            let reach = rng.random_range(0.5..4.0);
            let cull = rng.random_range(0.0..0.3);
            let want = scalar(&sw, &fp, &pts, reach, cull);
            for level in [SimdLevel::Portable, SimdLevel::detect()] {
                let mut near = Vec::new();
                let set = PointSet { pts: &flat[..], stride: 2, motion: None, reach, band: None };
                let ([c], h) = clearances_of([&sw.planes], &here, set, Some(&mut near), cull, level);
                assert!((c - want.0).abs() < 1e-12 && (h - want.1).abs() < 1e-12, "case {case} {level:?}: {c} {h} vs {want:?}");
                assert_eq!(near.len() / 2, pts.iter().filter(|p| p[0].hypot(p[1]) <= reach).count());
                let f32s: Vec<f32> = flat.iter().map(|&v| v as f32).collect();
                let set = PointSet { pts: &f32s[..], stride: 2, motion: None, reach, band: None };
                let ([c32], h32) = clearances_of([&sw.planes], &here, set, None, cull, level);
                if want.0 < f64::MAX && want.1 < f64::MAX && c32 < f64::MAX && h32 < f64::MAX {
                    assert!((c32 - want.0).abs() < 1e-5 && (h32 - want.1).abs() < 1e-5, "f32 case {case}: {c32} vs {want:?}");
                }
            }
        }
    }

    #[test]
    fn a_straight_brake_from_full_speed_ends_where_the_tracker_stops() {
        let model = BrakingModel::default();
        let sw = model.sweep([1.6, 0.0, 0.0], [1.6, 0.0, 0.0]);
        let mut t = crate::robot::Tracker::new(model.tracker).unwrap();
        t.set_velocity([1.6, 0.0, 0.0]);
        let mut x = 0.0;
        x += t.step([1.6, 0.0, 0.0], model.dt).unwrap().velocity[0] * model.dt;
        for _ in 0..2000 {
            x += t.step([0.0; 3], model.dt).unwrap().velocity[0] * model.dt;
        }
        assert!(x > 0.6 && x < 0.75, "stopping distance {x}");
        assert!((sw.chord[0] - x).abs() < 1e-9, "{} vs {x}", sw.chord[0]);
        assert!(sw.chord[1].abs() < 1e-12 && sw.heading == 0.0);
        assert!(sw.growth < 1e-12, "a straight brake does not grow: {}", sw.growth);
        // a wall point just past the stopping footprint's nose clears it, one inside does not
        let nose = x + 0.55;
        assert!(sw.clearance([nose + 0.01, 0.2]) > 0.0);
        assert!(sw.clearance([nose - 0.01, 0.2]) < 0.0);
        // beside the body, the sweep is as wide as the body
        assert!((sw.clearance([0.3, 0.35]) - 0.1).abs() < 1e-3);
    }

    #[test]
    fn turning_the_path_stays_inside_the_grown_sweep() {
        let model = BrakingModel::default();
        let fp = model.footprint;
        for (v0, cmd) in [([1.2, 0.3, 1.5], [1.6, 0.8, 1.5]), ([0.3, 0.0, -1.0], [0.5, -0.3, -1.5]), ([0.0; 3], [0.0, 0.0, 1.5])] {
            let sw = model.sweep(v0, cmd);
            let mut t = crate::robot::Tracker::new(model.tracker).unwrap();
            t.set_velocity(v0);
            let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
            let mut c = cmd;
            for _ in 0..400 {
                let v = t.step(c, model.dt).unwrap().velocity;
                c = [0.0; 3];
                let (s, co) = th.sin_cos();
                x += model.dt * (co * v[0] - s * v[1]);
                y += model.dt * (s * v[0] + co * v[1]);
                th += model.dt * v[2];
                let (s, co) = th.sin_cos();
                // every boundary point of the footprint at every replayed pose lies in the set
                let vs = fp.vertices();
                for k in 0..vs.len() {
                    for f in 0..10 {
                        let f = f as f64 / 10.0;
                        let (a, b) = (vs[k], vs[(k + 1) % vs.len()]);
                        let e = [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])];
                        let p = [x + co * e[0] - s * e[1], y + s * e[0] + co * e[1]];
                        assert!(sw.clearance(p) <= 1e-9, "{v0:?} {cmd:?}: pose ({x}, {y}, {th}) leaves the sweep at {p:?}");
                        assert!(p[0].hypot(p[1]) <= sw.extent + 1e-9);
                    }
                }
            }
        }
    }

    #[test]
    fn the_incremental_turn_equals_sin_cos() {
        let (mut s, mut c, mut th) = (0.0f64, 1.0f64, 0.0f64);
        for k in 0..20_000 {
            let d = 0.03 * ((k as f64) * 0.37).sin() + if k % 997 == 0 { 0.5 } else { 0.0 };
            th += d;
            (s, c) = turned(s, c, d, th);
            let (s0, c0) = th.sin_cos();
            assert!((s - s0).abs() < 1e-11 && (c - c0).abs() < 1e-11, "step {k}: {s} {c} vs {s0} {c0}");
        }
    }

    #[test]
    fn footprints_are_checked_and_either_winding_is_taken() {
        let ccw = Footprint::polygon(&[[0.5, 0.3], [-0.5, 0.3], [-0.5, -0.3], [0.5, -0.3]]).unwrap();
        let cw = Footprint::polygon(&[[0.5, -0.3], [-0.5, -0.3], [-0.5, 0.3], [0.5, 0.3]]).unwrap();
        assert!((ccw.clearance([1.0, 0.0]) - 0.5).abs() < 1e-12 && (cw.clearance([1.0, 0.0]) - 0.5).abs() < 1e-12);
        assert!((rect().clearance([0.0, 0.0]) + 0.25).abs() < 1e-12);
        let err = |v: &[[f64; 2]]| Footprint::polygon(v).unwrap_err().to_string();
        assert!(err(&[[1.0, 0.0], [0.0, 1.0]]).contains("footprint"));
        assert!(err(&[[1.0, 1.0], [2.0, 1.0], [2.0, 2.0]]).contains("origin"));
        assert!(err(&[[1.0, 1.0], [-1.0, 1.0], [0.0, 0.5], [-1.0, -1.0], [1.0, -1.0]]).contains("convex"));
        assert!(err(&[[f64::NAN, 1.0], [-1.0, 1.0], [0.0, -1.0]]).contains("finite"));
        assert!(Footprint::rectangle(-1.0, 0.5).unwrap_err().to_string().contains("footprint"));
    }
}
