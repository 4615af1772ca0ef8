//! `Shield` and `ShieldOutcome`.

use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shieldnav_core::math::{rot_z, Mat3};
use shieldnav_core::robot::TrackerConfig;
use shieldnav_core::sensors::Mover;
use shieldnav_core::shield::{BodyState, BrakingModel, Footprint, LinearConstraints, Scan, ScanFilter, Shield, ShieldConfig, ShieldMethod};

use crate::errors::{invalid, to_py};
use crate::outcome::PyShieldOutcome;

/// Scans with at least this many points release the GIL while the core runs.
const DETACH_POINTS: usize = 4096;

/// A float vector from a 1-D numpy array or any sequence of numbers.
pub(crate) fn vector(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    if let Ok(a) = obj.extract::<PyReadonlyArray1<f64>>() {
        return Ok(a.as_array().to_vec());
    }
    obj.extract::<Vec<f64>>().map_err(|_| invalid(name, "expected a 1-D sequence of numbers"))
}

/// Either a borrowed float32 or float64 `(N, 2|3)` C-contiguous array.
enum PointsArg<'py> {
    F32(PyReadonlyArray2<'py, f32>),
    F64(PyReadonlyArray2<'py, f64>),
}

impl<'py> PointsArg<'py> {
    fn extract(obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        let Ok(arr) = obj.cast::<PyUntypedArray>() else {
            return Err(invalid("points", format!("expected a numpy array of shape (N, 2) or (N, 3), got {}", obj.get_type().name()?)));
        };
        if arr.ndim() != 2 || !(arr.shape()[1] == 2 || arr.shape()[1] == 3) {
            return Err(invalid("points", format!("expected shape (N, 2) or (N, 3), got {:?}", arr.shape())));
        }
        if !arr.is_c_contiguous() {
            return Err(invalid("points", "must be C-contiguous (use np.ascontiguousarray)"));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray2<f32>>() {
            return Ok(Self::F32(a));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray2<f64>>() {
            return Ok(Self::F64(a));
        }
        Err(invalid("points", format!("dtype must be float32 or float64, got {}", arr.dtype())))
    }

    fn scan(&self) -> PyResult<Scan<'_>> {
        let r = match self {
            Self::F32(a) => Scan::new_f32(a.as_slice().map_err(|e| invalid("points", e))?, a.shape()[1]),
            Self::F64(a) => Scan::new_f64(a.as_slice().map_err(|e| invalid("points", e))?, a.shape()[1]),
        };
        r.map_err(to_py)
    }
}

/// Shield(semi_axes=(0.9, 0.45), gamma=0.9, kappa=8.0, alpha=2.0, crop_radius=3.5, u_max=None,
///        method="composite", safety_distance=0.8, height_band=(-0.4, 1.5), voxel_size=None,
///        angular_bins=None, grad_eps=1e-9, tracker_tau=0.15, a_max=(2.0, 2.0), w_max=1.5,
///        yaw_accel_max=4.0, dt=0.02, brake_margin=0.01, rotation_weight=4.0, footprint=None,
///        lidar_noise_std=0.01, tight_speed=0.5, mover_accel=0.25)
///
/// The composite control-barrier-function safety shield (paper Sec. III) and its baselines.
///
/// `filter(points, u_nom, yaw=0.0, omega=0.0)` (planar) or
/// `filter(points, u_nom, rotation=R, omega=w)` (3D) returns the world-frame command
/// u* = argmin |u - u_nom|^2 s.t. dH/dp . u >= -alpha H - dH/dt, |u| <= u_max.
///
/// `method="braking"` filters the rotation too: (u, omega) nearest (u_nom, omega) with
/// dH/dp . u + dH/domega . omega >= -alpha H, |u| <= u_max, |omega| <= w_max; a planar one
/// then checks that after one period `dt` of that command the robot, whose velocity follows
/// a lag `tracker_tau` with acceleration limits `a_max`, `yaw_accel_max`, can still brake to
/// a stop with its footprint at least brake_margin + 3 lidar_noise_std from every point. It
/// sends the largest safe fraction of that command, or, where the row stalls (the ellipse
/// does not fit where the body does), of the nominal command at most `tight_speed`, or the
/// brake. With a point already nearer than that clearance, only commands that bring no point
/// nearer pass. It needs `velocity=(vx, vy, omega)`, the body's measured velocity, at every call.
///
/// Arguments:
///     semi_axes: body-frame ellipsoid semi-axes (m); 2 values planar, 3 values 3D.
///     gamma, kappa: saturation and sharpness of the soft-min composite (> 0).
///     alpha: gain of alpha(h) = alpha * h (> 0).
///     crop_radius: drop points farther than this (m); None keeps all.
///     u_max: symmetric world-frame velocity box (m/s), one entry per axis; None for no box.
///     method: "composite" (the paper's filter), "braking" (rotation filtered, braking
///         checked), "distance" (one 0.8 m sphere row per point, Clarabel), "hardmin"
///         (nearest point only) or "none" (no filter, H still reported).
///     safety_distance: s_d of the distance baseline (m).
///     height_band: (z_lo, z_hi) body-frame band kept when a planar shield gets (N, 3) points.
///     voxel_size, angular_bins: optional down-sampling; each keeps the point with the
///         smallest h per cell. The composite turns conservative like ln(N)/kappa.
///     grad_eps: below this gradient norm an unmet row counts as infeasible (stop).
///     tracker_tau, a_max, w_max, yaw_accel_max, dt: the robot's velocity tracker (lag in s, acceleration
///         limits in m/s^2, yaw-rate limit in rad/s, yaw acceleration limit in rad/s^2) and
///         control period (s), for method "braking"; its speed limit is u_max (default
///         (1.6, 0.8)).
///     brake_margin: clearance (m) the braking check keeps between the footprint and every
///         point beyond three standard deviations of the range noise (gaps between beams).
///     footprint: the body's outline for the braking check: (length, width) of a centred
///         rectangle, or a convex polygon [[x, y], ...] (m, body frame, Nav2's `footprint`
///         convention) holding the origin; None: 1.1 x 0.5 m.
///     lidar_noise_std: the range noise's standard deviation (m): the check keeps 3 of them.
///     mover_accel: acceleration (m/s²) up to which a moving object may leave its estimated
///         velocity: its predicted disc grows by a t²/2 (see `filter(movers=...)`).
///     tight_speed: speed (m/s) up to which the braking shield follows the nominal command
///         where the ellipse row stalls but the footprint passes; 0 keeps the row's command.
///     rotation_weight: w in min |u - u_nom|^2 + w^2 |omega - omega_nom|^2 (method
///         "braking"): large, the filter changes the translation first.
///
/// Points are float32 or float64 (N, 2) / (N, 3) C-contiguous arrays in the body frame, read
/// without a copy. Bad input raises shieldnav.InvalidArgumentError (a ValueError).
#[pyclass(name = "Shield", module = "shieldnav._core")]
pub struct PyShield {
    inner: Shield,
}

#[pymethods]
impl PyShield {
    #[new]
    #[pyo3(signature = (
        semi_axes = ShieldConfig::default().semi_axes,
        gamma = ShieldConfig::default().gamma,
        kappa = ShieldConfig::default().kappa,
        alpha = ShieldConfig::default().alpha,
        crop_radius = ShieldConfig::default().scan.crop_radius,
        u_max = ShieldConfig::default().u_max,
        method = ShieldConfig::default().method.name().to_string(),
        safety_distance = ShieldConfig::default().safety_distance,
        height_band = ShieldConfig::default().scan.height_band,
        voxel_size = ShieldConfig::default().scan.voxel_size,
        angular_bins = ShieldConfig::default().scan.angular_bins,
        grad_eps = ShieldConfig::default().grad_eps,
        tracker_tau = TrackerConfig::default().tau,
        a_max = TrackerConfig::default().a_max,
        w_max = TrackerConfig::default().w_max,
        yaw_accel_max = TrackerConfig::default().alpha_max,
        dt = BrakingModel::default().dt,
        brake_margin = BrakingModel::default().brake_margin,
        rotation_weight = ShieldConfig::default().rotation_weight,
        footprint = None,
        lidar_noise_std = BrakingModel::default().lidar_noise_std,
        tight_speed = ShieldConfig::default().tight_speed,
        mover_accel = ShieldConfig::default().mover_accel,
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        #[pyo3(from_py_with = crate::errors::shield_args::semi_axes)] semi_axes: Vec<f64>,
        #[pyo3(from_py_with = crate::errors::shield_args::gamma)] gamma: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::kappa)] kappa: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::alpha)] alpha: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::crop_radius)] crop_radius: Option<f64>,
        #[pyo3(from_py_with = crate::errors::shield_args::u_max)] u_max: Option<Vec<f64>>,
        #[pyo3(from_py_with = method_arg)] method: String,
        #[pyo3(from_py_with = crate::errors::shield_args::safety_distance)] safety_distance: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::height_band)] height_band: Option<(f64, f64)>,
        #[pyo3(from_py_with = crate::errors::shield_args::voxel_size)] voxel_size: Option<f64>,
        #[pyo3(from_py_with = crate::errors::shield_args::angular_bins)] angular_bins: Option<usize>,
        #[pyo3(from_py_with = crate::errors::shield_args::grad_eps)] grad_eps: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::tracker_tau)] tracker_tau: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::a_max)] a_max: [f64; 2],
        #[pyo3(from_py_with = crate::errors::shield_args::w_max)] w_max: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::yaw_accel_max)] yaw_accel_max: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::dt)] dt: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::brake_margin)] brake_margin: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::rotation_weight)] rotation_weight: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::footprint)] footprint: Option<Footprint>,
        #[pyo3(from_py_with = crate::errors::shield_args::lidar_noise_std)] lidar_noise_std: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::tight_speed)] tight_speed: f64,
        #[pyo3(from_py_with = crate::errors::shield_args::mover_accel)] mover_accel: f64,
    ) -> PyResult<Self> {
        let mut tracker = TrackerConfig { tau: tracker_tau, a_max, w_max, alpha_max: yaw_accel_max, ..TrackerConfig::default() };
        if let Some(m) = u_max.as_deref().filter(|m| m.len() == 2) {
            // the braking model's speed limit is the box
            tracker.v_max = [m[0], m[1]];
        }
        let config = ShieldConfig {
            semi_axes,
            gamma,
            kappa,
            alpha,
            u_max,
            method: ShieldMethod::parse(&method).map_err(to_py)?,
            safety_distance,
            scan: ScanFilter { crop_radius, height_band, voxel_size, angular_bins },
            grad_eps,
            braking: BrakingModel { tracker, dt, brake_margin, lidar_noise_std, footprint: footprint.unwrap_or_default() },
            rotation_weight,
            tight_speed,
            mover_accel,
        };
        Ok(Self { inner: Shield::new(config).map_err(to_py)? })
    }

    /// filter(points, u_nom, yaw=None, omega=None, rotation=None, extra_A=None, extra_b=None,
    ///        velocity=None)
    ///
    /// The safe command nearest `u_nom` (world frame) against a body-frame scan: `points`
    /// float32 or float64 (N, 2) or (N, 3), C-contiguous, read without a copy. A planar shield
    /// takes `yaw` (rad) and the yaw rate `omega` (rad/s); a 3D one `rotation` (3x3,
    /// body-to-world) or `yaw`, and `omega` as the body angular velocity (3 values).
    /// `extra_A @ u >= extra_b` adds rows, solved with the barrier's by Clarabel. For
    /// method "braking", `omega` is the nominal rotation command it filters and `velocity`
    /// the body's measured (vx, vy, omega), body frame. Returns a `ShieldOutcome` (u, omega,
    /// H, h_min, grad_p, dH_dt, num_points, active, feasible, braked, recovering, sweep_h, tight, clearance,
    /// solve_time_ns); bad input raises `InvalidArgumentError` naming the argument.
    /// `movers` (K, 5) or (K, 6) rows `x, y, vx, vy, radius[, velocity_std]` (body frame, m
    /// and m/s; the velocity over the ground in the body's axes) are moving objects: the
    /// braking shield keeps the robot at rest before any reaches it and steps out of the way
    /// of one coming at it; both rows take their motion into dH/dt (planar shields).
    #[pyo3(signature = (points, u_nom, yaw = None, omega = None, rotation = None, extra_A = None, extra_b = None, velocity = None, movers = None))]
    #[allow(non_snake_case, clippy::too_many_arguments)]
    fn filter(
        &mut self,
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        u_nom: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::errors::shield_args::yaw)] yaw: Option<f64>,
        omega: Option<&Bound<'_, PyAny>>,
        rotation: Option<&Bound<'_, PyAny>>,
        extra_A: Option<&Bound<'_, PyAny>>,
        extra_b: Option<&Bound<'_, PyAny>>,
        velocity: Option<&Bound<'_, PyAny>>,
        movers: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyShieldOutcome> {
        self.run(py, points, u_nom, None, yaw, omega, rotation, extra_A, extra_b, velocity, movers)
    }

    /// Like `filter`, for world-frame points and the robot at `position`: (x, y) or
    /// (x, y, z) for a planar shield (the height band of (N, 3) points applies to their
    /// height above z, 0 if not given), (x, y, z) for a 3D one.
    #[pyo3(signature = (points, u_nom, position, yaw = None, omega = None, rotation = None, extra_A = None, extra_b = None, velocity = None, movers = None))]
    #[allow(non_snake_case, clippy::too_many_arguments)]
    fn filter_world(
        &mut self,
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        u_nom: &Bound<'_, PyAny>,
        position: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::errors::shield_args::yaw)] yaw: Option<f64>,
        omega: Option<&Bound<'_, PyAny>>,
        rotation: Option<&Bound<'_, PyAny>>,
        extra_A: Option<&Bound<'_, PyAny>>,
        extra_b: Option<&Bound<'_, PyAny>>,
        velocity: Option<&Bound<'_, PyAny>>,
        movers: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyShieldOutcome> {
        self.run(py, points, u_nom, Some(position), yaw, omega, rotation, extra_A, extra_b, velocity, movers)
    }

    /// Forgets the escape the braking shield is running (it keeps one from call to call while
    /// a mover comes at the robot): call it when the robot's run starts anew.
    fn reset(&mut self) {
        self.inner.reset();
    }

    /// The configuration as a dict of the constructor's keyword arguments.
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        config_dict(py, self.inner.config())
    }

    /// 2 for a planar shield, 3 for 3D.
    #[getter]
    fn dim(&self) -> usize {
        self.inner.dim()
    }

    /// The method name.
    #[getter]
    fn method(&self) -> &'static str {
        self.inner.config().method.name()
    }

    /// The SIMD level of the composite kernel on this CPU.
    #[getter]
    fn simd_level(&self) -> String {
        format!("{:?}", self.inner.simd_level()).to_lowercase()
    }

    fn __repr__(&self) -> String {
        let c = self.inner.config();
        format!("Shield(semi_axes={:?}, gamma={}, kappa={}, alpha={}, crop_radius={:?}, u_max={:?}, method={:?})", c.semi_axes, c.gamma, c.kappa, c.alpha, c.scan.crop_radius, c.u_max, c.method.name())
    }
}

