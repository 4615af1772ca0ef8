//! `shieldnav._core.Batch`: N episodes stepped in Rust on worker threads, one FFI crossing
//! per batch step, the GIL released while they run. Outputs are new numpy arrays filled in
//! place by the core.

use std::path::PathBuf;

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shieldnav_core::env::{AutoReset, Batch, SlotOutcome};

use crate::config::{episode_config, SiteArgs};
use crate::episode::summary_dict;
use crate::errors::{invalid, to_py};

/// A batch of corridor-inspection episodes (the native vector environment's engine).
///
/// `Batch(num_envs, seeds, *, preset=None, procedural=False, ros_map=None, scenario=None,
/// autoreset_mode="next_step", threads=2, **config)`.
#[pyclass(name = "Batch", module = "shieldnav._core")]
pub struct PyBatch {
    inner: Batch,
    outcomes: Vec<SlotOutcome>,
}

fn seeds_vec(obj: &Bound<'_, PyAny>, n: usize, name: &str) -> PyResult<Vec<u64>> {
    let v: Vec<u64> =
        if let Ok(a) = obj.extract::<PyReadonlyArray1<u64>>() { a.as_array().to_vec() } else { obj.extract().map_err(|_| invalid(name, "expected a sequence of non-negative integers"))? };
    if v.len() != n {
        return Err(invalid(name, format!("expected {n} seeds, got {}", v.len())));
    }
    Ok(v)
}

