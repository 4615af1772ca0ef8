//! `ViewPlanner` and `NominalController`.

use numpy::{PyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use shieldnav_core::control::{NominalController, NominalControllerConfig};
use shieldnav_core::planner::{ViewPlanner, ViewPlannerConfig, ViewPose};

use crate::errors::{invalid, to_py};

fn points_arg<'py>(obj: &Bound<'py, PyAny>) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let a = obj.extract::<PyReadonlyArray2<f64>>().map_err(|_| invalid("points", "expected a float64 array of shape (N, 2) or (N, 3)"))?;
    let cols = a.shape()[1];
    if cols != 2 && cols != 3 {
        return Err(invalid("points", format!("expected 2 or 3 columns, got {cols}")));
    }
    Ok(a)
}

/// A 2-vector from a tuple, a list or a length-2 array (the planner's `p_d` goes straight
/// into the controller).
fn pair(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<[f64; 2]> {
    match crate::shield::vector(name, obj)?.as_slice() {
        &[x, y] => Ok([x, y]),
        v => Err(invalid(name, format!("expected 2 numbers (x, y), got {}", v.len()))),
    }
}

type Pose<'py> = (Bound<'py, PyArray1<f64>>, f64);

fn pose_out<'py>(py: Python<'py>, v: ViewPose, planar: bool) -> Pose<'py> {
    (PyArray1::from_slice(py, &v.position[..if planar { 2 } else { 3 }]), v.yaw)
}

/// ViewPlanner(d_view=1.5, gamma_h=0.5, fov_h_deg=69.4, fov_v_deg=45.0, gamma_v=1.0,
///             horizon=5, reach_threshold=0.3, planar=True)
///
/// The reactive inspection planner of the paper (Sec. IV-A, Eq. flip), on the estimated pose.
/// Methods take body-frame points (float64, (N, 2) or (N, 3)), the estimated position and
/// yaw, and return (p_d, psi), or None without points.
///
/// planar=True (a ground robot, as the paper's quadruped experiments): the nearest point in
/// the horizontal plane, position (x, y), p_d a length-2 array; gamma_v must be 1 (the
/// vertical term would move only a height). planar=False: Eq. (flip) in space, the nearest
/// point in 3D, position (x, y, z), p_d a length-3 array.
#[pyclass(name = "ViewPlanner", module = "shieldnav._core")]
pub struct PyViewPlanner {
    inner: ViewPlanner,
}

impl PyViewPlanner {
    fn call<'py, T>(
        &mut self,
        points: &Bound<'py, PyAny>,
        position: &Bound<'py, PyAny>,
        yaw: f64,
        f: impl FnOnce(&mut ViewPlanner, &[f64], usize, &[f64; 3], f64) -> shieldnav_core::Result<T>,
    ) -> PyResult<T> {
        let a = points_arg(points)?;
        let stride = a.shape()[1];
        // (a Fortran-ordered array is contiguous too, but its rows are not runs of memory)
        if !a.is_c_contiguous() {
            return Err(invalid("points", "must be C-contiguous (np.ascontiguousarray)"));
        }
        let slice = a.as_slice().map_err(|_| invalid("points", "must be C-contiguous (np.ascontiguousarray)"))?;
        let at = if self.inner.config().planar {
            let [x, y] = pair("position", position)?;
            [x, y, 0.0]
        } else {
            match crate::shield::vector("position", position)?.as_slice() {
                &[x, y, z] => [x, y, z],
                v => return Err(invalid("position", format!("expected 3 numbers (x, y, z) for a planner in space (planar=False), got {}", v.len()))),
            }
        };
        f(&mut self.inner, slice, stride, &at, yaw).map_err(to_py)
    }
}

