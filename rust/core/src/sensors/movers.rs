//! Moving obstacles from the sensor alone: consecutive scans and the odometry.
//!
//! Each scan is cut into segments (neighbouring returns closer than `cluster_gap`, plus twice
//! the beams' spacing at their range); a segment no longer than `max_size`, within `max_range`
//! of the sensor, is a candidate object (longer ones are structure: walls, shelves).
//! Candidates' centroids are taken into the odometry frame with the odometry's pose at the
//! scan and associated, nearest first within `gate`, with the tracks predicted to the scan's
//! time; each track is a constant-velocity Kalman filter per axis, driven by white
//! acceleration of density `accel²`. A track is reported as a [`Mover`] once it has been seen
//! `confirm` times in a row and its estimated speed exceeds `min_speed`: a static object (whose centroid only jitters with the viewing angle and
//! the range noise) or an odometry drift reads as no mover. An odometry jump moves every
//! centroid by more than the gate at once: the tracks are lost and new ones start at rest, so a
//! jump creates no mover either.
//!
//! Nothing here reads the simulator's truth: the environments feed it the scan and the pose the
//! odometry reports.

use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::Pose2;

/// A moving object as the shield takes it: a disc in the current body frame with its ground
/// velocity in the same axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mover {
    /// Centre (m, body frame).
    pub centre: [Real; 2],
    /// Radius of the disc holding the object's returns (m).
    pub radius: Real,
    /// Velocity over the ground (m/s), in the body frame's axes.
    pub velocity: [Real; 2],
    /// Standard deviation of each velocity component's estimate (m/s).
    pub velocity_std: Real,
}

impl Mover {
    /// Checks that every number is finite, the radius in `[0, 10]` m, the speed at most
    /// `MAX_MOVER_SPEED` and the standard deviation in `[0, MAX_MOVER_SPEED]`; errors name
    /// `movers`.
    pub fn validate(&self) -> Result<()> {
        let finite = self.centre.iter().chain(&self.velocity).all(|v| v.is_finite()) && self.radius.is_finite() && self.velocity_std.is_finite();
        if !finite {
            return Err(Error::invalid("movers", format!("every value must be finite, got {self:?}")));
        }
        if !(0.0..=10.0).contains(&self.radius) {
            return Err(Error::invalid("movers", format!("radius must be from 0 to 10 m, got {}", self.radius)));
        }
        let speed = self.velocity[0].hypot(self.velocity[1]);
        if speed > MAX_MOVER_SPEED || !(0.0..=MAX_MOVER_SPEED).contains(&self.velocity_std) {
            return Err(Error::invalid("movers", format!("speed and its standard deviation must be at most {MAX_MOVER_SPEED} m/s, got {speed} and {}", self.velocity_std)));
        }
        Ok(())
    }

    /// The mover `tau` seconds later, moved along its velocity.
    pub fn advanced(&self, tau: Real) -> Self {
        Self { centre: [self.centre[0] + tau * self.velocity[0], self.centre[1] + tau * self.velocity[1]], ..*self }
    }

    /// The mover seen from a frame in which the old frame's pose is `(yaw, tx, ty)`.
    pub fn moved(&self, yaw: Real, tx: Real, ty: Real) -> Self {
        let (s, c) = yaw.sin_cos();
        let r = |p: [Real; 2]| [c * p[0] - s * p[1], s * p[0] + c * p[1]];
        let m = r(self.centre);
        Self { centre: [m[0] + tx, m[1] + ty], velocity: r(self.velocity), ..*self }
    }
}

/// The fastest mover (m/s) the shield accepts: a sprinting person, a fast cart.
pub const MAX_MOVER_SPEED: Real = 10.0;