/// `movers`: None, or a (K, 5) / (K, 6) array of `x, y, vx, vy, radius[, velocity_std]`.
fn movers_arg(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<Mover>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else { return Ok(Vec::new()) };
    let a: PyReadonlyArray2<'_, f64> = obj.extract().map_err(|_| invalid("movers", "expected a float64 (K, 5) or (K, 6) array: x, y, vx, vy, radius[, velocity_std]"))?;
    let a = a.as_array();
    if a.ncols() != 5 && a.ncols() != 6 {
        return Err(invalid("movers", format!("expected 5 or 6 columns (x, y, vx, vy, radius[, velocity_std]), got {}", a.ncols())));
    }
    Ok(a.rows().into_iter().map(|r| Mover { centre: [r[0], r[1]], velocity: [r[2], r[3]], radius: r[4], velocity_std: if r.len() == 6 { r[5] } else { 0.0 } }).collect())
}

/// `method`, a string, else an `InvalidArgumentError` naming it.
fn method_arg(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    obj.extract::<String>().map_err(|_| invalid("method", format!("expected a method name (str), got {}", obj.repr().map(|r| r.to_string()).unwrap_or_default())))
}

impl PyShield {
    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        u_nom: &Bound<'_, PyAny>,
        position: Option<&Bound<'_, PyAny>>,
        yaw: Option<f64>,
        omega: Option<&Bound<'_, PyAny>>,
        rotation: Option<&Bound<'_, PyAny>>,
        extra_a: Option<&Bound<'_, PyAny>>,
        extra_b: Option<&Bound<'_, PyAny>>,
        velocity: Option<&Bound<'_, PyAny>>,
        movers: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyShieldOutcome> {
        let dim = self.inner.dim();
        let pts = PointsArg::extract(points)?;
        let movers = movers_arg(movers)?;
        let scan = pts.scan()?.with_movers(&movers);
        let u = vector("u_nom", u_nom)?;
        let mut state = body_state(dim, yaw, omega, rotation)?;
        if let Some(v) = velocity {
            let v = vector("velocity", v)?;
            if dim != 2 || v.len() != 3 {
                return Err(invalid("velocity", format!("the braking check takes a planar body's (vx, vy, omega), 3 values, on a planar shield; got {} values on a {dim}-D shield", v.len())));
            }
            state = state.with_velocity([v[0], v[1], v[2]]).map_err(to_py)?;
        }
        let extra = extra_rows(dim, extra_a, extra_b)?;
        let position = match position {
            Some(p) => {
                // (a planar shield's position may carry the robot's height: the height band
                // of (N, 3) world points is taken relative to it)
                let v = vector("position", p)?;
                if !(v.len() == dim || dim == 2 && v.len() == 3) {
                    return Err(invalid("position", format!("expected {}, got {} values", if dim == 2 { "2 values (x, y) or 3 (x, y, z)" } else { "3 values" }, v.len())));
                }
                let mut a = [0.0; 3];
                a[..v.len()].copy_from_slice(&v);
                Some(a)
            }
            None => None,
        };
        let heavy = scan.len() >= DETACH_POINTS || extra.is_some() || self.inner.config().method == ShieldMethod::Distance;
        let shield = &mut self.inner;
        let mut call = || match &position {
            None => shield.filter_with(&scan, &state, &u, extra.as_ref()),
            Some(p) => shield.filter_world(&scan, p, &state, &u, extra.as_ref()),
        };
        let out = if heavy { py.detach(call) } else { call() };
        Ok(PyShieldOutcome { inner: out.map_err(to_py)? })
    }
}

