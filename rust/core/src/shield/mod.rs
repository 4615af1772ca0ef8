//! The composite-CBF safety shield of the paper (Sec. III) and its baselines.
//!
//! A [`Shield`] turns a nominal world-frame velocity `u_nom` and a body-frame LIDAR scan into
//! the filtered command `u*` of Eq. (qp):
//!
//! `u* = argmin ‖u − u_nom‖²  s.t.  ∂H/∂pᵀ u ≥ −α(H) − ∂H/∂t,  |u_j| ≤ u_max_j`.
//!
//! Methods ([`ShieldMethod`]): the braking shield (the composite row over velocity *and*
//! rotation, and the [`braking`] check against the body's tracker, so the guarantee holds
//! for the body that lags behind its command), the paper's soft-min composite of one
//! ellipsoidal CBF per point (closed-form exact QP, translation only), the distance baseline
//! (one spherical row per point, all rows in one Clarabel QP), hard-min (the nearest point's
//! ellipsoidal CBF only), and no filter.
//!
//! ```
//! use shieldnav_core::shield::{BodyState, Scan, Shield, ShieldConfig};
//! let mut shield = Shield::new(ShieldConfig::default()).unwrap();
//! // a wall 0.6 m to the left of the robot, the robot asked to move left at 1 m/s
//! let wall: Vec<f64> = (-20..=20).flat_map(|k| [k as f64 * 0.05, 0.6]).collect();
//! let out = shield.filter(&Scan::new_f64(&wall, 2).unwrap(), &BodyState::planar(0.0, 0.0).unwrap(), &[0.0, 1.0]).unwrap();
//! assert!(out.active && out.feasible);
//! assert!(out.u[1] < 1.0); // slowed down toward the wall
//! ```

pub mod braking;
mod composite;
mod conic;
mod ellipsoid;
mod lane;
mod qp;
mod scan;

use std::time::Instant;

pub use braking::{BrakingModel, Sweep};
use composite::composite_of_valid;
pub use composite::{composite_reference, evaluate_composite, evaluate_composite_moved, CompositeBarrier, CompositeParams, Motion, SimdLevel};
pub use conic::{solve_rows, LinearConstraints};
pub use ellipsoid::{Envelope, MAX_SEMI_AXIS, MIN_SEMI_AXIS};
pub use lane::Lane;
pub use qp::{project_halfspace_box, QpSolution, MAX_VARS};
pub use scan::{select_points, ScanFilter, ScanScratch, MAX_ANGULAR_BINS};

use crate::error::{Error, Result};
use crate::math::{det, mat_vec, orthonormality_error, rot_z, Mat3, Vec3};

/// Which filter a [`Shield`] applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShieldMethod {
    /// The composite barrier's row over the velocity and the rotation `(v, ω)`, each in its
    /// box, and (planar) the [`braking`] check on the tracker model: the command is sent only
    /// if the robot can still brake to a stop with its ellipse free (`"braking"`).
    Braking,
    /// The paper's soft-min composite of per-point ellipsoidal CBFs, filtering the
    /// translation only (`"composite"`).
    Composite,
    /// One spherical distance row `‖p_i − p_r‖ ≥ s_d` per point, one Clarabel QP (`"distance"`).
    Distance,
    /// The ellipsoidal CBF of the nearest point (smallest `h_i`) only (`"hardmin"`).
    HardMin,
    /// No filter: `u* = u_nom`; the composite is still evaluated and reported (`"none"`).
    Unfiltered,
}

