//! `shieldnav._core.Episode`: one corridor-inspection episode, stepped with one FFI crossing
//! per step. Converts arguments, calls `shieldnav_core::env::Episode`, maps errors.

use std::path::PathBuf;

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shieldnav_core::env::{Episode, EpisodeSummary, StepReport};
use shieldnav_core::world::Pose2;

use crate::config::{episode_config, episode_defaults, SiteArgs};
use crate::errors::{invalid, to_py};

/// What `Episode.step` returns: Gymnasium's `(observation, reward, terminated, truncated, info)`.
type Step<'py> = (Bound<'py, PyArray1<f32>>, f64, bool, bool, Bound<'py, PyDict>);
/// What `Episode.scan_points` returns: the points and their validity mask.
type ScanPoints<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<i8>>);
type ScanRanges<'py> = (Bound<'py, PyArray2<f64>>, f64, (f64, f64, f64, f64));

fn pose_tuple(p: Pose2) -> (f64, f64, f64) {
    (p.x, p.y, p.yaw)
}

/// The action as three floats: a float32 or float64 array of shape (3,), or a sequence of
/// real numbers (bool and complex refused).
fn action3(obj: &Bound<'_, PyAny>) -> PyResult<[f64; 3]> {
    crate::errors::refuse_bool_complex(obj, "action")?;
    let bad_shape = |shape: &[usize]| invalid("action", format!("expected shape (3,), got {shape:?}"));
    // (through a view, so that a strided array of three is read too)
    if let Ok(a) = obj.extract::<PyReadonlyArray1<f32>>() {
        let v = a.as_array();
        return if v.len() == 3 { Ok([v[0] as f64, v[1] as f64, v[2] as f64]) } else { Err(bad_shape(a.shape())) };
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray1<f64>>() {
        let v = a.as_array();
        return if v.len() == 3 { Ok([v[0], v[1], v[2]]) } else { Err(bad_shape(a.shape())) };
    }
    obj.extract::<[f64; 3]>().map_err(|_| invalid("action", "expected 3 numbers (a float32 array of shape (3,))"))
}

/// Builds the `info` dict of a step (Safety-Gymnasium style keys).
fn info<'py>(py: Python<'py>, r: &StepReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item(intern!(py, "cost"), r.cost)?;
    d.set_item(intern!(py, "collision"), r.cost > 0.0)?;
    d.set_item(intern!(py, "contacts"), r.contacts)?;
    d.set_item(intern!(py, "clearance"), r.clearance)?;
    d.set_item(intern!(py, "H"), r.h)?;
    d.set_item(intern!(py, "h_min"), r.h_min)?;
    d.set_item(intern!(py, "shield_active"), r.shield_active)?;
    d.set_item(intern!(py, "shield_feasible"), r.shield_feasible)?;
    d.set_item(intern!(py, "shield_braked"), r.shield_braked)?;
    d.set_item(intern!(py, "shield_recovering"), r.shield_recovering)?;
    d.set_item(intern!(py, "shield_tight"), r.shield_tight)?;
    d.set_item(intern!(py, "intervention"), r.intervention)?;
    d.set_item(intern!(py, "u_nom"), PyArray1::from_slice(py, &r.u_nom))?;
    d.set_item(intern!(py, "u_filtered"), PyArray1::from_slice(py, &r.u_filtered))?;
    d.set_item(intern!(py, "coverage"), r.coverage)?;
    d.set_item(intern!(py, "new_coverage"), r.new_coverage)?;
    d.set_item(intern!(py, "deadlock"), r.deadlock)?;
    d.set_item(intern!(py, "odometry_error"), r.odometry_error)?;
    d.set_item(intern!(py, "solve_time_ns"), r.solve_time_ns)?;
    d.set_item(intern!(py, "num_points"), r.num_points)?;
    d.set_item(intern!(py, "movers"), r.movers)?;
    d.set_item(intern!(py, "time"), r.time)?;
    Ok(d)
}