fn body_state(dim: usize, yaw: Option<f64>, omega: Option<&Bound<'_, PyAny>>, rotation: Option<&Bound<'_, PyAny>>) -> PyResult<BodyState> {
    if dim == 2 {
        if rotation.is_some() {
            return Err(invalid("rotation", "a planar shield takes `yaw` (rad), not a 3x3 rotation"));
        }
        let w = match omega {
            None => 0.0,
            Some(o) => o.extract::<f64>().map_err(|_| invalid("omega", "a planar shield takes a scalar yaw rate (rad/s)"))?,
        };
        return BodyState::planar(yaw.unwrap_or(0.0), w).map_err(to_py);
    }
    let r: Mat3 = match (rotation, yaw) {
        (Some(_), Some(_)) => return Err(invalid("rotation", "give either `rotation` or `yaw`, not both")),
        (Some(r), None) => rotation_arg(r)?,
        (None, y) => rot_z(y.unwrap_or(0.0)),
    };
    let w = match omega {
        None => [0.0; 3],
        Some(o) => {
            let v = vector("omega", o)?;
            if v.len() != 3 {
                return Err(invalid("omega", format!("a 3D shield takes the body angular velocity (3 values), got {}", v.len())));
            }
            [v[0], v[1], v[2]]
        }
    };
    BodyState::spatial(r, w).map_err(to_py)
}

