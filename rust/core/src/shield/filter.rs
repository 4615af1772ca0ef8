//! The [`Shield`]: configuration checked once, scratch buffers, and the filter call that
//! dispatches to each method's row (composite here, braking and the baselines beside).

use std::time::Instant;

use super::composite::{check_gamma_kappa, composite_of_valid, CompositeBarrier, CompositeParams, Motion, SimdLevel};
use super::config::{finite, positive, ShieldConfig, ShieldMethod};
use super::conic::{solve_rows, LinearConstraints};
use super::ellipsoid::Envelope;
use super::input::{check_finite, BodyState, Points, Scan, MAX_BODY_RATE};
use super::lane::Lane;
use super::qp::{self, QpSolution, MAX_VARS};
use super::scan::{select_points, ScanScratch};
use crate::error::{Error, Result};
use crate::math::{mat_vec, Mat3, Vec3};
use crate::sensors::Mover;

/// Everything one filter call produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShieldOutcome {
    /// Filtered world-frame command `u*` (first `dim` entries).
    pub u: Vec3,
    /// 2 (planar) or 3.
    pub dim: usize,
    /// The barrier the row was built from: the composite `H` (composite and none), the
    /// nearest point's `h` (hardmin), `min_i (‖p_i − p_r‖² − s_d²)` (distance).
    pub value: f64,
    /// `min_i h_i` of the method's per-point CBFs (`f64::MAX` when no point is used).
    pub h_min: f64,
    /// World-frame `∂H/∂p_r` (for distance: the nearest point's row).
    pub grad_p: Vec3,
    /// `∂H/∂t` (0 for distance: a sphere does not turn).
    pub dh_dt: f64,
    /// Points used after crop, band and down-sampling.
    pub num_points: usize,
    /// The constraints changed the command (beyond the box clamp of `u_nom`).
    pub active: bool,
    /// The constraints could be met; if not, `u` is the documented fallback.
    pub feasible: bool,
    /// Wall time of the whole call, points in to `u*` out (ns).
    pub solve_time_ns: u64,
    /// The rotation command: filtered by the braking shield, the given `ω` otherwise
    /// (body frame; `[0, 0, ω]` planar).
    pub omega: Vec3,
    /// The braking check found no safe fraction of the row's command nor of the tight-space
    /// command: the shield sends the brake (`0`).
    pub braked: bool,
    /// The ellipse already holds a point (`min h_i < 0`): the row's command is the one that
    /// raises `H` fastest within the box (the least-violating solution when the row cannot be
    /// met); the braking check still decides how much of it is sent.
    pub recovering: bool,
    /// The braking check's margin for the row's full command (m): the least clearance of the
    /// footprint swept until the robot stands, less the clearance required (≥ 0 passes); NaN
    /// when no check ran.
    pub sweep_h: f64,
    /// The braking shield sent (a safe fraction of) the tight-space command, the nominal
    /// command at most `tight_speed`, because the row's command made less progress: the
    /// ellipse does not fit where the body does.
    pub tight: bool,
    /// The least clearance (m) of the standing footprint to the points the check used
    /// (`f64::MAX` when none is within reach); NaN when no check ran.
    pub clearance: f64,
}

/// The largest `mover_accel` (m/s²) accepted.
pub const MAX_MOVER_ACCEL: f64 = 50.0;

/// The safety shield: configuration, scratch buffers and the SIMD level of its kernel.
#[derive(Debug, Clone)]
pub struct Shield {
    pub(super) config: ShieldConfig,
    pub(super) envelope: Envelope,
    pub(super) level: SimdLevel,
    pub(super) scratch: ScanScratch,
    pub(super) buf32: Vec<f32>,
    pub(super) buf64: Vec<f64>,
    /// The braking check's replayed path, reused from call to call.
    pub(super) brake_path: Vec<[f64; 2]>,
    /// The world-frame direction of the escape sent at the previous call, kept while it still
    /// passes (see `filter_braking`): cleared by [`Shield::reset`] and by any other command.
    pub(super) escape: Option<[f64; 2]>,
    /// Calls in a row that sent an escape.
    pub(super) escape_calls: u32,
    /// The braking check's points within reach, moved (rows of 2), reused from call to call.
    pub(super) near32: Vec<f32>,
    pub(super) near64: Vec<f64>,
    pub(super) moved32: Vec<f32>,
    pub(super) moved64: Vec<f64>,
    pub(super) body: Vec<f64>,
    pub(super) rows: LinearConstraints,
}

