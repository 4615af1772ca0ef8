//! `ShieldOutcome`: what one `Shield.filter` call produced, its arrays built when read.

use numpy::PyArray1;
use pyo3::prelude::*;
use shieldnav_core::shield::ShieldOutcome;

/// What one `Shield.filter` call produced. Arrays are built when read.
#[pyclass(name = "ShieldOutcome", module = "shieldnav._core", frozen)]
pub struct PyShieldOutcome {
    pub(crate) inner: ShieldOutcome,
}

#[pymethods]
impl PyShieldOutcome {
    /// Filtered world-frame command u* (float64, length dim).
    #[getter]
    fn u<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.u[..self.inner.dim])
    }
    /// The barrier value H (see the method's docs for what H is per method).
    #[getter(H)]
    fn h(&self) -> f64 {
        self.inner.value
    }
    /// min_i h_i (float max when no point was used).
    #[getter]
    fn h_min(&self) -> f64 {
        self.inner.h_min
    }
    /// World-frame dH/dp (float64, length dim).
    #[getter]
    fn grad_p<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.grad_p[..self.inner.dim])
    }
    /// The rotation command (rad/s; a float planar, 3 values 3D): filtered by the braking
    /// shield, the given omega otherwise.
    #[getter]
    fn omega(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let w = &self.inner.omega;
        if self.inner.dim == 2 {
            Ok(w[2].into_pyobject(py)?.into_any().unbind())
        } else {
            Ok(PyArray1::from_slice(py, w).into_any().unbind())
        }
    }
    /// The braking check found no safe fraction of the row's nor of the tight-space command:
    /// u and omega are the brake (0).
    #[getter]
    fn braked(&self) -> bool {
        self.inner.braked
    }
    /// The ellipse holds a point: the row's command raises H fastest within the box; the
    /// braking check still decides how much of it is sent.
    #[getter]
    fn recovering(&self) -> bool {
        self.inner.recovering
    }
    /// The braking check's margin for the row's full command (m): the least clearance of the
    /// footprint swept until the robot stands, less the clearance required (>= 0 passes);
    /// NaN when no check ran.
    #[getter]
    fn sweep_h(&self) -> f64 {
        self.inner.sweep_h
    }
    /// The braking shield sent (a safe fraction of) the nominal command at most tight_speed:
    /// the ellipse row stalled where the footprint passes.
    #[getter]
    fn tight(&self) -> bool {
        self.inner.tight
    }
    /// The least clearance (m) of the standing footprint to the points the check used
    /// (sys.float_info.max when none is within reach); NaN when no check ran.
    #[getter]
    fn clearance(&self) -> f64 {
        self.inner.clearance
    }
    /// dH/dt caused by the robot's rotation.
    #[getter(dH_dt)]
    fn dh_dt(&self) -> f64 {
        self.inner.dh_dt
    }
    /// Points used after crop, height band and down-sampling.
    #[getter]
    fn num_points(&self) -> usize {
        self.inner.num_points
    }
    /// The constraints changed the command (beyond clamping u_nom to the box).
    #[getter]
    fn active(&self) -> bool {
        self.inner.active
    }
    /// The constraints could be met; if not, u is the documented fallback.
    #[getter]
    fn feasible(&self) -> bool {
        self.inner.feasible
    }
    /// Wall time of the whole call inside the core (ns).
    #[getter]
    fn solve_time_ns(&self) -> u64 {
        self.inner.solve_time_ns
    }

    fn __repr__(&self) -> String {
        let o = &self.inner;
        format!(
            "ShieldOutcome(u={:?}, omega={:?}, H={:.6}, h_min={:.6}, num_points={}, active={}, feasible={}, braked={}, recovering={}, solve_time_ns={})",
            &o.u[..o.dim],
            if o.dim == 2 { &o.omega[2..] } else { &o.omega[..] },
            o.value,
            o.h_min,
            o.num_points,
            o.active,
            o.feasible,
            o.braked,
            o.recovering,
            o.solve_time_ns
        )
    }
}
