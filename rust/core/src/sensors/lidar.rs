//! An exact planar / 3D LIDAR by polar sweep, configurable like an Ouster OS0.
//!
//! For each wall in range the sweep finds the beams inside the wall's angular interval (seen
//! from the sensor) and gives each the exact `f64` ray–segment distance; each beam keeps its
//! nearest hit. No BVH and no `f32`: ranges equal a brute-force `f64` ray cast to rounding
//! (≪ 1e-6 m), grazing beams down a corridor included.
//!
//! Frames: column `i` looks at azimuth `2π·i/columns`, counter-clockwise from the sensor's
//! `+x`; channel `k` at elevation `lo + k·(hi − lo)/(channels − 1)` (channel 0 lowest; a single
//! channel looks level). Walls are vertical, from the floor (`z = 0`) to their height; a beam
//! that passes over a wall or hits nothing gives no return. Floor and ceiling are not modelled.
//!
//! ```
//! use shieldnav_core::sensors::{Lidar, LidarConfig, Scan};
//! use shieldnav_core::world::{Pose2, Segment};
//! use rand::SeedableRng;
//! let mut lidar = Lidar::new(LidarConfig { range_noise_std: 0.0, ..LidarConfig::default() }).unwrap();
//! let wall = [Segment::new([2.0, -5.0], [2.0, 5.0], 2.5)];
//! let mut scan = Scan::default();
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
//! lidar.scan_into(&[&wall], Pose2::default(), 0.0, &mut rng, &mut scan).unwrap();
//! assert!((scan.ranges[0] - 2.0).abs() < 1e-12); // column 0 looks along +x
//! ```

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::noise::{fill_standard_normal, fill_unit_uniform};
use super::ray_segment::ray_segment_distance;
use crate::error::{Error, Result};
use crate::math::Real;
use crate::simd::SimdLevel;
use crate::world::{cross2, Pose2, Segment};

/// Where the sensor sits on the robot: body-frame position (m; `z` is the height above the
/// floor) and yaw (rad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LidarMount {
    /// Forward offset (m).
    pub x: Real,
    /// Left offset (m).
    pub y: Real,
    /// Height above the floor (m).
    pub z: Real,
    /// Yaw relative to the body (rad).
    pub yaw: Real,
}

impl Default for LidarMount {
    fn default() -> Self {
        Self { x: 0.0, y: 0.0, z: 0.5, yaw: 0.0 }
    }
}

/// The largest accepted `max_range` (m); an OS0 reaches about 50 m.
pub const MAX_RANGE_LIMIT: Real = 200.0;

/// LIDAR parameters. The default is a planar 1024-column ring at 10 Hz, range 0.1–20 m,
/// 1 cm range noise, no dropout.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LidarConfig {
    /// 1 for a planar ring, else 16..=128.
    pub channels: usize,
    /// 512, 1024 or 2048 beams per revolution.
    pub columns: usize,
    /// Lowest and highest elevation (rad) for `channels > 1`; OS0: ±45°.
    pub vertical_fov: (Real, Real),
    /// Returns nearer than this (m) are dropped (and occlude what is behind).
    pub min_range: Real,
    /// Returns farther than this (m) are dropped.
    pub max_range: Real,
    /// Standard deviation of additive Gaussian range noise (m).
    pub range_noise_std: Real,
    /// Probability that a return is dropped, in `[0, 1)`.
    pub dropout: Real,
    /// Revolutions per second (10–20 Hz).
    pub rate_hz: Real,
    /// Mounting pose on the body.
    pub mount: LidarMount,
}

impl Default for LidarConfig {
    fn default() -> Self {
        Self {
            channels: 1,
            columns: 1024,
            vertical_fov: (-std::f64::consts::FRAC_PI_4, std::f64::consts::FRAC_PI_4),
            min_range: 0.1,
            max_range: 20.0,
            range_noise_std: 0.01,
            dropout: 0.0,
            rate_hz: 10.0,
            mount: LidarMount::default(),
        }
    }
}

impl LidarConfig {
    /// Elevation of each channel (rad), lowest first: `[0]` for a planar ring, else evenly
    /// spread over `vertical_fov`.
    pub fn elevations(&self) -> Vec<Real> {
        if self.channels == 1 {
            vec![0.0]
        } else {
            let (lo, hi) = self.vertical_fov;
            (0..self.channels).map(|k| lo + k as Real * (hi - lo) / (self.channels - 1) as Real).collect()
        }
    }

    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<()> {
        if !(self.channels == 1 || (16..=128).contains(&self.channels)) {
            return Err(Error::invalid("channels", format!("must be 1 or in 16..=128, got {}", self.channels)));
        }
        if ![512, 1024, 2048].contains(&self.columns) {
            return Err(Error::invalid("columns", format!("must be 512, 1024 or 2048, got {}", self.columns)));
        }
        let (lo, hi) = self.vertical_fov;
        let half = std::f64::consts::FRAC_PI_2;
        if !(lo.is_finite() && hi.is_finite() && lo < hi && lo > -half && hi < half) {
            return Err(Error::invalid("vertical_fov", format!("needs -π/2 < low < high < π/2, got ({lo}, {hi})")));
        }
        if !(self.min_range.is_finite() && self.min_range >= 0.0) {
            return Err(Error::invalid("min_range", format!("must be finite and >= 0, got {}", self.min_range)));
        }
        if !(self.max_range.is_finite() && self.max_range > self.min_range && self.max_range <= MAX_RANGE_LIMIT) {
            return Err(Error::invalid("max_range", format!("must be > min_range and <= {MAX_RANGE_LIMIT} m, got {}", self.max_range)));
        }
        if !(self.range_noise_std.is_finite() && self.range_noise_std >= 0.0) {
            return Err(Error::invalid("range_noise_std", format!("must be finite and >= 0, got {}", self.range_noise_std)));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(Error::invalid("dropout", format!("must be in [0, 1), got {}", self.dropout)));
        }
        if !(10.0..=20.0).contains(&self.rate_hz) {
            return Err(Error::invalid("rate_hz", format!("must be in [10, 20] Hz, got {}", self.rate_hz)));
        }
        let m = self.mount;
        if ![m.x, m.y, m.z, m.yaw].iter().all(|v| v.is_finite()) || m.z < 0.0 {
            return Err(Error::invalid("mount", format!("must be finite with z >= 0, got {m:?}")));
        }
        Ok(())
    }
}