/// A 3 × 3 rotation from a float64 or float32 array or nested sequences of numbers.
fn rotation_arg(r: &Bound<'_, PyAny>) -> PyResult<Mat3> {
    let rows: Vec<Vec<f64>> = if let Ok(m) = r.extract::<PyReadonlyArray2<f64>>() {
        m.as_array().rows().into_iter().map(|row| row.to_vec()).collect()
    } else if let Ok(m) = r.extract::<PyReadonlyArray2<f32>>() {
        m.as_array().rows().into_iter().map(|row| row.iter().map(|&v| v as f64).collect()).collect()
    } else {
        r.extract().map_err(|_| invalid("rotation", format!("expected a 3x3 array of numbers (float64 or float32), got {}", r.get_type().name().map(|n| n.to_string()).unwrap_or_default())))?
    };
    let shape = (rows.len(), rows.first().map_or(0, Vec::len));
    if shape != (3, 3) || rows.iter().any(|row| row.len() != 3) {
        return Err(invalid("rotation", format!("expected shape (3, 3), got {} rows of {:?} values", rows.len(), rows.iter().map(Vec::len).collect::<Vec<_>>())));
    }
    Ok([[rows[0][0], rows[0][1], rows[0][2]], [rows[1][0], rows[1][1], rows[1][2]], [rows[2][0], rows[2][1], rows[2][2]]])
}