#[pymethods]
impl PyBatch {
    #[new]
    #[pyo3(signature = (num_envs, seeds, *, preset=None, procedural=false, ros_map=None, scenario=None, autoreset_mode="next_step", threads=2, **kwargs))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        #[pyo3(from_py_with = crate::errors::num_envs_arg)] num_envs: usize,
        seeds: &Bound<'_, PyAny>,
        preset: Option<String>,
        procedural: bool,
        ros_map: Option<PathBuf>,
        scenario: Option<PathBuf>,
        autoreset_mode: &str,
        #[pyo3(from_py_with = crate::errors::threads_arg)] threads: usize,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let args = SiteArgs { preset, procedural, ros_map, scenario };
        args.check()?;
        let kw = crate::config::values(kwargs)?;
        args.check_keys(&kw)?;
        if num_envs == 0 {
            return Err(invalid("num_envs", "must be at least 1"));
        }
        let seeds = seeds_vec(seeds, num_envs, "seeds")?;
        let mode = AutoReset::parse(autoreset_mode).map_err(to_py)?;
        let (config, opts) = episode_config(&kw)?;
        let inner = py
            .detach(move || {
                let site = args.load(&opts)?;
                Batch::new(site, config, &seeds, mode, threads)
            })
            .map_err(|e| crate::config::keyed(e, &kw))?;
        Ok(Self { outcomes: vec![SlotOutcome::default(); num_envs], inner })
    }

    /// Resets episode `i` with `seeds[i]`; returns the observations (N, L) float32.
    fn reset<'py>(&mut self, py: Python<'py>, seeds: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let seeds = seeds_vec(seeds, self.inner.len(), "seeds")?;
        let obs = PyArray2::<f32>::zeros(py, [self.inner.len(), self.inner.observation_len()], false);
        {
            let mut w = obs.readwrite();
            let o = w.as_slice_mut().map_err(|e| invalid("observations", e))?;
            let inner = &mut self.inner;
            py.detach(move || inner.reset(&seeds, o)).map_err(to_py)?;
        }
        Ok(obs)
    }

    /// Steps every episode: `actions` (N, 3) float32/float64 in [-1, 1], `next_seeds` (N,)
    /// uint64 for episodes that reset. Returns `(obs, reward, terminated, truncated, info,
    /// final_obs, reset)`; `info` holds one array per key, `final_obs` the last observation of
    /// episodes that ended (same-step mode), `reset` which episodes were reset in this call.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
        next_seeds: &Bound<'py, PyAny>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyDict>,
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray1<bool>>,
    )> {
        let n = self.inner.len();
        crate::errors::refuse_bool_complex(actions, "actions")?;
        let a: Vec<f64> = if let Ok(arr) = actions.extract::<PyReadonlyArray2<f32>>() {
            if arr.shape() != [n, 3] {
                return Err(invalid("actions", format!("expected shape ({n}, 3), got {:?}", arr.shape())));
            }
            arr.as_array().iter().map(|&v| v as f64).collect()
        } else if let Ok(arr) = actions.extract::<PyReadonlyArray2<f64>>() {
            if arr.shape() != [n, 3] {
                return Err(invalid("actions", format!("expected shape ({n}, 3), got {:?}", arr.shape())));
            }
            arr.as_array().iter().copied().collect()
        } else {
            return Err(invalid("actions", format!("expected a float32 or float64 array of shape ({n}, 3)")));
        };
        let seeds = seeds_vec(next_seeds, n, "next_seeds")?;
        let l = self.inner.observation_len();
        let obs = PyArray2::<f32>::zeros(py, [n, l], false);
        let fin = PyArray2::<f32>::zeros(py, [n, l], false);
        {
            let mut ow = obs.readwrite();
            let mut fw = fin.readwrite();
            let o = ow.as_slice_mut().map_err(|e| invalid("observations", e))?;
            let f = fw.as_slice_mut().map_err(|e| invalid("observations", e))?;
            let (inner, out) = (&mut self.inner, &mut self.outcomes);
            py.detach(move || inner.step(&a, &seeds, o, f, out)).map_err(to_py)?;
        }
        let out = &self.outcomes;
        let col = |f: &dyn Fn(&SlotOutcome) -> f64| PyArray1::from_iter(py, out.iter().map(f));
        let flag = |f: &dyn Fn(&SlotOutcome) -> bool| PyArray1::from_iter(py, out.iter().map(f));
        let info = PyDict::new(py);
        info.set_item("cost", col(&|s| s.report.cost))?;
        info.set_item("collision", flag(&|s| s.report.cost > 0.0))?;
        info.set_item("contacts", PyArray1::from_iter(py, out.iter().map(|s| s.report.contacts)))?;
        info.set_item("clearance", col(&|s| s.report.clearance))?;
        info.set_item("H", col(&|s| s.report.h))?;
        info.set_item("h_min", col(&|s| s.report.h_min))?;
        info.set_item("shield_active", flag(&|s| s.report.shield_active))?;
        info.set_item("shield_feasible", flag(&|s| s.report.shield_feasible))?;
        info.set_item("shield_braked", flag(&|s| s.report.shield_braked))?;
        info.set_item("shield_recovering", flag(&|s| s.report.shield_recovering))?;
        info.set_item("shield_tight", flag(&|s| s.report.shield_tight))?;
        info.set_item("intervention", col(&|s| s.report.intervention))?;
        info.set_item("coverage", col(&|s| s.report.coverage))?;
        info.set_item("new_coverage", col(&|s| s.report.new_coverage))?;
        info.set_item("deadlock", flag(&|s| s.report.deadlock))?;
        info.set_item("odometry_error", col(&|s| s.report.odometry_error))?;
        info.set_item("solve_time_ns", PyArray1::from_iter(py, out.iter().map(|s| s.report.solve_time_ns)))?;
        info.set_item("num_points", PyArray1::from_iter(py, out.iter().map(|s| s.report.num_points)))?;
        info.set_item("movers", PyArray1::from_iter(py, out.iter().map(|s| s.report.movers)))?;
        info.set_item("time", col(&|s| s.report.time))?;
        let u = |f: &dyn Fn(&SlotOutcome) -> [f64; 3]| PyArray1::from_iter(py, out.iter().flat_map(f)).reshape([n, 3]);
        info.set_item("u_nom", u(&|s| s.report.u_nom)?)?;
        info.set_item("u_filtered", u(&|s| s.report.u_filtered)?)?;
        let ended = PyDict::new(py);
        for (i, s) in out.iter().enumerate() {
            if let Some(e) = &s.ended {
                ended.set_item(i, summary_dict(py, e)?)?;
            }
        }
        info.set_item("ended", ended)?;
        Ok((obs, col(&|s| s.report.reward), flag(&|s| s.report.terminated), flag(&|s| s.report.truncated), info, fin, flag(&|s| s.reset)))
    }

    /// Totals of episode `i` so far.
    fn summary<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyDict>> {
        let ep = self.inner.episodes().get(i).ok_or_else(|| invalid("i", format!("must be < {}", self.inner.len())))?;
        summary_dict(py, ep.summary())
    }

    /// The scenario's name in episode `i` (a procedural site's changes with each episode).
    fn site_name(&self, i: usize) -> PyResult<String> {
        let ep = self.inner.episodes().get(i).ok_or_else(|| invalid("i", format!("must be < {}", self.inner.len())))?;
        Ok(ep.world().scenario().name.clone())
    }

    /// Number of episodes.
    fn __len__(&self) -> usize {
        self.inner.len()
    }

    /// Length of one observation.
    #[getter]
    fn observation_len(&self) -> usize {
        self.inner.observation_len()
    }
}

/// Adds the batch class to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyBatch>()
}