impl ShieldMethod {
    /// Every method name, in the order the docs list them.
    pub const NAMES: [&'static str; 5] = ["braking", "composite", "distance", "hardmin", "none"];

    /// Parses `"braking"`, `"composite"`, `"distance"`, `"hardmin"` or `"none"`.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "braking" => Ok(Self::Braking),
            "composite" => Ok(Self::Composite),
            "distance" => Ok(Self::Distance),
            "hardmin" => Ok(Self::HardMin),
            "none" => Ok(Self::Unfiltered),
            other => Err(Error::invalid("method", format!("unknown method {other:?}; expected \"braking\", \"composite\", \"distance\", \"hardmin\" or \"none\""))),
        }
    }

    /// The name [`ShieldMethod::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Self::Braking => "braking",
            Self::Composite => "composite",
            Self::Distance => "distance",
            Self::HardMin => "hardmin",
            Self::Unfiltered => "none",
        }
    }
}

/// Every parameter of the shield. `Default` holds the paper's values (Sec. IV-B): a
/// 0.9 × 0.45 m ellipse, `γ = 0.9`, `κ = 8`, `α(h) = 2h`, points cropped at 3.5 m, and
/// `s_d = 0.8 m` for the distance baseline.
#[derive(Debug, Clone, PartialEq)]
pub struct ShieldConfig {
    /// Semi-axes of the body-frame ellipsoid (m): 2 values planar, 3 values 3D.
    pub semi_axes: Vec<f64>,
    /// Saturation `γ > 0` of `tanh(h/γ)`.
    pub gamma: f64,
    /// Sharpness `κ > 0` of the soft-min.
    pub kappa: f64,
    /// Gain of the linear class-K function `α(h) = α h`, `α > 0`.
    pub alpha: f64,
    /// Symmetric world-frame velocity box `|u_j| ≤ u_max_j` (m/s), one entry per axis. The
    /// braking shield's default is the tracker's `v_max`.
    pub u_max: Option<Vec<f64>>,
    /// Which filter.
    pub method: ShieldMethod,
    /// Safety distance `s_d` (m) of the distance baseline.
    pub safety_distance: f64,
    /// Crop, height band and down-sampling of the scan.
    pub scan: ScanFilter,
    /// Below this gradient norm the barrier counts as flat: an unmet row is infeasible.
    pub grad_eps: f64,
    /// The body's tracker and control period, for the braking shield: its check replays
    /// them, and the tracker's `w_max` boxes the rotation.
    pub braking: BrakingModel,
    /// How much more the braking shield's QP weighs a change of the rotation (rad/s) than
    /// one of the velocity (m/s): `min ‖u − u_nom‖² + w² ‖ω − ω_nom‖²`. Large, it changes the
    /// translation first, as the paper's filter does, and the turn only where the box leaves
    /// no other way.
    pub rotation_weight: f64,
}

impl Default for ShieldConfig {
    fn default() -> Self {
        Self {
            semi_axes: vec![0.9, 0.45],
            gamma: 0.9,
            kappa: 8.0,
            alpha: 2.0,
            u_max: None,
            method: ShieldMethod::Composite,
            safety_distance: 0.8,
            scan: ScanFilter::default(),
            grad_eps: 1e-9,
            braking: BrakingModel::default(),
            rotation_weight: 4.0,
        }
    }
}

fn positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(name, format!("must be finite and > 0, got {v}")))
    }
}

fn finite(name: &'static str, v: &[f64]) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::invalid(name, "contains NaN or inf"))
    }
}

/// The robot's orientation and angular velocity when the scan was taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    rotation: Mat3,
    omega: Vec3,
    planar: bool,
    velocity: Option<Vec3>,
}

/// The largest angular velocity (rad/s) and speed (m/s) a body state may give: far beyond any
/// robot, small enough that `∂H/∂t` and the braking replay stay finite numbers.
pub const MAX_BODY_RATE: f64 = 1.0e4;

/// The error of a point whose barrier is no finite number: the composite kernel's.
fn too_far() -> Error {
    Error::invalid("points", "contains NaN or inf (or a coordinate too large to square)")
}

/// `values` finite and within `±MAX_BODY_RATE`, else an error naming `name`.
fn body_rate(name: &'static str, values: &[f64]) -> Result<()> {
    finite(name, values)?;
    if values.iter().any(|v| v.abs() > MAX_BODY_RATE) {
        return Err(Error::invalid(name, format!("must be within ±{MAX_BODY_RATE} (rad/s or m/s), got {values:?}")));
    }
    Ok(())
}