/// What one method's row gives the filter call.
pub(super) struct Filtered {
    pub(super) value: f64,
    pub(super) h_min: f64,
    pub(super) grad_p: Vec3,
    pub(super) dh_dt: f64,
    pub(super) num_points: usize,
    pub(super) sol: QpSolution,
    /// The rotation command sent (the given `ω` but for the braking shield).
    pub(super) omega: Vec3,
    pub(super) braked: bool,
    pub(super) recovering: bool,
    pub(super) sweep_h: f64,
    pub(super) tight: bool,
    pub(super) clearance: f64,
}

impl Filtered {
    /// A row without the braking check: the given rotation passes through.
    pub(super) fn unchecked(value: f64, h_min: f64, grad_p: Vec3, dh_dt: f64, num_points: usize, sol: QpSolution, omega: Vec3) -> Self {
        Self { value, h_min, grad_p, dh_dt, num_points, sol, omega, braked: false, recovering: false, sweep_h: f64::NAN, tight: false, clearance: f64::NAN }
    }
}

/// A body-frame vector `g` in the world frame (`R g`), its z dropped for a planar shield.
pub(super) fn to_world(r: &Mat3, dim: usize, g: &Vec3) -> Vec3 {
    let mut w = mat_vec(r, g);
    if dim == 2 {
        w[2] = 0.0;
    }
    w
}

impl Shield {
    /// Validates `config`; every error names the field at fault.
    pub fn new(config: ShieldConfig) -> Result<Self> {
        let envelope = Envelope::new(&config.semi_axes)?;
        check_gamma_kappa(config.gamma, config.kappa)?;
        positive("alpha", config.alpha)?;
        positive("safety_distance", config.safety_distance)?;
        if !(config.grad_eps.is_finite() && config.grad_eps >= 0.0) {
            return Err(Error::invalid("grad_eps", format!("must be finite and ≥ 0, got {}", config.grad_eps)));
        }
        if let Some(m) = &config.u_max {
            if m.len() != envelope.dim() {
                return Err(Error::DimensionMismatch { name: "u_max", expected: envelope.dim(), got: m.len() });
            }
            for &v in m {
                positive("u_max", v)?;
            }
        }
        config.scan.validate()?;
        config.braking.validate()?;
        if !(config.tight_speed.is_finite() && (0.0..=MAX_BODY_RATE).contains(&config.tight_speed)) {
            return Err(Error::invalid("tight_speed", format!("must be from 0 to {MAX_BODY_RATE} m/s, got {}", config.tight_speed)));
        }
        if !(config.mover_accel.is_finite() && (0.0..=MAX_MOVER_ACCEL).contains(&config.mover_accel)) {
            return Err(Error::invalid("mover_accel", format!("must be from 0 to {MAX_MOVER_ACCEL} m/s², got {}", config.mover_accel)));
        }
        if !(config.rotation_weight.is_finite() && (1e-3..=1e3).contains(&config.rotation_weight)) {
            return Err(Error::invalid("rotation_weight", format!("must be from 1e-3 to 1e3, got {}", config.rotation_weight)));
        }
        let dim = envelope.dim();
        Ok(Self {
            config,
            envelope,
            level: SimdLevel::detect(),
            scratch: ScanScratch::default(),
            buf32: Vec::new(),
            buf64: Vec::new(),
            brake_path: Vec::new(),
            escape: None,
            escape_calls: 0,
            near32: Vec::new(),
            near64: Vec::new(),
            moved32: Vec::new(),
            moved64: Vec::new(),
            body: Vec::new(),
            rows: LinearConstraints::new(dim),
        })
    }

    /// Runs the composite kernel at `level` instead of the best one detected (benchmarks).
    pub fn with_simd_level(mut self, level: SimdLevel) -> Result<Self> {
        if !level.is_supported() {
            return Err(Error::invalid("simd_level", format!("{level:?} is not supported by this CPU")));
        }
        self.level = level;
        Ok(self)
    }

    /// The configuration.
    pub fn config(&self) -> &ShieldConfig {
        &self.config
    }

    /// The ellipsoid.
    pub fn envelope(&self) -> &Envelope {
        &self.envelope
    }

    /// The SIMD level the composite kernel runs at.
    pub fn simd_level(&self) -> SimdLevel {
        self.level
    }

    /// Forgets what the braking shield keeps from call to call (the escape it is running):
    /// call it when the robot's episode starts anew.
    pub fn reset(&mut self) {
        self.escape = None;
        self.escape_calls = 0;
    }