#[pymethods]
impl PyViewPlanner {
    #[new]
    #[pyo3(signature = (
        d_view = ViewPlannerConfig::default().d_view,
        gamma_h = ViewPlannerConfig::default().gamma_h,
        fov_h_deg = ViewPlannerConfig::default().fov_h.to_degrees(),
        fov_v_deg = ViewPlannerConfig::default().fov_v.to_degrees(),
        gamma_v = ViewPlannerConfig::default().gamma_v,
        horizon = ViewPlannerConfig::default().horizon,
        reach_threshold = ViewPlannerConfig::default().reach_threshold,
        planar = ViewPlannerConfig::default().planar,
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(d_view: f64, gamma_h: f64, fov_h_deg: f64, fov_v_deg: f64, gamma_v: f64, horizon: usize, reach_threshold: f64, planar: bool) -> PyResult<Self> {
        for (name, v) in [("fov_h_deg", fov_h_deg), ("fov_v_deg", fov_v_deg)] {
            if !(v > 0.0 && v < 180.0) {
                return Err(invalid(name, format!("must be in (0, 180) degrees, got {v}")));
            }
        }
        let config = ViewPlannerConfig { d_view, gamma_h, gamma_v, fov_h: fov_h_deg.to_radians(), fov_v: fov_v_deg.to_radians(), horizon, reach_threshold, planar };
        Ok(Self { inner: ViewPlanner::new(config).map_err(to_py)? })
    }

    /// One step of Eq. (flip) from the estimated pose.
    fn plan<'py>(&mut self, py: Python<'py>, points: &Bound<'py, PyAny>, position: &Bound<'py, PyAny>, yaw: f64) -> PyResult<Option<Pose<'py>>> {
        let planar = self.inner.config().planar;
        Ok(self.call(points, position, yaw, |p, s, n, x, y| p.plan(s, n, x, y))?.map(|v| pose_out(py, v, planar)))
    }

    /// The held reference, replanned once the estimate is within reach_threshold of it.
    fn update<'py>(&mut self, py: Python<'py>, points: &Bound<'py, PyAny>, position: &Bound<'py, PyAny>, yaw: f64) -> PyResult<Option<Pose<'py>>> {
        let planar = self.inner.config().planar;
        Ok(self.call(points, position, yaw, |p, s, n, x, y| p.update(s, n, x, y))?.map(|v| pose_out(py, v, planar)))
    }

    /// The predicted inspection path over the horizon: a list of (p_d, psi).
    fn predict_path<'py>(&mut self, py: Python<'py>, points: &Bound<'py, PyAny>, position: &Bound<'py, PyAny>, yaw: f64) -> PyResult<Vec<Pose<'py>>> {
        let planar = self.inner.config().planar;
        Ok(self.call(points, position, yaw, |p, s, n, x, y| p.predict_path(s, n, x, y))?.into_iter().map(|v| pose_out(py, v, planar)).collect())
    }

    /// Forgets the held reference.
    fn reset(&mut self) {
        self.inner.reset();
    }
}

/// NominalController(kp=4.0, k_yaw=2.0, u_max=(1.0, 1.0), omega_max=1.0)
///
/// u_nom = K_p (p_d - p_hat) scaled into the speed limits (direction kept), and a yaw rate
/// toward psi_d. `command(goal, goal_yaw, position, yaw) -> (u_nom, yaw_rate)`.
#[pyclass(name = "NominalController", module = "shieldnav._core", frozen)]
pub struct PyNominalController {
    inner: NominalController,
}

#[pymethods]
impl PyNominalController {
    #[new]
    #[pyo3(signature = (
        kp = NominalControllerConfig::default().kp,
        k_yaw = NominalControllerConfig::default().k_yaw,
        u_max = (NominalControllerConfig::default().u_max[0], NominalControllerConfig::default().u_max[1]),
        omega_max = NominalControllerConfig::default().omega_max,
    ))]
    fn new(kp: f64, k_yaw: f64, u_max: (f64, f64), omega_max: f64) -> PyResult<Self> {
        let config = NominalControllerConfig { kp, k_yaw, u_max: [u_max.0, u_max.1], omega_max };
        Ok(Self { inner: NominalController::new(config).map_err(to_py)? })
    }

    /// The nominal command toward (goal, goal_yaw) from the estimated (position, yaw).
    fn command<'py>(&self, py: Python<'py>, goal: &Bound<'py, PyAny>, goal_yaw: f64, position: &Bound<'py, PyAny>, yaw: f64) -> PyResult<(Bound<'py, PyArray1<f64>>, f64)> {
        let c = self.inner.command(&pair("goal", goal)?, goal_yaw, &pair("position", position)?, yaw).map_err(to_py)?;
        Ok((PyArray1::from_slice(py, &c.velocity), c.yaw_rate))
    }
}

/// Adds the planner classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyViewPlanner>()?;
    m.add_class::<PyNominalController>()?;
    Ok(())
}