impl BodyState {
    /// A planar robot at heading `yaw` (rad) turning at `yaw_rate` (rad/s). For the braking
    /// shield `yaw_rate` is the nominal rotation command, which it filters.
    pub fn planar(yaw: f64, yaw_rate: f64) -> Result<Self> {
        finite("yaw", &[yaw])?;
        body_rate("omega", &[yaw_rate])?;
        Ok(Self { rotation: rot_z(yaw), omega: [0.0, 0.0, yaw_rate], planar: true, velocity: None })
    }

    /// The same state with the body's measured velocity `(v_x, v_y, ω)` (body frame, m/s and
    /// rad/s): the tracker state the braking check starts from.
    pub fn with_velocity(self, velocity: Vec3) -> Result<Self> {
        body_rate("velocity", &velocity)?;
        Ok(Self { velocity: Some(velocity), ..self })
    }

    /// The measured body velocity, if given.
    pub fn velocity(&self) -> Option<&Vec3> {
        self.velocity.as_ref()
    }

    /// A robot with body-to-world rotation `rotation` and body-frame angular velocity `omega`.
    pub fn spatial(rotation: Mat3, omega: Vec3) -> Result<Self> {
        finite("rotation", rotation.as_flattened())?;
        body_rate("omega", &omega)?;
        let err = orthonormality_error(&rotation);
        if err > ROTATION_TOLERANCE || det(&rotation) < 0.0 {
            return Err(Error::invalid("rotation", format!("not a proper rotation matrix (|RᵀR − I| = {err:.2e}, det = {:.3})", det(&rotation))));
        }
        Ok(Self { rotation, omega, planar: false, velocity: None })
    }

    /// Body-to-world rotation.
    pub fn rotation(&self) -> &Mat3 {
        &self.rotation
    }

    /// Body-frame angular velocity (rad/s).
    pub fn omega(&self) -> &Vec3 {
        &self.omega
    }
}

/// A borrowed body-frame scan: `N` points stored row-major, 2 or 3 coordinates each.
#[derive(Debug, Clone, Copy)]
pub enum Points<'a> {
    /// Single precision: runs the `f32` kernel.
    F32(&'a [f32]),
    /// Double precision: runs the `f64` kernel.
    F64(&'a [f64]),
}

/// A scan: points, their row stride, and an optional [`Motion`] that moves them into the
/// current body frame before use (for points measured in an earlier frame).
#[derive(Debug, Clone, Copy)]
pub struct Scan<'a> {
    points: Points<'a>,
    stride: usize,
    motion: Option<Motion>,
}

impl<'a> Scan<'a> {
    fn new(points: Points<'a>, stride: usize) -> Result<Self> {
        let len = match points {
            Points::F32(p) => p.len(),
            Points::F64(p) => p.len(),
        };
        if stride != 2 && stride != 3 {
            return Err(Error::invalid("points", format!("expected 2 or 3 columns, got {stride}")));
        }
        if len % stride != 0 {
            return Err(Error::invalid("points", format!("{len} values do not make rows of {stride}")));
        }
        Ok(Self { points, stride, motion: None })
    }

    /// The same points, moved by `motion` before use (crop, band and barrier see the moved
    /// points; the composite applies it inside its kernel, the other methods to a copy).
    pub fn moved(self, motion: Motion) -> Self {
        Self { motion: Some(motion), ..self }
    }

    /// The motion applied before use, if any.
    pub fn motion(&self) -> Option<Motion> {
        self.motion
    }

    /// A scan of `f32` points with `stride` (2 or 3) coordinates each.
    pub fn new_f32(points: &'a [f32], stride: usize) -> Result<Self> {
        Self::new(Points::F32(points), stride)
    }