    /// 2 for a planar shield, 3 for 3D.
    pub fn dim(&self) -> usize {
        self.envelope.dim()
    }

    /// Filters `u_nom` (world frame) against a body-frame `scan`.
    pub fn filter(&mut self, scan: &Scan, state: &BodyState, u_nom: &[f64]) -> Result<ShieldOutcome> {
        self.filter_with(scan, state, u_nom, None)
    }

    /// [`Shield::filter`] with extra user rows `a_kᵀu ≥ c_k`, solved together with the CBF row
    /// by Clarabel.
    pub fn filter_with(&mut self, scan: &Scan, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<ShieldOutcome> {
        let start = Instant::now();
        let in_kernel = matches!(self.config.method, ShieldMethod::Braking | ShieldMethod::Composite | ShieldMethod::Unfiltered);
        if scan.motion.is_some() && !in_kernel {
            // the baselines read the points directly
            return self.on_moved_copy(scan, |sh, moved| sh.filter_with(moved, state, u_nom, extra));
        }
        let dim = self.dim();
        self.check_inputs(scan, state, u_nom, extra)?;
        let f = match self.config.method {
            ShieldMethod::Braking => self.braking_row(scan, state, u_nom, extra)?,
            ShieldMethod::Composite | ShieldMethod::Unfiltered => self.composite_row(scan, state, u_nom, extra)?,
            ShieldMethod::HardMin => self.hard_min_row(scan, state, u_nom, extra)?,
            ShieldMethod::Distance => self.distance_row(scan, state, u_nom, extra)?,
        };
        let Filtered { value, h_min, grad_p, dh_dt, num_points, sol, omega: omega_out, braked, recovering, sweep_h, tight, clearance } = f;
        if !sol.u.iter().chain(&omega_out).all(|v| v.is_finite()) {
            // (never seen within the parameters' bounds; a NaN command must not reach a robot)
            return Err(Error::Solver(format!("the filtered command is not finite: {:?}", &sol.u[..dim])));
        }
        Ok(ShieldOutcome {
            u: [sol.u[0], sol.u[1], sol.u[2]],
            dim,
            value,
            h_min,
            grad_p,
            dh_dt,
            num_points,
            active: sol.active,
            feasible: sol.feasible,
            solve_time_ns: start.elapsed().as_nanos() as u64,
            omega: omega_out,
            braked,
            recovering,
            sweep_h,
            tight,
            clearance,
        })
    }

    /// [`Shield::filter_with`] for a scan in the world frame: points `p_i^W`, the robot at
    /// `position` (three finite values; a scan of 2-D points ignores its z, and the heights of
    /// 3-D points are taken relative to it, so a planar shield's height band applies to
    /// `z − position[2]`). The points are taken to the body frame,
    /// `Rᵀ(p_i − p_r)`, so only relative positions matter (an odometry jump that moves robot
    /// and points together changes nothing).
    pub fn filter_world(&mut self, scan: &Scan, position: &Vec3, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<ShieldOutcome> {
        finite("position", position)?;
        if scan.motion.is_some() {
            return Err(Error::invalid("motion", "applies to body-frame scans; move world-frame points yourself"));
        }
        let stride = scan.stride;
        let mut body = std::mem::take(&mut self.body);
        body.clear();
        body.reserve(scan.len() * stride);
        let rt = state.rotation;
        let mut push = |p: [f64; 3]| {
            let d = [p[0] - position[0], p[1] - position[1], if stride == 3 { p[2] - position[2] } else { 0.0 }];
            let b = crate::math::mat_t_vec(&rt, &d);
            body.extend_from_slice(&b[..stride]);
        };
        match scan.points {
            Points::F32(p) => p.chunks_exact(stride).for_each(|c| push([c[0] as f64, c[1] as f64, if stride == 3 { c[2] as f64 } else { 0.0 }])),
            Points::F64(p) => p.chunks_exact(stride).for_each(|c| push([c[0], c[1], if stride == 3 { c[2] } else { 0.0 }])),
        }
        let out = Scan::new_f64(&body, stride).and_then(|s| self.filter_with(&s.with_movers(scan.movers), state, u_nom, extra));
        self.body = body;
        out
    }

    /// The composite barrier of `scan` (after crop, band and down-sampling), without filtering.
    pub fn barrier(&mut self, scan: &Scan, state: &BodyState) -> Result<CompositeBarrier> {
        let mut params = CompositeParams {
            envelope: self.envelope,
            gamma: self.config.gamma,
            kappa: self.config.kappa,
            crop_radius: self.config.scan.crop_radius,
            height_band: self.config.scan.height_band,
            omega: state.omega,
        };
        if !self.config.scan.downsamples() {
            return match scan.points {
                Points::F32(p) => composite_of_valid(p, scan.stride, scan.motion, &params, self.level),
                Points::F64(p) => composite_of_valid(p, scan.stride, scan.motion, &params, self.level),
            };
        }
        if scan.motion.is_some() {
            // down-sampling reads the points directly
            return self.on_moved_copy(scan, |sh, moved| sh.barrier(moved, state));
        }
        check_finite(scan)?;
        params.crop_radius = None;
        params.height_band = None;
        let dim = self.dim();
        match scan.points {
            Points::F32(p) => {
                select_points(p, scan.stride, &self.envelope, &self.config.scan, &mut self.scratch, &mut self.buf32);
                composite_of_valid(&self.buf32, dim, None, &params, self.level)
            }
            Points::F64(p) => {
                select_points(p, scan.stride, &self.envelope, &self.config.scan, &mut self.scratch, &mut self.buf64);
                composite_of_valid(&self.buf64, dim, None, &params, self.level)
            }
        }
    }

    /// Runs `f` on a copy of `scan` moved by its motion (for the paths that read the points
    /// directly; the composite kernel moves them itself).
    pub(super) fn on_moved_copy<R>(&mut self, scan: &Scan, f: impl FnOnce(&mut Self, &Scan) -> Result<R>) -> Result<R> {
        let Some(m) = scan.motion else { return f(self, scan) };
        if !m.is_finite() {
            return Err(Error::invalid("motion", "contains NaN or inf"));
        }
        let (mut b32, mut b64) = (std::mem::take(&mut self.moved32), std::mem::take(&mut self.moved64));
        let moved = match scan.points {
            Points::F32(p) => {
                move_points(p, scan.stride, &m, &mut b32);
                Scan::new_f32(&b32, scan.stride).map(|s| s.with_movers(scan.movers))
            }
            Points::F64(p) => {
                move_points(p, scan.stride, &m, &mut b64);
                Scan::new_f64(&b64, scan.stride).map(|s| s.with_movers(scan.movers))
            }
        };
        let out = moved.and_then(|moved| f(self, &moved));
        (self.moved32, self.moved64) = (b32, b64);
        out
    }

    /// The points a baseline uses, as `f64` rows of `dim` (checked finite by the caller).
    pub(super) fn selected_f64(&mut self, scan: &Scan) -> &[f64] {
        match scan.points {
            Points::F32(p) => {
                select_points(p, scan.stride, &self.envelope, &self.config.scan, &mut self.scratch, &mut self.buf32);
                self.buf64.clear();
                self.buf64.extend(self.buf32.iter().map(|&v| v as f64));
            }
            Points::F64(p) => {
                select_points(p, scan.stride, &self.envelope, &self.config.scan, &mut self.scratch, &mut self.buf64);
            }
        }
        &self.buf64
    }

    /// [`qp::project_checked`] over `n` variables with the box `lim`, or Clarabel with the
    /// user's rows (over the translation; zero on the rotation).
    pub(super) fn solve_row_n(&mut self, x_nom: &[f64], row: &[f64], b: f64, lim: &[f64], extra: Option<&LinearConstraints>) -> Result<QpSolution> {
        let n = x_nom.len();
        match extra {
            None => Ok(qp::project_checked(x_nom, row, b, Some(lim), self.config.grad_eps)),
            Some(e) => {
                let mut rows = LinearConstraints::new(n);
                if b.is_finite() {
                    rows.push(row, b)?;
                }
                let mut padded = [0.0; MAX_VARS];
                for k in 0..e.len() {
                    let (a, c) = e.row(k);
                    padded[..n].fill(0.0);
                    padded[..a.len()].copy_from_slice(a);
                    rows.push(&padded[..n], c)?;
                }
                solve_rows(x_nom, &rows, Some(lim))
            }
        }
    }

    pub(super) fn solve_row(&mut self, u_nom: &[f64], g: &Vec3, b: f64, u_max: Option<&[f64]>, extra: Option<&LinearConstraints>) -> Result<QpSolution> {
        let dim = self.dim();
        match extra {
            None => Ok(qp::project_checked(u_nom, &g[..dim], b, u_max, self.config.grad_eps)),
            Some(e) => {
                self.rows.clear();
                if b.is_finite() {
                    self.rows.push(&g[..dim], b)?;
                }
                self.rows.extend(e)?;
                solve_rows(u_nom, &self.rows, u_max)
            }
        }
    }

    pub(super) fn check_inputs(&self, scan: &Scan, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<()> {
        let dim = self.dim();
        if u_nom.len() != dim {
            return Err(Error::DimensionMismatch { name: "u_nom", expected: dim, got: u_nom.len() });
        }
        finite("u_nom", u_nom)?;
        for m in scan.movers {
            m.validate()?;
        }
        if !scan.movers.is_empty() && dim != 2 {
            return Err(Error::invalid("movers", "moving objects are taken by a planar shield only"));
        }
        if scan.stride < dim {
            return Err(Error::DimensionMismatch { name: "points", expected: dim, got: scan.stride });
        }
        if dim == 2 && !state.planar {
            return Err(Error::invalid("rotation", "a planar shield takes yaw and a scalar omega, not a 3D rotation"));
        }
        if let Some(e) = extra {
            if e.dim() != dim {
                return Err(Error::DimensionMismatch { name: "extra_A", expected: dim, got: e.dim() });
            }
            if self.config.method == ShieldMethod::Unfiltered {
                return Err(Error::invalid("extra_A", "method \"none\" applies no constraints; pick a filtering method"));
            }
        }
        // (the composite kernel, which the braking shield runs first, rejects NaN and inf itself)
        if !matches!(self.config.method, ShieldMethod::Composite | ShieldMethod::Unfiltered | ShieldMethod::Braking) {
            check_finite(scan)?;
        }
        Ok(())
    }

    /// The paper's composite row (Eq. qp), or the nominal command unfiltered (`none`).
    pub(super) fn composite_row(&mut self, scan: &Scan, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<Filtered> {
        let (dim, r) = (self.dim(), state.rotation);
        let alpha = self.config.alpha;
        let u_max = self.config.u_max.clone();
        let b = self.barrier(scan, state)?;
        let g = to_world(&r, dim, &b.grad_body);
        let dh_movers = self.movers_dh_dt(scan.movers, b.value);
        let sol = if self.config.method == ShieldMethod::Unfiltered {
            let mut u = [0.0; MAX_VARS];
            u[..dim].copy_from_slice(u_nom);
            QpSolution { u, active: false, feasible: true }
        } else {
            self.solve_row(u_nom, &g, -alpha * b.value - b.dh_dt - dh_movers, u_max.as_deref(), extra)?
        };
        Ok(Filtered::unchecked(b.value, b.h_min, g, b.dh_dt + dh_movers, b.num_points, sol, state.omega))
    }
}

impl Shield {
    /// The movers' share of `∂H/∂t`: each mover's nearest point `q` (its disc's point nearest
    /// the robot) moves at the mover's velocity `v`, `ḣ = ∂h/∂q · v = 2 A q · v`, weighed as
    /// the composite weighs the points it stands for, `min(1, λ) sech²(h/γ)` with `λ` the
    /// point's soft-min weight `exp(−κ (tanh(h/γ) − H/γ))` given `H`: 1 where the mover holds
    /// the nearest point, as its cluster's weights sum to about 1 there.
    pub(super) fn movers_dh_dt(&self, movers: &[Mover], value: f64) -> f64 {
        let (gamma, kappa) = (self.config.gamma, self.config.kappa);
        movers
            .iter()
            .map(|m| {
                let c = m.centre;
                let d = c[0].hypot(c[1]);
                let k = if d > m.radius { 1.0 - m.radius / d } else { 0.0 };
                let q = [k * c[0], k * c[1], 0.0];
                let h = self.envelope.h_body(&q);
                let g = self.envelope.grad_body(&q);
                let hdot = -(g[0] * m.velocity[0] + g[1] * m.velocity[1]);
                let th = (h / gamma).tanh();
                let weight = (-kappa * (th - value / gamma)).exp().min(1.0) * (1.0 - th * th);
                weight * hdot
            })
            .sum()
    }
}

/// `out` = the rows of `pts` (stride 2 or 3) moved by `m` ([`Motion::apply`]).
pub fn move_points<T: Lane>(pts: &[T], stride: usize, m: &Motion, out: &mut Vec<T>) {
    out.clear();
    out.extend_from_slice(pts);
    for row in out.chunks_exact_mut(stride) {
        (row[0], row[1]) = m.apply(row[0], row[1]);
    }
}