impl LidarConfig {
    /// Checks that the scan rate can be honoured with the control period `dt` (s): scans are
    /// taken at control steps (each at the first step at or after its due time, the step's
    /// time reported as the scan's `stamp`), so a rate faster than the control rate `1 / dt`
    /// would silently be capped to it. The error names `rate_hz` and `dt`.
    pub fn check_rate(&self, dt: Real) -> Result<()> {
        // (within a relative 1e-9: 10 Hz at 0.1 s is one scan a step)
        if self.rate_hz * dt > 1.0 + 1e-9 {
            return Err(Error::invalid(
                "rate_hz",
                format!("{} Hz is faster than the control rate 1 / dt = {} Hz (dt = {dt} s): scans are taken at control steps; lower `rate_hz` or `dt`", self.rate_hz, 1.0 / dt),
            ));
        }
        Ok(())
    }
}

/// One revolution's returns.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scan {
    /// Channel count.
    pub channels: usize,
    /// Column count.
    pub columns: usize,
    /// Range along each beam (m), `ranges[k * columns + i]`; `+inf` where there is no return.
    pub ranges: Vec<Real>,
    /// Body-frame points `[x, y, z]` (m), same order; NaN where there is no return.
    pub points: Vec<[Real; 3]>,
    /// World time of the scan (s).
    pub stamp: Real,
    /// The true sensor pose in the world when scanned (planar part).
    pub sensor_pose: Pose2,
}

impl Scan {
    /// The valid returns only, in body frame.
    pub fn valid_points(&self) -> impl Iterator<Item = &[Real; 3]> + '_ {
        self.points.iter().filter(|p| !p[0].is_nan())
    }
}

/// The LIDAR: configuration plus precomputed beam tables and scratch space.
#[derive(Debug, Clone)]
pub struct Lidar {
    pub(super) config: LidarConfig,
    pub(super) az_cos: Vec<Real>,
    pub(super) az_sin: Vec<Real>,
    /// Columns per radian.
    pub(super) inv_step: Real,
    el_tan: Vec<Real>,
    el_sec: Vec<Real>,
    el_cos: Vec<Real>,
    el_sin: Vec<Real>,
    /// Walls in range, in the sensor frame: `(distance, a, b, height)`, nearest first.
    visible: Vec<(Real, [Real; 2], [Real; 2], Real)>,
    /// Sort keys of `visible` (see [`Lidar::scan_into`]).
    order: Vec<u64>,
    /// Scratch of [`Lidar::scan_indexed_into`].
    pub(super) indexed: super::lidar_indexed::IndexedScratch,
    /// Scratch of [`Lidar::scan_mesh_into`].
    pub(super) mesh: super::lidar_mesh::MeshScratch,
    /// Scratch of [`Lidar::sweep_tops`]: the edges of the solids found, in the sensor frame.
    top_edges: Vec<([Real; 2], [Real; 2])>,
    /// Scratch of the noise draws (one normal per beam).
    normals: Vec<f32>,
    /// Scratch of the dropout draws (one uniform per beam).
    uniforms: Vec<Real>,
    /// The vector instructions the scans run with.
    pub(super) simd: SimdLevel,
}