/// The tracker's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoverTrackerConfig {
    /// Neighbouring returns farther apart (m) than this plus twice the beams' spacing at their
    /// range start a new segment.
    pub cluster_gap: Real,
    /// Segments whose bounding box's diagonal exceeds this (m) are structure, never movers.
    pub max_size: Real,
    /// Candidates farther than this from the sensor (m) are not tracked.
    pub max_range: Real,
    /// Fewest returns of a candidate object.
    pub min_points: usize,
    /// Association radius (m) around a track's predicted position.
    pub gate: Real,
    /// Slowest speed (m/s) reported as moving.
    pub min_speed: Real,
    /// Consecutive scans a track must be seen in before it is reported.
    pub confirm: u32,
    /// Scans a track survives unseen.
    pub max_misses: u32,
    /// Density of the white acceleration driving the tracks (m/s²).
    pub accel: Real,
    /// Standard deviation of a centroid's measurement (m).
    pub centroid_std: Real,
}

impl Default for MoverTrackerConfig {
    fn default() -> Self {
        Self { cluster_gap: 0.2, max_size: 1.2, max_range: 6.0, min_points: 3, gate: 0.6, min_speed: 0.3, confirm: 3, max_misses: 2, accel: 1.0, centroid_std: 0.05 }
    }
}

impl MoverTrackerConfig {
    /// Checks every field; errors name it.
    pub fn validate(&self) -> Result<()> {
        for (name, v, hi) in [
            ("cluster_gap", self.cluster_gap, 5.0),
            ("max_size", self.max_size, 20.0),
            ("max_range", self.max_range, 100.0),
            ("gate", self.gate, 10.0),
            ("mover_min_speed", self.min_speed, MAX_MOVER_SPEED),
            ("accel", self.accel, 100.0),
            ("centroid_std", self.centroid_std, 1.0),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= hi) {
                return Err(Error::invalid(name, format!("must be in (0, {hi}], got {v}")));
            }
        }
        if self.min_points == 0 || self.confirm == 0 {
            return Err(Error::invalid("min_points", "min_points and confirm must be at least 1"));
        }
        Ok(())
    }
}

/// One axis's constant-velocity Kalman filter: position, velocity and their covariance.
#[derive(Debug, Clone, Copy)]
struct Axis {
    p: Real,
    v: Real,
    /// `[pp, pv, vv]`.
    cov: [Real; 3],
}

impl Axis {
    fn predict(&mut self, dt: Real, q: Real) {
        let [pp, pv, vv] = self.cov;
        self.p += dt * self.v;
        self.cov = [pp + 2.0 * dt * pv + dt * dt * vv + q * dt * dt * dt / 3.0, pv + dt * vv + q * dt * dt / 2.0, vv + q * dt];
    }

    fn update(&mut self, z: Real, r: Real) {
        let [pp, pv, vv] = self.cov;
        let s = pp + r;
        let (kp, kv) = (pp / s, pv / s);
        let e = z - self.p;
        self.p += kp * e;
        self.v += kv * e;
        self.cov = [(1.0 - kp) * pp, (1.0 - kp) * pv, vv - kv * pv];
    }
}

#[derive(Debug, Clone, Copy)]
struct Track {
    x: Axis,
    y: Axis,
    radius: Real,
    hits: u32,
    misses: u32,
    seen: bool,
}

/// A candidate object of one scan: centroid (odometry frame and body frame) and radius.
#[derive(Debug, Clone, Copy)]
struct Segment {
    odom: [Real; 2],
    radius: Real,
}

/// Tracks the scan's small objects over time; see the module docs.
#[derive(Debug, Clone)]
pub struct MoverTracker {
    config: MoverTrackerConfig,
    tracks: Vec<Track>,
    time: Option<Real>,
    pose: Pose2,
    segments: Vec<Segment>,
    movers: Vec<Mover>,
    pairs: Vec<(Real, usize, usize)>,
    norms: Vec<Real>,
    breaks: Vec<bool>,
}