    /// A scan of `f64` points with `stride` (2 or 3) coordinates each.
    pub fn new_f64(points: &'a [f64], stride: usize) -> Result<Self> {
        Self::new(Points::F64(points), stride)
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        match self.points {
            Points::F32(p) => p.len() / self.stride,
            Points::F64(p) => p.len() / self.stride,
        }
    }

    /// No points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Coordinates per point.
    pub fn stride(&self) -> usize {
        self.stride
    }
}

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
    /// The braking check refused the row's command and every fraction of it the shield
    /// tries (½, ¼, ⅛): it sends the brake (`0`).
    pub braked: bool,
    /// The ellipse already holds a point (`min h_i < 0`): the braking shield sends the
    /// command that raises `H` fastest within the box (the least-violating solution when
    /// the row cannot be met), never a stop, and skips the check.
    pub recovering: bool,
    /// The braking check's value for the row's command: the least `h` against the ellipse
    /// swept until the robot stands (≥ 0 passes); NaN when no check ran.
    pub sweep_h: f64,
}

/// The safety shield: configuration, scratch buffers and the SIMD level of its kernel.
#[derive(Debug, Clone)]
pub struct Shield {
    config: ShieldConfig,
    envelope: Envelope,
    level: SimdLevel,
    scratch: ScanScratch,
    buf32: Vec<f32>,
    buf64: Vec<f64>,
    /// The braking check's replayed path, reused from call to call.
    brake_path: Vec<[f64; 2]>,
    moved32: Vec<f32>,
    moved64: Vec<f64>,
    body: Vec<f64>,
    rows: LinearConstraints,
}

/// The fractions of the row's command the braking shield tries, in turn, before it brakes:
/// near a wall the full command may fail the check while a slower one of the same direction
/// passes (a robot standing by a wall would otherwise brake for ever).
const BRAKING_SCALES: [f64; 4] = [1.0, 0.5, 0.25, 0.125];

/// How far from orthonormal (`max |RᵀR − I|`) a rotation may be: a rotation written to six
/// decimals is off by up to about 3e-6 (1e-6 refused a fifth of them); an error `ε` in `R`
/// moves each `h_i` by about `ε` relative.
pub const ROTATION_TOLERANCE: f64 = 1e-5;

/// Largest soft-min sharpness `κ`: beyond it the weights' products overflow (κ = 1e100 gave a
/// NaN command), and the soft-min equals the hard min to every digit long before.
pub const MAX_KAPPA: f64 = 1e6;
/// Least `κ`: the soft-min's offset `(γ/κ) ln N` grows as `1/κ` (κ = 1e-300 asked for
/// commands of 1e300 m/s).
pub const MIN_KAPPA: f64 = 1e-3;
/// Largest saturation `γ` (m² of `h`): beyond, `γ tanh(h/γ)` is `h` to every digit.
pub const MAX_GAMMA: f64 = 1e6;
/// Least saturation `γ`: below about 1.6e-308 the kernel's `2 log₂e / γ` is infinite (a point
/// on the ellipse gave a NaN command); long before, `tanh(h/γ)` is the sign of `h`.
pub const MIN_GAMMA: f64 = 1e-6;