/// The episode totals as a dict.
pub fn summary_dict<'py>(py: Python<'py>, s: &EpisodeSummary) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("steps", s.steps)?;
    d.set_item("time", s.time)?;
    d.set_item("collisions", s.collisions)?;
    d.set_item("contact_events", s.contact_events)?;
    d.set_item("moving_collisions", s.moving_collisions)?;
    d.set_item("mover_steps", s.mover_steps)?;
    d.set_item("odometry_distrusted_steps", s.odometry_distrusted_steps)?;
    d.set_item("contact_steps", s.contact_steps)?;
    d.set_item("contact_time", s.contact_time)?;
    d.set_item("deadlock", s.deadlock)?;
    d.set_item("deadlock_time", s.deadlock_time)?;
    d.set_item("success", s.success)?;
    d.set_item("coverage", s.coverage)?;
    d.set_item("path_length", s.path_length)?;
    d.set_item("intervention_mean", s.intervention_mean)?;
    d.set_item("shield_active_steps", s.shield_active_steps)?;
    d.set_item("shield_infeasible_steps", s.shield_infeasible_steps)?;
    d.set_item("shield_braked_steps", s.shield_braked_steps)?;
    d.set_item("shield_recovering_steps", s.shield_recovering_steps)?;
    d.set_item("shield_tight_steps", s.shield_tight_steps)?;
    d.set_item("min_clearance", s.min_clearance)?;
    d.set_item("min_h", s.min_h)?;
    d.set_item("solve_time_mean_ns", s.solve_time_mean_ns)?;
    d.set_item("solve_time_max_ns", s.solve_time_max_ns)?;
    d.set_item("total_reward", s.total_reward)?;
    Ok(d)
}

/// One corridor-inspection episode in Rust: world, shield, coverage, reward and metrics.
///
/// Build from exactly one of `preset` (a paper scenario), `procedural=True` (a new site every
/// reset), `ros_map` (map_server YAML) or `scenario` (JSON file); every other keyword is a
/// configuration key (see `episode_defaults()`).
#[pyclass(name = "Episode", module = "shieldnav._core")]
pub struct PyEpisode {
    inner: Episode,
}

#[pymethods]
impl PyEpisode {
    #[new]
    #[pyo3(signature = (*, preset=None, procedural=false, ros_map=None, scenario=None, seed=0, **kwargs))]
    fn new(
        py: Python<'_>,
        preset: Option<String>,
        procedural: bool,
        ros_map: Option<PathBuf>,
        scenario: Option<PathBuf>,
        #[pyo3(from_py_with = crate::errors::seed_arg)] seed: u64,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let args = SiteArgs { preset, procedural, ros_map, scenario };
        args.check()?;
        let kw = crate::config::values(kwargs)?;
        args.check_keys(&kw)?;
        let (config, opts) = episode_config(&kw)?;
        let inner = py
            .detach(move || {
                let site = args.load(&opts)?;
                Episode::new(site, config, seed)
            })
            .map_err(|e| crate::config::keyed(e, &kw))?;
        Ok(Self { inner })
    }

    /// Starts a new episode from `seed` (a new site for procedural sources).
    fn reset(&mut self, py: Python<'_>, #[pyo3(from_py_with = crate::errors::seed_arg)] seed: u64) -> PyResult<()> {
        let inner = &mut self.inner;
        py.detach(move || inner.reset(seed)).map_err(to_py)
    }

    /// One control period. Returns `(observation, reward, terminated, truncated, info)`; the
    /// observation is a new float32 array.
    fn step<'py>(&mut self, py: Python<'py>, action: &Bound<'py, PyAny>) -> PyResult<Step<'py>> {
        let a = action3(action)?;
        let obs = PyArray1::<f32>::zeros(py, self.inner.observation_len(), false);
        let r = {
            let mut w = obs.readwrite();
            let o = w.as_slice_mut().map_err(|e| invalid("observation", e))?;
            let inner = &mut self.inner;
            // (the GIL released while the episode steps, as `World.step` and `Batch.step` do)
            py.detach(move || {
                let r = inner.step(a)?;
                inner.observe(o)?;
                Ok(r)
            })
            .map_err(to_py)?
        };
        Ok((obs, r.reward, r.terminated, r.truncated, info(py, &r)?))
    }