impl MoverTracker {
    /// A tracker with no tracks.
    pub fn new(config: MoverTrackerConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self { config, tracks: Vec::new(), time: None, pose: Pose2::default(), segments: Vec::new(), movers: Vec::new(), pairs: Vec::new(), norms: Vec::new(), breaks: Vec::new() })
    }

    /// Forgets every track.
    pub fn reset(&mut self) {
        self.tracks.clear();
        self.movers.clear();
        self.time = None;
    }

    /// The configuration.
    pub fn config(&self) -> &MoverTrackerConfig {
        &self.config
    }

    /// The movers of the latest scan, in its body frame.
    pub fn movers(&self) -> &[Mover] {
        &self.movers
    }

    /// Tracks alive (reported or not).
    pub fn num_tracks(&self) -> usize {
        self.tracks.len()
    }

    /// Takes a scan: `points` (body frame, in beam order, NaN where there is no return), taken
    /// at `time` (s) with the odometry's pose `pose`. Returns the movers, in the scan's body
    /// frame. A time not after the previous scan's is an error.
    pub fn update(&mut self, points: &[[Real; 3]], pose: Pose2, time: Real) -> Result<&[Mover]> {
        if !time.is_finite() {
            return Err(Error::invalid("time", format!("must be finite, got {time}")));
        }
        pose.validate("pose")?;
        let dt = match self.time {
            Some(t) if time <= t => return Err(Error::invalid("time", format!("scans must come in time order: {time} s after {t} s"))),
            Some(t) => time - t,
            None => 0.0,
        };
        self.segment(points, pose);
        let c = self.config;
        let q = c.accel * c.accel;
        for t in &mut self.tracks {
            t.x.predict(dt, q);
            t.y.predict(dt, q);
            t.seen = false;
        }
        // nearest pairs first within the gate, each track and segment used once
        self.pairs.clear();
        for (i, t) in self.tracks.iter().enumerate() {
            for (j, s) in self.segments.iter().enumerate() {
                let d = (s.odom[0] - t.x.p).hypot(s.odom[1] - t.y.p);
                if d <= c.gate {
                    self.pairs.push((d, i, j));
                }
            }
        }
        self.pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut used = vec![false; self.segments.len()];
        let r = c.centroid_std * c.centroid_std;
        for &(_, i, j) in &self.pairs {
            let t = &mut self.tracks[i];
            if t.seen || used[j] {
                continue;
            }
            let s = self.segments[j];
            t.x.update(s.odom[0], r);
            t.y.update(s.odom[1], r);
            t.radius = s.radius;
            t.hits += 1;
            t.misses = 0;
            t.seen = true;
            used[j] = true;
        }
        for t in &mut self.tracks {
            if !t.seen {
                t.misses += 1;
                t.hits = 0;
            }
        }
        self.tracks.retain(|t| t.misses <= c.max_misses);
        // new tracks start at rest, their velocity unknown up to 3 m/s
        for (s, _) in self.segments.iter().zip(&used).filter(|(_, &u)| !u) {
            let axis = |p| Axis { p, v: 0.0, cov: [r, 0.0, 9.0] };
            self.tracks.push(Track { x: axis(s.odom[0]), y: axis(s.odom[1]), radius: s.radius, hits: 1, misses: 0, seen: true });
        }
        self.time = Some(time);
        self.pose = pose;
        self.movers.clear();
        let (sin, cos) = pose.yaw.sin_cos();
        for t in self.tracks.iter().filter(|t| t.seen && t.hits >= c.confirm) {
            let (vx, vy) = (t.x.v, t.y.v);
            let std = t.x.cov[2].max(t.y.cov[2]).sqrt();
            let speed = vx.hypot(vy);
            if speed < c.min_speed {
                continue;
            }
            let b = pose.inverse_transform_point([t.x.p, t.y.p]);
            let v = [cos * vx + sin * vy, -sin * vx + cos * vy];
            self.movers.push(Mover { centre: b, radius: t.radius, velocity: v, velocity_std: std });
        }
        Ok(&self.movers)
    }

    /// Cuts the scan into segments and keeps the small ones as candidates.
    fn segment(&mut self, points: &[[Real; 3]], pose: Pose2) {
        self.segments.clear();
        let n = points.len();
        if n == 0 {
            return;
        }
        let gap = self.config.cluster_gap;
        let mut norms = std::mem::take(&mut self.norms);
        norms.clear();
        // (`sqrt` of the sum, not `hypot`: ranges are far from overflow, and `hypot` per beam
        // was a third of the tracker's time)
        norms.extend(points.iter().map(|p| (p[0] * p[0] + p[1] * p[1]).sqrt()));
        // the gap grows with the beams' spacing at the nearer return's range (twice it), so
        // that a far wall's noisy returns stay one segment: `r_min sin Δθ = |p × q| / r_max`
        let joined = |a: usize, b: usize| {
            let (p, q) = (points[a], points[b]);
            let (dx, dy) = (p[0] - q[0], p[1] - q[1]);
            let allowed = gap + 2.0 * (p[0] * q[1] - p[1] * q[0]).abs() / norms[a].max(norms[b]).max(1e-12);
            // (NaN, no return, compares false)
            dx * dx + dy * dy <= allowed * allowed
        };
        // breaks[k]: return k is not joined to the one before it (the scan wraps around)
        let mut breaks = std::mem::take(&mut self.breaks);
        breaks.clear();
        breaks.push(!joined(n - 1, 0));
        breaks.extend((1..n).map(|k| !joined(k - 1, k)));
        self.norms = norms;
        // start at a break so that an object across the scan's seam is one segment
        let Some(start) = breaks.iter().position(|&b| b) else {
            self.breaks = breaks;
            return;
        };
        let mut first = None;
        for i in 0..=n {
            let k = if start + i >= n { start + i - n } else { start + i };
            let ends = i == n || breaks[k];
            if ends {
                if let Some(f) = first.take() {
                    self.close(points, f, i, start, pose);
                }
            }
            if i < n && !points[k][0].is_nan() && first.is_none() {
                first = Some(i);
            }
        }
        self.breaks = breaks;
    }

    /// The segment of scan indices `start + [from, to)` (mod the scan's length).
    fn close(&mut self, points: &[[Real; 3]], from: usize, to: usize, start: usize, pose: Pose2) {
        let c = self.config;
        let n = points.len();
        let count = to - from;
        if count < c.min_points {
            return;
        }
        let pts = (from..to).map(|i| points[if start + i >= n { start + i - n } else { start + i }]);
        let (mut lo, mut hi, mut sum) = ([Real::INFINITY; 2], [Real::NEG_INFINITY; 2], [0.0; 2]);
        for p in pts.clone() {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
                sum[k] += p[k];
            }
        }
        if (hi[0] - lo[0]).hypot(hi[1] - lo[1]) > c.max_size {
            return;
        }
        let centre = [sum[0] / count as Real, sum[1] / count as Real];
        if centre[0].hypot(centre[1]) > c.max_range {
            return;
        }
        let radius = pts.map(|p| (p[0] - centre[0]).hypot(p[1] - centre[1])).fold(0.0, Real::max);
        self.segments.push(Segment { odom: pose.transform_point(centre), radius });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A planar scan of 360 beams from the origin of `pose` seeing a `side` square centred at
    /// `c` (world) and a wall at x = 6.
    fn scan_of(pose: Pose2, c: [Real; 2], side: Real) -> Vec<[Real; 3]> {
        use crate::sensors::ray_segment_distance;
        let h = 0.5 * side;
        let corners = [[c[0] - h, c[1] - h], [c[0] + h, c[1] - h], [c[0] + h, c[1] + h], [c[0] - h, c[1] + h]];
        let mut walls: Vec<([Real; 2], [Real; 2])> = (0..4).map(|k| (corners[k], corners[(k + 1) % 4])).collect();
        walls.push(([6.0, -20.0], [6.0, 20.0]));
        (0..360)
            .map(|k| {
                let a = pose.yaw + (k as Real).to_radians();
                let d = [a.cos(), a.sin()];
                let r = walls.iter().filter_map(|&(p, q)| ray_segment_distance([pose.x, pose.y], d, p, q)).fold(Real::INFINITY, Real::min);
                if r > 20.0 {
                    [Real::NAN; 3]
                } else {
                    let b = (k as Real).to_radians();
                    [r * b.cos(), r * b.sin(), 0.0]
                }
            })
            .collect()
    }

    /// A 0.5 m object walking at 1.2 m/s seen from a robot that drives too: after 6 scans at
    /// 10 Hz (0.5 s) the velocity is within 0.25 m/s of the truth (the visible faces, and the
    /// centroid with them, change as it passes).
    #[test]
    fn a_walker_is_tracked_to_its_velocity() {
        let mut tr = MoverTracker::new(MoverTrackerConfig::default()).unwrap();
        let v = [-0.6, 1.04];
        for k in 0..20 {
            let t = 0.1 * k as Real;
            let pose = Pose2::new(0.3 * t, 0.0, 0.05 * t);
            let c = [3.0 + v[0] * t, -1.5 + v[1] * t];
            let movers = tr.update(&scan_of(pose, c, 0.5), pose, t).unwrap().to_vec();
            if k >= 5 {
                assert_eq!(movers.len(), 1, "scan {k}: {movers:?}");
                let m = movers[0];
                // the body-frame velocity rotated back to the world
                let (s, co) = pose.yaw.sin_cos();
                let w = [co * m.velocity[0] - s * m.velocity[1], s * m.velocity[0] + co * m.velocity[1]];
                let err = (w[0] - v[0]).hypot(w[1] - v[1]);
                assert!(err < 0.25, "scan {k}: error {err} ({w:?})");
                let centre = pose.transform_point(m.centre);
                assert!((centre[0] - c[0]).hypot(centre[1] - c[1]) < 0.3, "{centre:?} {c:?}");
                assert!(m.radius > 0.1 && m.radius < 0.6, "{m:?}");
            }
        }
    }

    /// Static objects seen from a driving, turning robot through a drifting odometry give no
    /// mover; an odometry jump gives none either.
    #[test]
    fn a_static_world_gives_no_movers() {
        let mut tr = MoverTracker::new(MoverTrackerConfig::default()).unwrap();
        let mut rng_state = 7u64;
        let mut noise = || {
            rng_state = rng_state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((rng_state >> 33) as Real / (1u64 << 31) as Real - 0.5) * 0.02
        };
        for k in 0..200 {
            let t = 0.1 * k as Real;
            let truth = Pose2::new(0.4 * t.min(8.0) - 0.01 * t * t.min(3.0), 0.3 * (0.5 * t).sin(), 0.3 * (0.3 * t).sin());
            let mut scan = scan_of(truth, [4.5, 1.0], 0.5);
            for p in &mut scan {
                let f = 1.0 + noise();
                p[0] *= f;
                p[1] *= f;
            }
            // odometry: drift of 2 cm/s and 0.01 rad/s, and a 0.8 m jump at 10 s
            let jump = if t >= 10.0 { 0.8 } else { 0.0 };
            let odo = Pose2::new(truth.x + 0.02 * t + jump, truth.y - 0.01 * t, truth.yaw + 0.01 * t);
            let movers = tr.update(&scan, odo, t).unwrap();
            assert!(movers.is_empty(), "scan {k}: {movers:?}");
        }
        assert!(tr.num_tracks() >= 1);
    }

    #[test]
    fn bad_inputs_are_named() {
        let mut tr = MoverTracker::new(MoverTrackerConfig::default()).unwrap();
        tr.update(&[], Pose2::default(), 1.0).unwrap();
        let e = tr.update(&[], Pose2::default(), 1.0).unwrap_err();
        assert!(e.to_string().contains("time order"), "{e}");
        assert!(tr.update(&[], Pose2::new(Real::NAN, 0.0, 0.0), 2.0).is_err());
        let e = MoverTracker::new(MoverTrackerConfig { gate: -1.0, ..Default::default() }).unwrap_err();
        assert!(e.to_string().contains("gate"), "{e}");
        let m = Mover { centre: [1.0, 0.0], radius: 0.3, velocity: [20.0, 0.0], velocity_std: 0.1 };
        assert!(m.validate().unwrap_err().to_string().contains("movers"));
    }
}