/// `γ` and `κ` within their bounds ([`MIN_GAMMA`] to [`MAX_GAMMA`], [`MIN_KAPPA`] to
/// [`MAX_KAPPA`]): the one check of [`Shield::new`] and [`composite::CompositeParams::validate`].
pub(crate) fn check_gamma_kappa(gamma: f64, kappa: f64) -> Result<()> {
    if !(MIN_GAMMA..=MAX_GAMMA).contains(&gamma) {
        return Err(Error::invalid("gamma", format!("must be from {MIN_GAMMA:e} to {MAX_GAMMA:e} (below, tanh(h/γ) is the sign of h; above, γ tanh(h/γ) is h itself), got {gamma:e}")));
    }
    if !(MIN_KAPPA..=MAX_KAPPA).contains(&kappa) {
        return Err(Error::invalid("kappa", format!("must be from {MIN_KAPPA:e} to {MAX_KAPPA:e} (beyond, the soft-min is the hard min to every digit), got {kappa:e}")));
    }
    Ok(())
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
        let r = state.rotation;
        let to_world = |g: &Vec3| -> Vec3 {
            let mut w = mat_vec(&r, g);
            if dim == 2 {
                w[2] = 0.0;
            }
            w
        };
        let alpha = self.config.alpha;
        let u_max = self.config.u_max.clone();
        let mut omega_out = state.omega;
        let (mut braked, mut recovering, mut sweep_h) = (false, false, f64::NAN);
        let (value, h_min, grad_p, dh_dt, num_points, sol) = match self.config.method {
            ShieldMethod::Braking => {
                let still = BodyState { omega: [0.0; 3], ..*state };
                let b = self.barrier(scan, &still)?;
                let g = to_world(&b.grad_body);
                // variables (u, ω): the rotation term of ∂H/∂t is linear in ω
                let nw = if dim == 2 { 1 } else { 3 };
                let n = dim + nw;
                let mut x_nom = [0.0; MAX_VARS];
                let mut row = [0.0; MAX_VARS];
                let mut lim = [0.0; MAX_VARS];
                x_nom[..dim].copy_from_slice(u_nom);
                row[..dim].copy_from_slice(&g[..dim]);
                let t = &self.config.braking.tracker;
                match &u_max {
                    Some(m) => lim[..dim].copy_from_slice(m),
                    None => lim[..2].copy_from_slice(&t.v_max),
                }
                // the rotation enters the QP as w·ω, so its distance counts w² times a speed's
                let w = self.config.rotation_weight;
                for k in 0..nw {
                    let axis = if dim == 2 { 2 } else { k };
                    x_nom[dim + k] = w * state.omega[axis];
                    row[dim + k] = b.grad_omega[axis] / w;
                    lim[dim + k] = w * t.w_max;
                }
                let mut sol = self.solve_row_n(&x_nom[..n], &row[..n], -alpha * b.value, &lim[..n], extra)?;
                for k in dim..n {
                    sol.u[k] /= w;
                }
                recovering = b.h_min < 0.0;
                if dim == 2 && !recovering && b.num_points > 0 {
                    let v0 = *state.velocity.as_ref().ok_or_else(|| Error::invalid("velocity", "the braking shield needs the body's measured velocity (v_x, v_y, ω), body frame"))?;
                    let cmd = crate::math::mat_t_vec(&r, &[sol.u[0], sol.u[1], 0.0]);
                    let semi = self.envelope.semi_axes();
                    // the row's command, else the largest of its fractions that passes, else the
                    // brake: the command's check in one pass over the points, its fractions'
                    // together in a second
                    let passes = |h: f64, here: f64| h >= 0.0 || h >= here - braking::WORSE;
                    let model = self.config.braking;
                    let mut path = std::mem::take(&mut self.brake_path);
                    let w_cmd = sol.u[2];
                    let mut sweep = |scale: f64| model.sweep_with(v0, [scale * cmd[0], scale * cmd[1], scale * w_cmd], [semi[0], semi[1]], &mut path);
                    let ([h], here) = self.sweep_least_h(scan, &[sweep(1.0)]);
                    sweep_h = h;
                    let mut passed = passes(h, here).then_some(1.0);
                    if passed.is_none() {
                        let fractions = [sweep(BRAKING_SCALES[1]), sweep(BRAKING_SCALES[2]), sweep(BRAKING_SCALES[3])];
                        let (hs, here) = self.sweep_least_h(scan, &fractions);
                        passed = (0..3).find(|&k| passes(hs[k], here)).map(|k| BRAKING_SCALES[k + 1]);
                    }
                    self.brake_path = path;
                    match passed {
                        Some(1.0) => {}
                        Some(scale) => {
                            sol.u.iter_mut().for_each(|v| *v *= scale);
                            sol.active = true;
                        }
                        None => {
                            braked = true;
                            sol = QpSolution { u: [0.0; MAX_VARS], active: true, feasible: sol.feasible };
                        }
                    }
                }
                let mut u = [0.0; MAX_VARS];
                u[..dim].copy_from_slice(&sol.u[..dim]);
                omega_out = [0.0; 3];
                if dim == 2 {
                    omega_out[2] = sol.u[2];
                } else {
                    omega_out.copy_from_slice(&sol.u[3..6]);
                }
                let dh_dt = (0..3).map(|k| b.grad_omega[k] * omega_out[k]).sum();
                (b.value, b.h_min, g, dh_dt, b.num_points, QpSolution { u, ..sol })
            }
            ShieldMethod::Composite | ShieldMethod::Unfiltered => {
                let b = self.barrier(scan, state)?;
                let g = to_world(&b.grad_body);
                let sol = if self.config.method == ShieldMethod::Unfiltered {
                    let mut u = [0.0; MAX_VARS];
                    u[..dim].copy_from_slice(u_nom);
                    QpSolution { u, active: false, feasible: true }
                } else {
                    self.solve_row(u_nom, &g, -alpha * b.value - b.dh_dt, u_max.as_deref(), extra)?
                };
                (b.value, b.h_min, g, b.dh_dt, b.num_points, sol)
            }
            ShieldMethod::HardMin => {
                let env = self.envelope;
                let pts = self.selected_f64(scan);
                let n = pts.len() / dim;
                let mut nearest: Option<(f64, Vec3)> = None;
                for i in 0..n {
                    let c = &pts[i * dim..(i + 1) * dim];
                    let p = [c[0], c[1], if dim == 3 { c[2] } else { 0.0 }];
                    let h = env.h_body(&p);
                    // (a point 1e154 m away: its h, gradient or ∂h/∂t overflows)
                    if !(h.is_finite() && env.dh_dt_body(&p, &state.omega).is_finite()) {
                        return Err(too_far());
                    }
                    if nearest.is_none_or(|(hn, _)| h < hn) {
                        nearest = Some((h, p));
                    }
                }
                match nearest {
                    None => {
                        let sol = self.solve_row(u_nom, &[0.0; 3], f64::NEG_INFINITY, u_max.as_deref(), extra)?;
                        (f64::MAX, f64::MAX, [0.0; 3], 0.0, 0, sol)
                    }
                    Some((h, p)) => {
                        let g = to_world(&env.grad_body(&p));
                        let dt = env.dh_dt_body(&p, &state.omega);
                        let sol = self.solve_row(u_nom, &g, -alpha * h - dt, u_max.as_deref(), extra)?;
                        (h, h, g, dt, n, sol)
                    }
                }
            }
            ShieldMethod::Distance => {
                let pts = self.selected_f64(scan).to_vec();
                let n = pts.len() / dim;
                let sd2 = self.config.safety_distance * self.config.safety_distance;
                self.rows.clear();
                let (mut h_min, mut g_near, mut stuck) = (f64::MAX, [0.0; 3], false);
                for i in 0..n {
                    let p = &pts[i * dim..(i + 1) * dim];
                    let d = to_world(&[p[0], p[1], if dim == 3 { p[2] } else { 0.0 }]);
                    let h = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - sd2;
                    if !h.is_finite() {
                        return Err(too_far());
                    }
                    let g = [-2.0 * d[0], -2.0 * d[1], -2.0 * d[2]];
                    self.rows.push(&g[..dim], -alpha * h)?;
                    // a violated row no direction helps (a point at the robot's centre)
                    stuck |= -alpha * h > 0.0 && (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt() <= self.config.grad_eps;
                    if h < h_min {
                        (h_min, g_near) = (h, g);
                    }
                }
                if let Some(e) = extra {
                    self.rows.extend(e)?;
                }
                // stop, as the composite does with a vanishing gradient (see `qp`)
                let sol = if stuck { QpSolution { u: [0.0; MAX_VARS], active: true, feasible: false } } else { solve_rows(u_nom, &self.rows, u_max.as_deref())? };
                (h_min, h_min, g_near, 0.0, n, sol)
            }
        };
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
        let out = Scan::new_f64(&body, stride).and_then(|s| self.filter_with(&s, state, u_nom, extra));
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
    fn on_moved_copy<R>(&mut self, scan: &Scan, f: impl FnOnce(&mut Self, &Scan) -> Result<R>) -> Result<R> {
        let Some(m) = scan.motion else { return f(self, scan) };
        if !m.is_finite() {
            return Err(Error::invalid("motion", "contains NaN or inf"));
        }
        let (mut b32, mut b64) = (std::mem::take(&mut self.moved32), std::mem::take(&mut self.moved64));
        let moved = match scan.points {
            Points::F32(p) => {
                move_points(p, scan.stride, &m, &mut b32);
                Scan::new_f32(&b32, scan.stride)
            }
            Points::F64(p) => {
                move_points(p, scan.stride, &m, &mut b64);
                Scan::new_f64(&b64, scan.stride)
            }
        };
        let out = moved.and_then(|moved| f(self, &moved));
        (self.moved32, self.moved64) = (b32, b64);
        out
    }

    /// The points a baseline uses, as `f64` rows of `dim` (checked finite by the caller).
    fn selected_f64(&mut self, scan: &Scan) -> &[f64] {
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

    /// The braking check's least `h` over the points the composite used.
    fn sweep_least_h<const K: usize>(&self, scan: &Scan, sweeps: &[Sweep; K]) -> ([f64; K], f64) {
        if self.config.scan.downsamples() {
            // the down-sampled points (already moved, cropped and banded), as the barrier took them
            return match scan.points {
                Points::F32(_) => braking::least_h_of(sweeps, &self.buf32, self.dim(), None, f64::INFINITY, None, self.level),
                Points::F64(_) => braking::least_h_of(sweeps, &self.buf64, self.dim(), None, f64::INFINITY, None, self.level),
            };
        }
        let crop = self.config.scan.crop_radius.unwrap_or(f64::INFINITY);
        let band = if scan.stride == 3 { self.config.scan.height_band } else { None };
        match scan.points {
            Points::F32(p) => braking::least_h_of(sweeps, p, scan.stride, scan.motion, crop, band, self.level),
            Points::F64(p) => braking::least_h_of(sweeps, p, scan.stride, scan.motion, crop, band, self.level),
        }
    }

    /// [`qp::project_checked`] over `n` variables with the box `lim`, or Clarabel with the
    /// user's rows (over the translation; zero on the rotation).
    fn solve_row_n(&mut self, x_nom: &[f64], row: &[f64], b: f64, lim: &[f64], extra: Option<&LinearConstraints>) -> Result<QpSolution> {
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

    fn solve_row(&mut self, u_nom: &[f64], g: &Vec3, b: f64, u_max: Option<&[f64]>, extra: Option<&LinearConstraints>) -> Result<QpSolution> {
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

    fn check_inputs(&self, scan: &Scan, state: &BodyState, u_nom: &[f64], extra: Option<&LinearConstraints>) -> Result<()> {
        let dim = self.dim();
        if u_nom.len() != dim {
            return Err(Error::DimensionMismatch { name: "u_nom", expected: dim, got: u_nom.len() });
        }
        finite("u_nom", u_nom)?;
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
        if self.config.method != ShieldMethod::Composite && self.config.method != ShieldMethod::Unfiltered {
            check_finite(scan)?;
        }
        Ok(())
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

fn check_finite(scan: &Scan) -> Result<()> {
    let ok = match scan.points {
        Points::F32(p) => p.iter().all(|v| v.is_finite()),
        Points::F64(p) => p.iter().all(|v| v.is_finite()),
    };
    if ok {
        Ok(())
    } else {
        Err(Error::invalid("points", "contains NaN or inf"))
    }
}