    /// The flat observation now, as a new float32 array.
    fn observe<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let obs = PyArray1::<f32>::zeros(py, self.inner.observation_len(), false);
        {
            let mut w = obs.readwrite();
            let o = w.as_slice_mut().map_err(|e| invalid("observation", e))?;
            let inner = &self.inner;
            py.detach(move || inner.observe(o)).map_err(to_py)?;
        }
        Ok(obs)
    }

    /// The latest scan's returns in the current body frame as a new float32 array of shape
    /// (channels * columns, 3), zero where there is no return, and the validity mask (int8).
    fn scan_points<'py>(&self, py: Python<'py>) -> PyResult<ScanPoints<'py>> {
        let scan = self.inner.world().scan();
        let n = scan.channels * scan.columns;
        let pts = PyArray2::<f32>::zeros(py, [n, 3], false);
        let valid = PyArray1::<i8>::zeros(py, n, false);
        {
            let mut p = pts.readwrite();
            let mut v = valid.readwrite();
            let ps = p.as_slice_mut().map_err(|e| invalid("points", e))?;
            let vs = v.as_slice_mut().map_err(|e| invalid("points", e))?;
            let (points, ids) = self.inner.points();
            for (row, &id) in points.chunks_exact(3).zip(&ids) {
                let k = id as usize;
                ps[3 * k] = row[0] as f32;
                ps[3 * k + 1] = row[1] as f32;
                ps[3 * k + 2] = row[2] as f32;
                vs[k] = 1;
            }
        }
        Ok((pts, valid))
    }

    /// The latest scan as its sensor measured it: ranges, float64 `(channels, columns)` (m;
    /// `inf` where there is no return; column `i` at azimuth `2π i / columns` in the sensor
    /// frame), its time (s), and the sensor's mount `(x, y, z, yaw)` on the body.
    fn scan_ranges<'py>(&self, py: Python<'py>) -> PyResult<ScanRanges<'py>> {
        let scan = self.inner.world().scan();
        let m = self.inner.config().world.lidar.mount;
        let ranges = PyArray1::from_slice(py, &scan.ranges).reshape([scan.channels, scan.columns])?;
        Ok((ranges, scan.stamp, (m.x, m.y, m.z, m.yaw)))
    }

    /// The latest scan's valid returns in the current body frame, float64 (n, 3).
    fn valid_points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (p, _) = self.inner.points();
        let n = p.len() / 3;
        PyArray1::from_vec(py, p).reshape([n, 3])
    }

    /// The returns the shield sees this step, float32 (n, 3) in the current body frame: those
    /// of `valid_points()` that can lie inside its crop radius.
    fn shield_points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let p = self.inner.shield_points();
        let n = p.len() / 3;
        PyArray1::from_vec(py, p).reshape([n, 3])
    }

    /// Totals of the episode so far.
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        summary_dict(py, self.inner.summary())
    }

    /// Everything a top-down picture needs, as numpy arrays (world frame, m).
    fn render_data<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let w = self.inner.world();
        let d = PyDict::new(py);
        let seg = |v: &mut Vec<f64>, a: [f64; 2], b: [f64; 2]| v.extend_from_slice(&[a[0], a[1], b[0], b[1]]);
        let mut walls = Vec::new();
        for s in &w.scenario().map.segments {
            seg(&mut walls, s.a, s.b);
        }
        let mut obstacles = Vec::new();
        let now = w.walls_now();
        for s in &now[w.scenario().map.segments.len()..] {
            seg(&mut obstacles, s.a, s.b);
        }
        let cov = self.inner.coverage();
        let mut pieces = Vec::new();
        for p in cov.pieces() {
            seg(&mut pieces, p.a, p.b);
        }
        let shape4 = |v: Vec<f64>| {
            let n = v.len() / 4;
            PyArray1::from_vec(py, v).reshape([n, 4])
        };
        d.set_item("walls", shape4(walls)?)?;
        d.set_item("obstacles", shape4(obstacles)?)?;
        d.set_item("pieces", shape4(pieces)?)?;
        d.set_item("inspected", PyArray1::from_vec(py, cov.inspected().to_vec()))?;
        let pose = w.true_pose();
        d.set_item("pose", PyArray1::from_slice(py, &[pose.x, pose.y, pose.yaw]))?;
        let est = w.estimated_pose();
        d.set_item("estimated_pose", PyArray1::from_slice(py, &[est.x, est.y, est.yaw]))?;
        let (s, c) = pose.yaw.sin_cos();
        let pts: Vec<f64> = self.inner.points().0.chunks_exact(3).flat_map(|p| [pose.x + c * p[0] - s * p[1], pose.y + s * p[0] + c * p[1]]).collect();
        let n = pts.len() / 2;
        d.set_item("points", PyArray1::from_vec(py, pts).reshape([n, 2])?)?;
        let r = self.inner.last_report();
        let to_world = |u: [f64; 3]| [c * u[0] - s * u[1], s * u[0] + c * u[1]];
        d.set_item("u_nom", PyArray1::from_slice(py, &to_world(r.u_nom)))?;
        d.set_item("u_star", PyArray1::from_slice(py, &to_world(r.u_filtered)))?;
        d.set_item("contact", r.cost > 0.0)?;
        d.set_item("time", r.time)?;
        d.set_item("coverage", r.coverage)?;
        d.set_item("H", r.h)?;
        Ok(d)
    }

    /// Length of the flat observation.
    #[getter]
    fn observation_len(&self) -> usize {
        self.inner.observation_len()
    }

    /// `(low, high)` of the flat observation under this configuration (float32 arrays).
    fn observation_bounds<'py>(&self, py: Python<'py>) -> (Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>) {
        let (low, high) = self.inner.observation_bounds();
        (PyArray1::from_vec(py, low), PyArray1::from_vec(py, high))
    }

    /// `(channels, columns, max_range)` of the LIDAR.
    #[getter]
    fn lidar_shape(&self) -> (usize, usize, f64) {
        let l = self.inner.config().world.lidar;
        (l.channels, l.columns, l.max_range)
    }

    /// Episode time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.inner.world().time()
    }

    /// The robot's true pose `(x, y, yaw)`.
    #[getter]
    fn true_pose(&self) -> (f64, f64, f64) {
        pose_tuple(self.inner.world().true_pose())
    }

    /// The body velocity `(v_x, v_y, ω)` (body frame) the last step left the robot at: the
    /// tracker state the braking shield's check starts from.
    #[getter]
    fn velocity(&self) -> (f64, f64, f64) {
        let v = self.inner.velocity();
        (v[0], v[1], v[2])
    }

    /// The odometry estimate `(x, y, yaw)`.
    #[getter]
    fn estimated_pose(&self) -> (f64, f64, f64) {
        pose_tuple(self.inner.world().estimated_pose())
    }

    /// The scenario's goal `(x, y, yaw)` in the world frame, if it has one.
    #[getter]
    fn goal(&self) -> Option<(f64, f64, f64)> {
        self.inner.world().scenario().goal.map(pose_tuple)
    }

    /// The scenario's name.
    #[getter]
    fn name(&self) -> String {
        self.inner.world().scenario().name.clone()
    }

    /// Robot `(length, width)` and shield semi-axes, for drawing.
    #[getter]
    fn geometry(&self) -> ((f64, f64), Vec<f64>, Option<f64>) {
        let c = self.inner.config();
        ((c.world.robot.length, c.world.robot.width), c.shield.semi_axes.clone(), c.shield.scan.crop_radius)
    }

    /// Control period (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.inner.config().world.dt
    }

    fn __repr__(&self) -> String {
        format!("Episode(name={:?}, time={:.2}, coverage={:.3})", self.inner.world().scenario().name, self.inner.world().time(), self.inner.coverage().fraction())
    }
}

/// Every configuration key of `Episode` with its default (the paper's values).
#[pyfunction(name = "episode_defaults")]
fn episode_defaults_dict(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    episode_defaults(py)
}

/// Adds the episode classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyEpisode>()?;
    m.add_function(wrap_pyfunction!(episode_defaults_dict, m)?)?;
    Ok(())
}
