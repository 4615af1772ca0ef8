//! The beam tables of a LIDAR and the sweeps every scan shares: the beams a wall can hit, the
//! exact hit test, the planar block sweep, and the range limits, noise and points at the end.

use rand::Rng;

use super::super::noise::{fill_standard_normal, fill_unit_uniform};
use super::super::ray_segment::ray_segment_distance;
use super::config::{LidarConfig, Scan};
use super::numeric::{fast_atan2, flat_beam, iceil, ifloor, none_beyond, parallel_beam, ANGLE_SLACK};
use crate::error::{Error, Result};
use crate::math::Real;
use crate::simd::SimdLevel;
use crate::world::{cross2, Pose2};

/// A LIDAR's configuration with its precomputed beam tables and the scratch of its draws.
#[derive(Debug, Clone)]
pub(crate) struct Beams {
    pub(crate) config: LidarConfig,
    pub(crate) az_cos: Vec<Real>,
    pub(crate) az_sin: Vec<Real>,
    /// Columns per radian.
    pub(crate) inv_step: Real,
    pub(crate) el_tan: Vec<Real>,
    pub(crate) el_sec: Vec<Real>,
    pub(crate) el_cos: Vec<Real>,
    pub(crate) el_sin: Vec<Real>,
    /// Scratch of the noise draws (one normal per beam).
    normals: Vec<f32>,
    /// Scratch of the dropout draws (one uniform per beam).
    uniforms: Vec<Real>,
    /// The vector instructions the scans run with.
    pub(crate) simd: SimdLevel,
}

impl Beams {
    /// Builds the beam tables after validating `config`.
    pub(crate) fn new(config: LidarConfig) -> Result<Self> {
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
            normals: Vec::new(),
            uniforms: Vec::new(),
            simd: SimdLevel::detect(),
        })
    }

    /// The sensor's planar pose in the world for a robot at `body`.
    pub(crate) fn sensor_pose(&self, body: Pose2) -> Pose2 {
        let m = self.config.mount;
        body.compose(&Pose2::new(m.x, m.y, m.yaw))
    }

    /// Unit direction of column `i`, channel `k` in the sensor frame.
    ///
    /// # Panics
    ///
    /// If `k` is not below the channels or `i` not below the columns, as slice indexing does.
    pub(crate) fn beam_direction(&self, k: usize, i: usize) -> [Real; 3] {
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

    /// Sweeps one wall given in the sensor frame, `dmin` its distance from the sensor.
    #[inline]
    pub(crate) fn sweep_segment(&self, a: [Real; 2], b: [Real; 2], height: Real, dmin: Real, zs: Real, best: &mut [Real]) {
        self.sweep_piece(a, b, a, b, height, dmin, zs, best);
    }

    /// Sweeps the beams through the part `p q` of the wall `a b` (sensor frame) with hits on
    /// the whole wall; `dmin` is no farther than the part. A planar scan skips the wall if
    /// every such beam already hits no farther than `dmin`, else sweeps them in blocks without
    /// a test each ([`Beams::sweep_flat`]).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn sweep_piece(&self, a: [Real; 2], b: [Real; 2], p: [Real; 2], q: [Real; 2], height: Real, dmin: Real, zs: Real, best: &mut [Real]) {
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
    pub(crate) fn wall_beams(&self, a: [Real; 2], b: [Real; 2], cr: Real) -> (i64, usize) {
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
    pub(crate) fn sweep(&self, a: [Real; 2], b: [Real; 2], height: Real, j0: i64, count: usize, zs: Real, dmin: Real, best: &mut [Real]) {
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

    /// [`Beams::sweep`] for a planar ring, without branches but for walls parallel to a beam;
    /// with AVX2, four beams at once (see [`super::simd::flat_blocks_avx2`]), else more than a
    /// few beams go over contiguous runs, so that the divisions run several to an instruction.
    /// Returns whether one of the beams has no range (`inf`) after the sweep.
    #[inline(always)]
    pub(crate) fn sweep_flat(&self, a: [Real; 2], b: [Real; 2], j0: i64, count: usize, best: &mut [Real]) -> bool {
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
    pub(crate) fn finish<R: Rng + ?Sized>(&mut self, rng: &mut R, out: &mut Scan) {
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

    /// [`Beams::apply_draws_and_points`] built for AVX2 and FMA (same numbers: no fused
    /// multiply-add is asked for).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn apply_draws_and_points_avx2(&self, out: &mut Scan) {
        self.apply_draws_and_points(out);
    }

    /// [`Beams::apply_draws_and_points`] built for AVX-512 (same numbers).
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