impl Lidar {
    /// Builds the beam tables after validating `config`.
    pub fn new(config: LidarConfig) -> Result<Self> {
        config.validate()?;
        let n = config.columns;
        let step = std::f64::consts::TAU / n as Real;
        let (az_sin, az_cos) = (0..n).map(|i| (i as Real * step).sin_cos()).unzip();
        let elev = config.elevations();
        Ok(Self {
            config,
            az_cos,
            az_sin,
            inv_step: n as Real / std::f64::consts::TAU,
            el_tan: elev.iter().map(|e| e.tan()).collect(),
            el_sec: elev.iter().map(|e| 1.0 / e.cos()).collect(),
            el_cos: elev.iter().map(|e| e.cos()).collect(),
            el_sin: elev.iter().map(|e| e.sin()).collect(),
            visible: Vec::new(),
            order: Vec::new(),
            indexed: Default::default(),
            mesh: Default::default(),
            top_edges: Vec::new(),
            normals: Vec::new(),
            uniforms: Vec::new(),
            simd: SimdLevel::detect(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &LidarConfig {
        &self.config
    }

    /// Seconds between scans.
    pub fn period(&self) -> Real {
        1.0 / self.config.rate_hz
    }

    /// The sensor's planar pose in the world for a robot at `body`.
    pub fn sensor_pose(&self, body: Pose2) -> Pose2 {
        let m = self.config.mount;
        body.compose(&Pose2::new(m.x, m.y, m.yaw))
    }

    /// Unit direction of column `i`, channel `k` in the sensor frame.
    ///
    /// # Panics
    ///
    /// If `k` is not below the channels or `i` not below the columns, as slice indexing does.
    pub fn beam_direction(&self, k: usize, i: usize) -> [Real; 3] {
        [self.el_cos[k] * self.az_cos[i], self.el_cos[k] * self.az_sin[i], self.el_sin[k]]
    }

    /// Validates `body`, sizes `out` for one scan (every range `inf`) and stamps it; returns
    /// the sensor's world pose. Shared by every scan entry point.
    pub(crate) fn begin_scan(&self, body: Pose2, stamp: Real, out: &mut Scan) -> Result<Pose2> {
        body.validate("pose")?;
        if !stamp.is_finite() {
            return Err(Error::invalid("stamp", format!("must be finite, got {stamp}")));
        }
        let c = self.config;
        out.channels = c.channels;
        out.columns = c.columns;
        out.stamp = stamp;
        out.ranges.clear();
        out.ranges.resize(c.columns * c.channels, Real::INFINITY);
        let sp = self.sensor_pose(body);
        out.sensor_pose = sp;
        Ok(sp)
    }

    /// Scans `walls` (each slice in the world frame) from a robot whose true pose is `body`,
    /// at time `stamp`; noise and dropout are drawn from `rng`. Writes into `out`, reusing its
    /// buffers.
    pub fn scan_into<R: Rng + ?Sized>(&mut self, walls: &[&[Segment]], body: Pose2, stamp: Real, rng: &mut R, out: &mut Scan) -> Result<()> {
        let sp = self.begin_scan(body, stamp, out)?;
        // (the walls are the caller's, new each call: a wall with a NaN end or height would be
        // skipped or scanned silently)
        if let Some(s) = walls.iter().flat_map(|w| w.iter()).find(|s| !(s.a.iter().chain(&s.b).all(|v| v.is_finite()) && s.height.is_finite())) {
            return Err(Error::invalid("walls", format!("every end point and height must be finite, got {s:?}")));
        }
        // (an AVX2 build of this sweep measured slower, unlike the indexed one)
        self.sweep_walls(walls, sp, out);
        self.sweep_tops(walls, sp, &mut out.ranges);
        self.finish(rng, out);
        Ok(())
    }

    /// The ranges of [`Lidar::scan_into`] before limits and noise.
    #[inline(always)]
    fn sweep_walls(&mut self, walls: &[&[Segment]], sp: Pose2, out: &mut Scan) {
        let c = self.config;
        let kch = c.channels;
        let (s, co) = sp.yaw.sin_cos();
        let zs = c.mount.z;
        let mut visible = std::mem::take(&mut self.visible);
        visible.clear();
        for slice in walls {
            for seg in slice.iter() {
                if (kch == 1 && zs > seg.height) || !seg.faces([sp.x, sp.y]) {
                    continue; // the level ring passes over this wall, or sees only its back
                }
                let (dxa, dya) = (seg.a[0] - sp.x, seg.a[1] - sp.y);
                let (dxb, dyb) = (seg.b[0] - sp.x, seg.b[1] - sp.y);
                // the distance to the wall's bounding box: a lower bound of the wall's (exact
                // for axis-aligned walls), all the order and the occluded-beam skip need
                let bx = dxa.min(dxb).max(0.0).max(-dxa.max(dxb));
                let by = dya.min(dyb).max(0.0).max(-dya.max(dyb));
                let dmin = (bx * bx + by * by).sqrt();
                if dmin <= c.max_range {
                    let a = [co * dxa + s * dya, -s * dxa + co * dya];
                    let b = [co * dxb + s * dyb, -s * dxb + co * dyb];
                    visible.push((dmin, a, b, seg.height));
                }
            }
        }
        // nearest first, so that occluded beams of farther walls are skipped by one compare:
        // sorted as keys, a distance's bits (ordered like the distance, which is ≥ 0) with the
        // low 16 replaced by the wall's place (the order only decides how much is skipped)
        let mut order = std::mem::take(&mut self.order);
        order.clear();
        if visible.len() <= 1 << 16 {
            order.extend(visible.iter().enumerate().map(|(k, v)| (v.0.to_bits() & !0xFFFF) | k as u64));
            order.sort_unstable();
            for key in &order {
                let (dmin, a, b, height) = visible[(key & 0xFFFF) as usize];
                self.sweep_segment(a, b, height, dmin, zs, &mut out.ranges);
            }
        } else {
            visible.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
            for &(dmin, a, b, height) in &visible {
                self.sweep_segment(a, b, height, dmin, zs, &mut out.ranges);
            }
        }
        self.order = order;
        self.visible = visible;
    }

    /// The top faces of solids, for scans of more than one channel (a planar ring never looks
    /// down on one): a solid is a closed run of consecutive one-sided walls of one height, each
    /// ending where the next starts (or each starting where the next ends), running
    /// counter-clockwise around it (the solid on their left) — the edges of a polygon of a map
    /// and of a moving obstacle, as [`crate::world::Polygon::edges`] and
    /// [`crate::world::MovingObstacle::segments_at`] give them. Its top is the horizontal face at
    /// its height over the polygon: a beam descending from above it (mount higher than the
    /// solid) hits it at the exact ray–plane distance `(height − z) / tan(elevation)` (horizontal)
    /// wherever that point lies inside the polygon, and keeps the nearer of that and its wall
    /// hits. (A beam inside a solid's outline below its top has hit the top or a front face
    /// first, so its back faces, skipped, would never be the nearest hit.)
    pub(super) fn sweep_tops(&mut self, walls: &[&[Segment]], sp: Pose2, best: &mut [Real]) {
        let c = self.config;
        if c.channels == 1 {
            return;
        }
        let zs = c.mount.z;
        if !self.el_tan.iter().any(|&t| t < 0.0) {
            return;
        }
        let (s, co) = sp.yaw.sin_cos();
        let frame = |p: [Real; 2]| {
            let (dx, dy) = (p[0] - sp.x, p[1] - sp.y);
            [co * dx + s * dy, -s * dx + co * dy]
        };
        let mut edges = std::mem::take(&mut self.top_edges);
        for slice in walls {
            let n = slice.len();
            let mut i = 0;
            while i < n {
                let first = slice[i];
                if !(first.one_sided && first.height < zs) {
                    i += 1;
                    continue;
                }
                // grow a chain of one-sided walls of the same height until it closes
                let mut j = i + 1;
                let mut forward: Option<bool> = None;
                let mut closed = false;
                while j < n {
                    let (prev, next) = (slice[j - 1], slice[j]);
                    let link_fwd = prev.b == next.a;
                    let link_bwd = prev.a == next.b;
                    let ok = next.one_sided
                        && next.height == first.height
                        && match forward {
                            None => link_fwd || link_bwd,
                            Some(true) => link_fwd,
                            Some(false) => link_bwd,
                        };
                    if !ok {
                        break;
                    }
                    if forward.is_none() {
                        forward = Some(link_fwd);
                    }
                    j += 1;
                    let last = slice[j - 1];
                    if j - i >= 3 && (if forward == Some(true) { last.b == first.a } else { last.a == first.b }) {
                        closed = true;
                        break;
                    }
                }
                if closed {
                    let run = &slice[i..j];
                    // twice the signed area: the solid on the walls' left is inside the loop
                    let area2: Real = run.iter().map(|w| cross2(w.a, w.b)).sum();
                    if area2 > 0.0 {
                        edges.clear();
                        edges.extend(run.iter().map(|w| (frame(w.a), frame(w.b))));
                        self.sweep_top(&edges, first.height, zs, best);
                    }
                    i = j;
                } else {
                    i = j.max(i + 1);
                }
            }
        }
        self.top_edges = edges;
    }

    /// The top at `height` of one solid whose outline's `edges` (counter-clockwise, sensor
    /// frame) do not enclose the sensor (see [`Lidar::sweep_tops`]).
    fn sweep_top(&self, edges: &[([Real; 2], [Real; 2])], height: Real, zs: Real, best: &mut [Real]) {
        let c = self.config;
        let n = c.columns;
        let dmin = edges.iter().map(|&(a, b)| seg_origin_distance(a, b)).fold(Real::INFINITY, Real::min);
        let dmax = edges.iter().map(|&(a, _)| (a[0] * a[0] + a[1] * a[1]).sqrt()).fold(0.0, Real::max);
        if dmin <= 0.0 || dmin > c.max_range {
            return; // the sensor is on the outline (not in free space), or it is out of range
        }
        let inside = |p: [Real; 2]| {
            let mut inside = false;
            for &(a, b) in edges {
                if (a[1] > p[1]) != (b[1] > p[1]) {
                    let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                    if p[0] < x {
                        inside = !inside;
                    }
                }
            }
            inside
        };
        for (k, &tan) in self.el_tan.iter().enumerate() {
            if tan >= 0.0 {
                continue;
            }
            // horizontal distance at which the beam is at the top's height
            let t = (height - zs) / tan;
            if !(t >= dmin && t <= dmax) {
                continue;
            }
            let r = t * self.el_sec[k];
            // every beam into the outline crosses an edge facing the sensor: their columns
            for &(a, b) in edges {
                let cr = cross2(a, b);
                if cr >= 0.0 {
                    continue; // seen from behind, or collinear with the sensor
                }
                let (j0, count) = self.wall_beams(a, b, cr);
                let mut i = (j0 & (n as i64 - 1)) as usize;
                for _ in 0..count {
                    let cell = &mut best[k * n + i];
                    if r < *cell && inside([t * self.az_cos[i], t * self.az_sin[i]]) {
                        *cell = r;
                    }
                    i = (i + 1) & (n - 1);
                }
            }
        }
    }

    /// Sweeps one wall given in the sensor frame, `dmin` its distance from the sensor.
    #[inline]
    pub(super) fn sweep_segment(&self, a: [Real; 2], b: [Real; 2], height: Real, dmin: Real, zs: Real, best: &mut [Real]) {
        self.sweep_piece(a, b, a, b, height, dmin, zs, best);
    }

    /// Sweeps the beams through the part `p q` of the wall `a b` (sensor frame) with hits on
    /// the whole wall; `dmin` is no farther than the part. A planar scan skips the wall if
    /// every such beam already hits no farther than `dmin`, else sweeps them in blocks without
    /// a test each ([`Lidar::sweep_flat`]).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn sweep_piece(&self, a: [Real; 2], b: [Real; 2], p: [Real; 2], q: [Real; 2], height: Real, dmin: Real, zs: Real, best: &mut [Real]) {
        let cr = cross2(p, q);
        if cr == 0.0 {
            // collinear with the sensor: only the beams at the end points can hit
            for e in [p, q] {
                let f = fast_atan2(e[1], e[0]) * self.inv_step;
                let j0 = ifloor(f) - 1;
                self.sweep(a, b, height, j0, ((iceil(f) + 1 - j0 + 1) as usize).min(self.config.columns), zs, dmin, best);
            }
            return;
        }
        let (j0, count) = self.wall_beams(p, q, cr);
        if self.config.channels > 1 {
            self.sweep(a, b, height, j0, count, zs, dmin, best);
        } else if !none_beyond(best, j0, count, dmin) {
            self.sweep_flat(a, b, j0, count, best);
        }
    }

    /// The beams a wall `a b` (sensor frame, `cr = a × b ≠ 0`) can hit: the first column (any
    /// integer, taken modulo the column count) and how many (possibly none): those whose
    /// azimuth lies in the wall's angular interval widened by [`ANGLE_SLACK`] each side for the
    /// approximate angles.
    #[inline]
    pub(super) fn wall_beams(&self, a: [Real; 2], b: [Real; 2], cr: Real) -> (i64, usize) {
        use std::f64::consts::TAU;
        let n = self.config.columns;
        let inv_step = self.inv_step;
        let fa = fast_atan2(a[1], a[0]);
        let fb = fast_atan2(b[1], b[0]);
        // counter-clockwise from the start to the end
        let (start, end) = if cr > 0.0 { (fa, fb) } else { (fb, fa) };
        let span = if end < start { end - start + TAU } else { end - start };
        let j0 = iceil((start - ANGLE_SLACK) * inv_step);
        let j1 = ifloor((start + span + ANGLE_SLACK) * inv_step);
        (j0, ((j1 - j0 + 1).max(0) as usize).min(n))
    }

    /// Visits `count` beams from column `j0` (modulo the column count) and keeps exact nearest
    /// hits of the wall `a b` (sensor frame). `dmin` is the wall's distance from the sensor: a
    /// planar beam already nearer skips the test.
    ///
    /// The hit test is division-free (`t = (a×e)/(d×e) ≥ 0` and `s = (a×d)/(d×e) ∈ [0, 1]`
    /// compared by sign); the one division gives `t` exactly as [`ray_segment_distance`].
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn sweep(&self, a: [Real; 2], b: [Real; 2], height: Real, j0: i64, count: usize, zs: Real, dmin: Real, best: &mut [Real]) {
        let n = self.config.columns;
        let e = [b[0] - a[0], b[1] - a[1]];
        let ae = cross2(a, e);
        let planar = self.config.channels == 1;
        let mut i = (j0 & (n as i64 - 1)) as usize; // n is a power of two: Euclidean remainder
        for _ in 0..count {
            let col = i;
            i += 1;
            if i == n {
                i = 0;
            }
            if planar && best[col] <= dmin {
                continue;
            }
            let (dc, ds) = (self.az_cos[col], self.az_sin[col]);
            let den = dc * e[1] - ds * e[0];
            let sn = a[0] * ds - a[1] * dc;
            let t = if den > 0.0 {
                if !(ae >= 0.0 && sn >= 0.0 && sn <= den) {
                    continue;
                }
                ae / den
            } else if den < 0.0 {
                if !(ae <= 0.0 && sn <= 0.0 && sn >= den) {
                    continue;
                }
                ae / den
            } else {
                match ray_segment_distance([0.0, 0.0], [dc, ds], a, b) {
                    Some(t) => t,
                    None => continue,
                }
            };
            if planar {
                if t < best[col] {
                    best[col] = t;
                }
            } else {
                for k in 0..self.el_tan.len() {
                    let z = zs + t * self.el_tan[k];
                    if z >= 0.0 && z <= height {
                        let r = t * self.el_sec[k];
                        let cell = &mut best[k * n + col];
                        if r < *cell {
                            *cell = r;
                        }
                    }
                }
            }
        }
    }

    /// [`Lidar::sweep`] for a planar ring, without branches but for walls parallel to a beam;
    /// with AVX2, four beams at once (see [`super::simd::flat_blocks_avx2`]), else more than a
    /// few beams go over contiguous runs, so that the divisions run several to an instruction.
    /// Returns whether one of the beams has no range (`inf`) after the sweep.
    #[inline(always)]
    pub(super) fn sweep_flat(&self, a: [Real; 2], b: [Real; 2], j0: i64, count: usize, best: &mut [Real]) -> bool {
        let n = self.config.columns;
        let i0 = (j0 & (n as i64 - 1)) as usize;
        let e = [b[0] - a[0], b[1] - a[1]];
        let ae = cross2(a, e);
        let (mut parallel, mut missed) = (false, false);
        if cfg!(target_arch = "x86_64") && self.simd != SimdLevel::Portable && i0 + count <= n {
            #[cfg(target_arch = "x86_64")]
            {
                // SAFETY: `simd` is not `Portable` only on a CPU found to run AVX2.
                (parallel, missed) = unsafe { super::simd::flat_blocks_avx2(a, e, ae, &self.az_cos, &self.az_sin, best, i0, count) };
            }
        } else if count <= 8 {
            let mut i = i0;
            for _ in 0..count {
                let (r, par) = flat_beam(a, e, ae, self.az_cos[i], self.az_sin[i], best[i]);
                best[i] = r;
                parallel |= par;
                missed |= r == Real::INFINITY;
                i = (i + 1) & (n - 1);
            }
        } else {
            let first = count.min(n - i0);
            for run in [i0..i0 + first, 0..count - first] {
                let beams = self.az_cos[run.clone()].iter().zip(&self.az_sin[run.clone()]);
                for ((&dc, &ds), cur) in beams.zip(&mut best[run]) {
                    let (r, par) = flat_beam(a, e, ae, dc, ds, *cur);
                    *cur = r;
                    parallel |= par;
                    missed |= r == Real::INFINITY;
                }
            }
        }
        if parallel {
            // a beam parallel to the wall (rare): the general test for those beams
            missed = false;
            for k in 0..count {
                let i = (i0 + k) & (n - 1);
                best[i] = parallel_beam(a, b, self.az_cos[i], self.az_sin[i], best[i]);
                missed |= best[i] == Real::INFINITY;
            }
        }
        missed
    }

    /// Applies range limits, noise and dropout, and fills the body-frame points.
    ///
    /// The draws: with noise, one standard normal per beam, in beam order (channel-major),
    /// whether or not the beam returns; then, with dropout, one uniform per beam. A fixed
    /// count per scan, drawn as blocks (see [`super::noise`]).
    pub(super) fn finish<R: Rng + ?Sized>(&mut self, rng: &mut R, out: &mut Scan) {
        let c = self.config;
        let n = out.ranges.len();
        if c.range_noise_std > 0.0 {
            self.normals.resize(n, 0.0);
            fill_standard_normal(rng, &mut self.normals);
        }
        if c.dropout > 0.0 {
            self.uniforms.resize(n, 0.0);
            fill_unit_uniform(rng, &mut self.uniforms);
        }
        match self.simd {
            // SAFETY: `simd` is found from the CPU: it runs these instructions.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => unsafe { self.apply_draws_and_points_avx512(out) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => unsafe { self.apply_draws_and_points_avx2(out) },
            _ => self.apply_draws_and_points(out),
        }
    }

    /// [`Lidar::apply_draws_and_points`] built for AVX2 and FMA (same numbers: no fused
    /// multiply-add is asked for).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn apply_draws_and_points_avx2(&self, out: &mut Scan) {
        self.apply_draws_and_points(out);
    }

    /// [`Lidar::apply_draws_and_points`] built for AVX-512 (same numbers).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq")]
    fn apply_draws_and_points_avx512(&self, out: &mut Scan) {
        self.apply_draws_and_points(out);
    }

    /// The range limits, the drawn noise and dropout, and the points, without branches.
    #[inline(always)]
    fn apply_draws_and_points(&self, out: &mut Scan) {
        let c = self.config;
        let (lo, hi) = (c.min_range, c.max_range);
        let in_range = |r: Real| r >= lo && r <= hi;
        if c.range_noise_std > 0.0 {
            let sd = c.range_noise_std;
            // a return out of range stays out; a noisy one that leaves the range is dropped
            for (r, z) in out.ranges.iter_mut().zip(&self.normals) {
                let noisy = *r + sd * *z as Real;
                *r = if in_range(*r) & in_range(noisy) { noisy } else { Real::INFINITY };
            }
        } else {
            for r in out.ranges.iter_mut() {
                *r = if in_range(*r) { *r } else { Real::INFINITY };
            }
        }
        if c.dropout > 0.0 {
            for (r, u) in out.ranges.iter_mut().zip(&self.uniforms) {
                *r = if *u < c.dropout { Real::INFINITY } else { *r };
            }
        }
        let (ms, mc) = c.mount.yaw.sin_cos();
        let n = c.columns;
        out.points.resize(out.ranges.len(), [0.0; 3]);
        for k in 0..c.channels {
            let (ec, es) = (self.el_cos[k], self.el_sin[k]);
            let rows = out.points[k * n..(k + 1) * n].iter_mut().zip(&out.ranges[k * n..(k + 1) * n]);
            for ((p, &r), (&ac, &as_)) in rows.zip(self.az_cos.iter().zip(&self.az_sin)) {
                let h = r * ec;
                let (xs, ys) = (h * ac, h * as_);
                let q = [c.mount.x + mc * xs - ms * ys, c.mount.y + ms * xs + mc * ys, c.mount.z + r * es];
                *p = if r.is_finite() { q } else { [Real::NAN; 3] };
            }
        }
    }
}

/// One beam `(dc, ds)` of [`Lidar::sweep_flat`] against the wall from `a` along `e` (`ae =
/// a × e`), nearest range so far `cur`: the new nearest range (the same test and quotient as
/// [`Lidar::sweep`]), and whether the beam is parallel to the wall (then left unchanged).
#[inline(always)]
fn flat_beam(a: [Real; 2], e: [Real; 2], ae: Real, dc: Real, ds: Real, cur: Real) -> (Real, bool) {
    let den = dc * e[1] - ds * e[0];
    let sn = a[0] * ds - a[1] * dc;
    let hit = (den > 0.0) & (ae >= 0.0) & (sn >= 0.0) & (sn <= den) | (den < 0.0) & (ae <= 0.0) & (sn <= 0.0) & (sn >= den);
    let t = ae / den;
    (if hit & (t < cur) { t } else { cur }, den == 0.0)
}

/// The nearest range of beam `(dc, ds)` so far, `cur`, after the general hit test against the
/// wall `a b` if the beam is parallel to it (which the division-free test of
/// [`Lidar::sweep_flat`] and its vector kernels leave unchanged); `cur` if not parallel.
#[inline]
pub(super) fn parallel_beam(a: [Real; 2], b: [Real; 2], dc: Real, ds: Real, cur: Real) -> Real {
    let e = [b[0] - a[0], b[1] - a[1]];
    if dc * e[1] - ds * e[0] != 0.0 {
        return cur;
    }
    ray_segment_distance([0.0, 0.0], [dc, ds], a, b).map_or(cur, |t| cur.min(t))
}

/// Distance from the origin to the segment `a b`.
#[inline]
pub(super) fn seg_origin_distance(a: [Real; 2], b: [Real; 2]) -> Real {
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
pub(super) fn ifloor(x: Real) -> i64 {
    let y = x + ROUND;
    (y.to_bits() as i64 - ROUND.to_bits() as i64) - ((y - ROUND) > x) as i64
}

/// `x.ceil()` as an integer, for `|x| < 2^51`, like [`ifloor`].
#[inline]
pub(super) fn iceil(x: Real) -> i64 {
    let y = x + ROUND;
    (y.to_bits() as i64 - ROUND.to_bits() as i64) + ((y - ROUND) < x) as i64
}

/// How far (rad) [`Lidar::wall_beams`] widens a wall's angular interval: five times the error
/// bound of [`fast_atan2`] (tested), far below a beam step (3.1e-3 rad at 2048 columns).
pub(super) const ANGLE_SLACK: Real = 1e-4;

/// Whether none of the `count` ranges from column `j0` (modulo their number, a power of two)
/// exceeds `d`.
#[inline]
pub(super) fn none_beyond(ranges: &[Real], j0: i64, count: usize, d: Real) -> bool {
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
pub(super) fn min(a: Real, b: Real) -> Real {
    if a < b {
        a
    } else {
        b
    }
}

/// The greater of `a` and `b` (finite), as one instruction (`f64::max` also orders NaNs).
#[inline(always)]
pub(super) fn max(a: Real, b: Real) -> Real {
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
pub(super) fn fast_atan2(y: Real, x: Real) -> Real {
    atan2_by(y, x, |n, d| n / d)
}

/// [`fast_atan2`] with `quotient(n, d)` for the one division `n / d` (`0 <= n <= d`, `d > 0`):
/// a quotient within a relative `e` of it moves the angle by at most `e` rad more.
#[inline(always)]
pub(super) fn atan2_by(y: Real, x: Real, quotient: impl Fn(Real, Real) -> Real) -> Real {
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn fast_atan2_is_within_its_bound() {
        let mut worst: Real = 0.0;
        for k in 0..100_000 {
            let a = k as Real * 1e-4 * std::f64::consts::TAU / 10.0 - 3.2;
            let (y, x) = (a.sin() * 3.7, a.cos() * 3.7);
            worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
        }
        assert!(worst < 2e-5, "worst {worst}");
    }

    /// The AVX2 and AVX-512 builds of the indexed scan, and the pieces' beams computed eight
    /// at once instead of four, give the portable build's ranges, bit for bit, on a generated
    /// site and (when `../shared/maps` is beside the repository) on the most cluttered real map.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_scans_equal_portable_scans() {
        use crate::world::generate::{generate, GeneratorConfig};
        use crate::world::{load_ros_map, RosMapOptions, SegmentIndex};
        let best = SimdLevel::detect();
        if best == SimdLevel::Portable {
            eprintln!("SKIPPED: no AVX2 on this CPU");
            return;
        }
        if best != SimdLevel::Avx512 {
            eprintln!("AVX-512 build not tested: not on this CPU");
        }
        let site = generate(4, &GeneratorConfig::default()).unwrap();
        let mut worlds = vec![("generated", site.scenario.map.segments, site.waypoints.iter().take(12).copied().collect::<Vec<_>>())];
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps/g4s_office");
        let yaml = std::fs::read_dir(&dir).map(|d| d.flatten().map(|e| e.path()).find(|p| p.extension().is_some_and(|x| x == "yaml"))).ok().flatten();
        if let Some(yaml) = yaml {
            let m = load_ros_map(&yaml, &RosMapOptions::default()).unwrap();
            let s = m.scenario.start;
            worlds.push(("g4s_office", m.scenario.map.segments, (0..12).map(|k| [s.x + 0.3 * k as Real, s.y - 0.1 * k as Real]).collect()));
        } else {
            eprintln!("real map skipped: no map in {}", dir.display());
        }
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for (name, walls, points) in worlds {
            let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
            let mesh = super::super::lidar_mesh::ScanMesh::new(&walls).unwrap();
            for channels in [1, 16] {
                let mut l = Lidar::new(LidarConfig { channels, range_noise_std: 0.0, ..Default::default() }).unwrap();
                for (k, w) in points.iter().enumerate() {
                    let pose = Pose2::new(w[0] + rng.random_range(-0.2..0.2), w[1], 0.7 * k as Real);
                    let mut scans: Vec<Scan> = (0..4).map(|_| Scan::default()).collect();
                    for s in scans.iter_mut() {
                        l.begin_scan(pose, 0.0, s).unwrap();
                    }
                    let sp = l.sensor_pose(pose);
                    l.simd = SimdLevel::Portable;
                    l.sweep_index::<4>(&index, &[], sp, &mut scans[0]);
                    // (eight pieces at once, as the AVX-512 build does, on any CPU)
                    l.sweep_index::<8>(&index, &[], sp, &mut scans[3]);
                    l.simd = SimdLevel::Avx2;
                    // SAFETY: this CPU runs AVX2 and FMA (`best` is not `Portable`).
                    unsafe { l.sweep_index_avx2(&index, &[], sp, &mut scans[1]) };
                    let bits = |s: &Scan| s.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>();
                    assert!(scans[0].ranges.iter().filter(|r| r.is_finite()).count() > 300 * channels);
                    assert_eq!(bits(&scans[0]), bits(&scans[1]), "{name}: AVX2, {channels} channels, pose {k}");
                    assert_eq!(bits(&scans[0]), bits(&scans[3]), "{name}: eight pieces at once, {channels} channels, pose {k}");
                    if channels == 1 {
                        // the walk of the triangulation, portable and built for AVX2 and
                        // AVX-512
                        for simd in [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512].into_iter().filter(|&s| s != SimdLevel::Avx512 || best == SimdLevel::Avx512) {
                            l.simd = simd;
                            let mut s = Scan::default();
                            l.begin_scan(pose, 0.0, &mut s).unwrap();
                            assert!(l.sweep_mesh(&mesh, sp, &mut s), "{name}: pose {k} off the triangulation");
                            // (before the range limits: the walk may keep a hit beyond the
                            // range where the index never swept that wall)
                            let max = l.config.max_range;
                            let clip = |r: Real| if r <= max { r.to_bits() } else { Real::INFINITY.to_bits() };
                            let diff: Vec<_> = (0..s.ranges.len()).filter(|&i| clip(scans[0].ranges[i]) != clip(s.ranges[i])).map(|i| (i, scans[0].ranges[i], s.ranges[i])).take(6).collect();
                            assert!(diff.is_empty(), "{name}: the walk ({simd:?}), pose {k}: {diff:?}");
                        }
                    }
                    if best == SimdLevel::Avx512 {
                        l.simd = SimdLevel::Avx512;
                        // SAFETY: this CPU runs AVX-512.
                        unsafe { l.sweep_index_avx512(&index, &[], sp, &mut scans[2]) };
                        assert_eq!(bits(&scans[0]), bits(&scans[2]), "{name}: AVX-512, {channels} channels, pose {k}");
                    }
                    // and the limits, noise, dropout and points alike
                    let mut noisy = Lidar::new(LidarConfig { channels, range_noise_std: 0.05, dropout: 0.1, max_range: 8.0, ..Default::default() }).unwrap();
                    let mut done: Vec<Scan> = Vec::new();
                    for simd in [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512].into_iter().filter(|&s| s != SimdLevel::Avx512 || best == SimdLevel::Avx512) {
                        noisy.simd = simd;
                        let mut s = scans[0].clone();
                        noisy.finish(&mut ChaCha8Rng::seed_from_u64(k as u64), &mut s);
                        done.push(s);
                    }
                    let point_bits = |s: &Scan| s.points.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert!(done[0].ranges.iter().any(|r| r.is_finite()) && done[0].ranges.iter().any(|r| r.is_infinite()));
                    for s in &done[1..] {
                        assert_eq!((bits(&done[0]), point_bits(&done[0])), (bits(s), point_bits(s)), "{name}: finished, {channels} channels, pose {k}");
                    }
                }
            }
        }
    }

    /// The planar sweep four beams at once gives the beam-by-beam sweep's ranges, bit for bit:
    /// walls at any angle and axis-aligned ones (beams parallel to them), near and far, over
    /// ranges already partly filled, without and across the wrap at column 0.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_planar_sweep_equals_portable_sweep() {
        if SimdLevel::detect() == SimdLevel::Portable {
            eprintln!("SKIPPED: no AVX2 on this CPU");
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut l = Lidar::new(LidarConfig { range_noise_std: 0.0, ..Default::default() }).unwrap();
        let mut parallel = 0;
        for trial in 0..20_000 {
            let mut a = [rng.random_range(-6.0..6.0), rng.random_range(-6.0..6.0)];
            if trial % 8 == 0 {
                // a horizontal wall nearly through the sensor: the beams along it are in its
                // interval's slack
                a[1] = rng.random_range(-1e-5..1e-5);
            }
            let b = match trial % 4 {
                0 => [a[0] + rng.random_range(-3.0..3.0), a[1]],
                1 => [a[0], a[1] + rng.random_range(-3.0..3.0)],
                _ => [a[0] + rng.random_range(-3.0..3.0), a[1] + rng.random_range(-3.0..3.0)],
            };
            let cr = cross2(a, b);
            if cr == 0.0 {
                continue;
            }
            let (j0, count) = l.wall_beams(a, b, cr);
            parallel += (0..count).any(|k| {
                let i = (j0 + k as i64).rem_euclid(1024) as usize;
                l.az_cos[i] * (b[1] - a[1]) - l.az_sin[i] * (b[0] - a[0]) == 0.0
            }) as usize;
            let start: Vec<Real> = (0..1024).map(|_| if rng.random_bool(0.3) { Real::INFINITY } else { rng.random_range(0.1..8.0) }).collect();
            let (mut portable, mut vector) = (start.clone(), start);
            l.simd = SimdLevel::Portable;
            let portable_missed = l.sweep_flat(a, b, j0, count, &mut portable);
            l.simd = SimdLevel::Avx2;
            let vector_missed = l.sweep_flat(a, b, j0, count, &mut vector);
            let bits = |v: &[Real]| v.iter().map(|r| r.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&portable), bits(&vector), "wall {a:?} {b:?}, beams {j0} + {count}");
            // whether a swept beam is left without a range, from either build
            let missed = (0..count).any(|k| portable[(j0 + k as i64).rem_euclid(1024) as usize] == Real::INFINITY);
            assert_eq!((portable_missed, vector_missed), (missed, missed), "wall {a:?} {b:?}, beams {j0} + {count}");
        }
        assert!(parallel > 100, "{parallel} walls with a parallel beam");
    }

    #[test]
    fn ifloor_and_iceil_equal_floor_and_ceil() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut xs: Vec<Real> = vec![0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 2.5, 3.0, -3.0, 1e-300, -1e-300, 4095.999999, -4096.0000001, 1e15 + 0.5, -(1e15 + 0.5)];
        xs.extend((0..100_000).map(|_| rng.random_range(-5000.0..5000.0)));
        xs.extend((0..1000).map(|k| k as Real * 0.25 - 100.0));
        for x in xs {
            assert_eq!(ifloor(x), x.floor() as i64, "floor {x}");
            assert_eq!(iceil(x), x.ceil() as i64, "ceil {x}");
        }
    }

    #[test]
    fn invalid_configs_name_the_field() {
        for (cfg, field) in [
            (LidarConfig { channels: 8, ..Default::default() }, "channels"),
            (LidarConfig { columns: 1000, ..Default::default() }, "columns"),
            (LidarConfig { max_range: 0.05, ..Default::default() }, "max_range"),
            (LidarConfig { dropout: 1.0, ..Default::default() }, "dropout"),
            (LidarConfig { rate_hz: 5.0, ..Default::default() }, "rate_hz"),
            (LidarConfig { range_noise_std: Real::NAN, ..Default::default() }, "range_noise_std"),
        ] {
            let e = Lidar::new(cfg).unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
    }

    #[test]
    fn a_scan_rate_faster_than_the_control_rate_is_an_error_naming_both() {
        let c = LidarConfig { rate_hz: 20.0, ..Default::default() };
        let e = c.check_rate(0.1).unwrap_err().to_string();
        assert!(e.contains("rate_hz") && e.contains("dt"), "{e}");
        c.check_rate(0.05).unwrap();
        LidarConfig { rate_hz: 10.0, ..Default::default() }.check_rate(0.1).unwrap();
        LidarConfig { rate_hz: 20.0, ..Default::default() }.check_rate(0.02).unwrap();
    }

    #[test]
    fn planar_ring_passes_over_low_walls() {
        let mut l = Lidar::new(LidarConfig { range_noise_std: 0.0, ..Default::default() }).unwrap();
        let low = [Segment::new([1.0, -1.0], [1.0, 1.0], 0.3)];
        let high = [Segment::new([3.0, -1.0], [3.0, 1.0], 2.0)];
        let mut scan = Scan::default();
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        l.scan_into(&[&low, &high], Pose2::default(), 0.0, &mut rng, &mut scan).unwrap();
        assert!((scan.ranges[0] - 3.0).abs() < 1e-12);
    }

    #[test]
    fn mount_offset_moves_points_into_the_body_frame() {
        let cfg = LidarConfig { range_noise_std: 0.0, mount: LidarMount { x: 0.5, y: 0.0, z: 0.4, yaw: std::f64::consts::PI }, ..Default::default() };
        let mut l = Lidar::new(cfg).unwrap();
        let wall = [Segment::new([-2.0, -1.0], [-2.0, 1.0], 2.0)];
        let mut scan = Scan::default();
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        l.scan_into(&[&wall], Pose2::default(), 0.0, &mut rng, &mut scan).unwrap();
        // column 0 looks backwards (mount yaw π) from x = 0.5: the wall is 2.5 m away
        assert!((scan.ranges[0] - 2.5).abs() < 1e-12);
        let p = scan.points[0];
        assert!((p[0] + 2.0).abs() < 1e-12 && p[1].abs() < 1e-12 && (p[2] - 0.4).abs() < 1e-15);
    }

    #[test]
    fn dropout_and_noise_use_the_given_rng() {
        let cfg = LidarConfig { dropout: 0.3, range_noise_std: 0.02, ..Default::default() };
        let mut l = Lidar::new(cfg).unwrap();
        let wall = [Segment::new([-2.0, -3.0], [-2.0, 3.0], 2.0), Segment::new([2.0, -3.0], [2.0, 3.0], 2.0)];
        let mut s1 = Scan::default();
        let mut s2 = Scan::default();
        l.scan_into(&[&wall], Pose2::default(), 0.0, &mut ChaCha8Rng::seed_from_u64(5), &mut s1).unwrap();
        l.scan_into(&[&wall], Pose2::default(), 0.0, &mut ChaCha8Rng::seed_from_u64(5), &mut s2).unwrap();
        assert_eq!(s1.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>(), s2.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>());
        let hits = s1.ranges.iter().filter(|r| r.is_finite()).count();
        // the two walls cover 2·2·atan(1.5) of the circle; ~30 % of those returns are dropped
        let expected = 1024.0 * 4.0 * (1.5f64).atan() / std::f64::consts::TAU * 0.7;
        assert!((hits as Real - expected).abs() < 0.08 * expected, "{hits} vs {expected}");
    }
}