fn extra_rows(dim: usize, a: Option<&Bound<'_, PyAny>>, b: Option<&Bound<'_, PyAny>>) -> PyResult<Option<LinearConstraints>> {
    match (a, b) {
        (None, None) => Ok(None),
        (Some(_), None) | (None, Some(_)) => Err(invalid("extra_A", "give extra_A and extra_b together")),
        (Some(a), Some(b)) => {
            let m = a.extract::<PyReadonlyArray2<f64>>().map_err(|_| invalid("extra_A", "expected a 2-D float64 array (M, dim)"))?;
            let shape = m.as_array().shape().to_vec();
            if shape[1] != dim {
                return Err(invalid("extra_A", format!("expected {dim} columns, got shape {shape:?}")));
            }
            let rows: Vec<f64> = m.as_array().iter().copied().collect();
            let rhs = vector("extra_b", b)?;
            LinearConstraints::from_rows(dim, &rows, &rhs).map(Some).map_err(to_py)
        }
    }
}

fn config_dict<'py>(py: Python<'py>, c: &ShieldConfig) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("semi_axes", c.semi_axes.clone())?;
    d.set_item("gamma", c.gamma)?;
    d.set_item("kappa", c.kappa)?;
    d.set_item("alpha", c.alpha)?;
    d.set_item("crop_radius", c.scan.crop_radius)?;
    d.set_item("u_max", c.u_max.clone())?;
    d.set_item("method", c.method.name())?;
    d.set_item("safety_distance", c.safety_distance)?;
    d.set_item("height_band", c.scan.height_band)?;
    d.set_item("voxel_size", c.scan.voxel_size)?;
    d.set_item("angular_bins", c.scan.angular_bins)?;
    d.set_item("grad_eps", c.grad_eps)?;
    d.set_item("tracker_tau", c.braking.tracker.tau)?;
    d.set_item("a_max", c.braking.tracker.a_max.to_vec())?;
    d.set_item("w_max", c.braking.tracker.w_max)?;
    d.set_item("yaw_accel_max", c.braking.tracker.alpha_max)?;
    d.set_item("dt", c.braking.dt)?;
    d.set_item("brake_margin", c.braking.brake_margin)?;
    d.set_item("rotation_weight", c.rotation_weight)?;
    d.set_item("footprint", c.braking.footprint.vertices().iter().map(|v| v.to_vec()).collect::<Vec<_>>())?;
    d.set_item("lidar_noise_std", c.braking.lidar_noise_std)?;
    d.set_item("tight_speed", c.tight_speed)?;
    d.set_item("mover_accel", c.mover_accel)?;
    Ok(d)
}

/// The paper's defaults, as the keyword arguments of `Shield(...)`.
#[pyfunction]
fn shield_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    config_dict(py, &ShieldConfig::default())
}

/// Adds the shield classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyShield>()?;
    m.add_class::<PyShieldOutcome>()?;
    m.add_function(wrap_pyfunction!(shield_defaults, m)?)?;
    Ok(())
}
