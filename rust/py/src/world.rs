//! `shieldnav._core.World`: build a world (preset, procedural site, ROS map or scenario file),
//! step it with a body-frame command, read the LIDAR, poses and contacts as numpy arrays.
//! Each method converts, calls `shieldnav_core::sim::World`, and maps errors; nothing here
//! computes.
//!
//! The scan, poses and contacts are read-only numpy views of buffers this object owns
//! (allocated once with their final shape, never reallocated): reading them copies nothing,
//! and they follow the world as it steps. The buffers are written after each step with the
//! GIL held, so no Python thread reads them mid-write.

use std::path::PathBuf;

use numpy::ndarray::{Array1, Array2, ArrayBase, Data, Dimension};
use numpy::{Element, IntoPyArray, PyArray, PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};
use shieldnav_core::robot::{RobotShape, TrackerConfig};
use shieldnav_core::sensors::{LidarConfig, LidarMount};
use shieldnav_core::sim::{World, WorldConfig};
use shieldnav_core::world::generate::{GeneratorConfig, SiteKind};
use shieldnav_core::world::{Footprint, RosMapOptions};

use crate::errors::{invalid, to_py, InvalidArgumentError};
use shieldnav_core::Error;

/// A read-only numpy array over `data`, which `owner` holds.
///
/// SAFETY (of the callers): `data` lives inside `owner`'s Rust struct and is never reallocated
/// (only overwritten in place, with the GIL held), so it outlives the array, which keeps
/// `owner` alive as its base.
fn view<'py, T: Element, S: Data<Elem = T>, D: Dimension>(data: &ArrayBase<S, D>, owner: &Bound<'py, PyWorld>) -> Bound<'py, PyArray<T, D>> {
    let array = unsafe { PyArray::borrow_from_array(data, owner.clone().into_any()) };
    // a new array has no borrows, so this cannot fail; the flag stays after the guard drops
    if let Ok(rw) = array.try_readwrite() {
        drop(rw.make_nonwriteable());
    }
    array
}

/// The world, borrowed to read a view: a world that another thread is stepping (its `step`
/// releases the GIL) is a `RuntimeError` saying so, not a panic.
fn borrowed<'py>(this: &Bound<'py, PyWorld>) -> PyResult<PyRef<'py, PyWorld>> {
    this.try_borrow().map_err(|_| PyRuntimeError::new_err("this World is being stepped by another thread: read its views after `step` returns"))
}

/// The buffers behind the views: written after every step, shapes fixed at construction.
struct Views {
    /// (channels, columns) ranges.
    ranges: Array2<f64>,
    /// (channels * columns, 3) body-frame points.
    points: Array2<f64>,
    /// Rows: true pose, odometry estimate, sensor pose at the latest scan; `[x, y, yaw]`.
    poses: Array2<f64>,
    /// `[count, with_walls, with_obstacles, max_penetration]`.
    contacts: Array1<f64>,
}

impl Views {
    fn new(world: &World) -> Self {
        let s = world.scan();
        let mut v = Self { ranges: Array2::zeros((s.channels, s.columns)), points: Array2::zeros((s.points.len(), 3)), poses: Array2::zeros((3, 3)), contacts: Array1::zeros(4) };
        v.update(world);
        v
    }

    /// Copies the world's state in place (no reallocation: shapes never change).
    fn update(&mut self, world: &World) {
        let s = world.scan();
        for (dst, src) in self.ranges.iter_mut().zip(&s.ranges) {
            *dst = *src;
        }
        for (mut row, p) in self.points.rows_mut().into_iter().zip(&s.points) {
            row[0] = p[0];
            row[1] = p[1];
            row[2] = p[2];
        }
        for (k, p) in [world.true_pose(), world.estimated_pose(), s.sensor_pose].into_iter().enumerate() {
            self.poses[[k, 0]] = p.x;
            self.poses[[k, 1]] = p.y;
            self.poses[[k, 2]] = p.yaw;
        }
        let c = world.contacts();
        self.contacts.assign(&Array1::from(vec![c.count as f64, c.with_walls as f64, c.with_obstacles as f64, c.max_penetration]));
    }
}

/// A count (a seed) from a Python int ≥ 0; `True`/`False` and negative or fractional numbers
/// are errors naming `name` (`procedural=True` was site seed 1).
fn count(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<u64> {
    if obj.is_instance_of::<PyBool>() {
        return Err(invalid(name, format!("expected an integer seed >= 0, got {}", obj.repr()?)));
    }
    obj.extract::<u64>().map_err(|_| invalid(name, format!("expected an integer seed from 0 to 2**64 - 1, got {}", obj.repr().map(|r| r.to_string()).unwrap_or_default())))
}

/// A simulated corridor world: walls, scripted obstacles, the robot's rapier body and
/// tracker, an exact LIDAR (seen from the true pose) and a faulty odometry.
///
/// Build from exactly one of `preset` (name), `procedural` (site seed; `kind` "office" or
/// "tunnel"), `ros_map` (map_server YAML path) or `scenario` (JSON path). `seed` seeds every
/// random draw (LIDAR noise and dropout, odometry noise).
#[pyclass(name = "World", module = "shieldnav._core")]
pub struct PyWorld {
    inner: World,
    views: Views,
}

#[pymethods]
impl PyWorld {
    #[new]
    #[pyo3(signature = (*, preset=None, procedural=None, kind="office", ros_map=None, scenario=None, seed=None, dt=0.02,
        channels=1, columns=1024, min_range=0.1, max_range=20.0, range_noise_std=0.01, dropout=0.0, rate_hz=10.0,
        vertical_fov=(-std::f64::consts::FRAC_PI_4, std::f64::consts::FRAC_PI_4), mount=(0.0, 0.0, 0.5, 0.0),
        robot_length=1.1, robot_width=0.5, corner_radius=0.0, unknown_is_wall=true, unreachable_walls=false, simplify=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        preset: Option<String>,
        procedural: Option<&Bound<'_, PyAny>>,
        kind: &str,
        ros_map: Option<PathBuf>,
        scenario: Option<PathBuf>,
        seed: Option<&Bound<'_, PyAny>>,
        dt: f64,
        #[pyo3(from_py_with = crate::errors::channels_arg)] channels: usize,
        #[pyo3(from_py_with = crate::errors::columns_arg)] columns: usize,
        min_range: f64,
        max_range: f64,
        range_noise_std: f64,
        dropout: f64,
        rate_hz: f64,
        #[pyo3(from_py_with = crate::errors::vertical_fov_arg)] vertical_fov: (f64, f64),
        #[pyo3(from_py_with = crate::errors::mount_arg)] mount: (f64, f64, f64, f64),
        robot_length: f64,
        robot_width: f64,
        corner_radius: f64,
        unknown_is_wall: bool,
        unreachable_walls: bool,
        simplify: Option<f64>,
    ) -> PyResult<Self> {
        let sources = preset.is_some() as u8 + procedural.is_some() as u8 + ros_map.is_some() as u8 + scenario.is_some() as u8;
        if sources != 1 {
            return Err(InvalidArgumentError::new_err(format!("give exactly one of preset, procedural, ros_map, scenario (got {sources})")));
        }
        let procedural = procedural.map(|p| count("procedural", p)).transpose()?;
        let seed = seed.map(|s| count("seed", s)).transpose()?.unwrap_or(0);
        // (keywords of another source would be silently ignored)
        if simplify.is_some() && ros_map.is_none() {
            return Err(InvalidArgumentError::new_err("invalid `simplify`: it applies to `ros_map` worlds only (their walls' contours)"));
        }
        if ros_map.is_none() && (!unknown_is_wall || unreachable_walls) {
            let key = if unknown_is_wall { "unreachable_walls" } else { "unknown_is_wall" };
            return Err(invalid(key, "applies to `ros_map` worlds only"));
        }
        if procedural.is_none() && kind != "office" {
            return Err(invalid("kind", "applies to `procedural` worlds only"));
        }
        if channels == 1 && vertical_fov != LidarConfig::default().vertical_fov {
            return Err(invalid("vertical_fov", "applies to multi-channel LIDARs (channels > 1); a planar ring has none"));
        }
        let kind = match kind {
            "office" => SiteKind::Office,
            "tunnel" => SiteKind::Tunnel,
            other => return Err(InvalidArgumentError::new_err(format!("invalid `kind`: expected \"office\" or \"tunnel\", got {other:?}"))),
        };
        let lidar = LidarConfig { channels, columns, vertical_fov, min_range, max_range, range_noise_std, dropout, rate_hz, mount: LidarMount { x: mount.0, y: mount.1, z: mount.2, yaw: mount.3 } };
        let config = WorldConfig { robot: RobotShape { length: robot_length, width: robot_width, corner_radius }, tracker: TrackerConfig::default(), lidar, dt, seed };
        let world = py
            .detach(move || {
                if let Some(name) = preset {
                    World::from_preset(&name, config)
                } else if let Some(site) = procedural {
                    // (every site admits this robot's footprint, not the default one)
                    let footprint = Footprint { length: robot_length, width: robot_width };
                    World::from_procedural(site, &GeneratorConfig { kind, footprint, ..Default::default() }, config).map_err(|e| match e {
                        // (the generator's site seed is this constructor's `procedural`)
                        Error::InvalidArgument { name: "seed", reason } => Error::InvalidArgument { name: "procedural", reason },
                        e => e,
                    })
                } else if let Some(path) = ros_map {
                    let simplify = simplify.unwrap_or(RosMapOptions::default().simplify);
                    World::from_ros_map(path, &RosMapOptions { unknown_is_wall, unreachable_walls, simplify, ..Default::default() }, config)
                } else {
                    World::from_scenario_file(scenario.unwrap_or_default(), config)
                }
            })
            .map_err(|e| match e {
                // (the robot's fields as this constructor's keywords name them)
                Error::InvalidArgument { name: "length", reason } => invalid("robot_length", reason),
                Error::InvalidArgument { name: "width", reason } => invalid("robot_width", reason),
                Error::InvalidArgument { name: "footprint", reason } => invalid("robot_length/robot_width", reason),
                e => to_py(e),
            })?;
        let views = Views::new(&world);
        Ok(Self { inner: world, views })
    }

    /// Advances one control period with the body-frame command (m/s, m/s, rad/s). Returns a
    /// dict: time, scanned, saturated, contact_count, max_penetration, and velocity (the
    /// body-frame `(vx, vy, ω)` the body achieved, what a wheel odometry reports).
    fn step<'py>(&mut self, py: Python<'py>, vx: f64, vy: f64, wz: f64) -> PyResult<Bound<'py, PyDict>> {
        let inner = &mut self.inner;
        let out = py.detach(move || inner.step([vx, vy, wz])).map_err(to_py)?;
        self.views.update(&self.inner);
        let d = PyDict::new(py);
        d.set_item("time", out.time)?;
        d.set_item("scanned", out.scanned)?;
        d.set_item("saturated", out.saturated)?;
        d.set_item("contact_count", out.contacts.count)?;
        d.set_item("max_penetration", out.contacts.max_penetration)?;
        d.set_item("velocity", out.velocity)?;
        Ok(d)
    }

    /// World time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.inner.time()
    }

    /// Latest ranges, shape (channels, columns), m; `inf` where there is no return. A live,
    /// read-only view (no copy): it follows the world as it steps; `.copy()` keeps a scan.
    #[getter]
    fn ranges<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(view(&borrowed(this)?.views.ranges, this))
    }

    /// Latest body-frame points, shape (channels * columns, 3), m; NaN rows where there is no
    /// return. A live, read-only view like `ranges`.
    #[getter]
    fn points<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(view(&borrowed(this)?.views.points, this))
    }

    /// Time (s) of the latest scan.
    #[getter]
    fn scan_time(&self) -> f64 {
        self.inner.scan().stamp
    }

    /// The sensor's true planar pose `[x, y, yaw]` when the latest scan was taken (live view).
    #[getter]
    fn sensor_pose<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(view(&borrowed(this)?.views.poses.row(2), this))
    }

    /// The robot's true pose `[x, y, yaw]` (live view).
    #[getter]
    fn true_pose<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(view(&borrowed(this)?.views.poses.row(0), this))
    }

    /// The odometry estimate `[x, y, yaw]` (live view).
    #[getter]
    fn estimated_pose<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(view(&borrowed(this)?.views.poses.row(1), this))
    }

    /// Contacts after the last step: `[count, with_walls, with_obstacles, max_penetration]`
    /// (live view).
    #[getter]
    fn contacts<'py>(this: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(view(&borrowed(this)?.views.contacts, this))
    }

    /// Every wall now (static and moving obstacles), shape (M, 5): `ax, ay, bx, by, height`.
    #[getter]
    fn walls<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let w = self.inner.walls_now();
        let flat: Vec<f64> = w.iter().flat_map(|s| [s.a[0], s.a[1], s.b[0], s.b[1], s.height]).collect();
        let a = Array2::from_shape_vec((w.len(), 5), flat).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py))
    }

    /// The scenario's name.
    #[getter]
    fn name(&self) -> String {
        self.inner.scenario().name.clone()
    }

    fn __repr__(&self) -> String {
        format!("World(name={:?}, time={:.3}, walls={})", self.inner.scenario().name, self.inner.time(), self.inner.scenario().map.segments.len())
    }
}

/// Adds the world classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyWorld>()?;
    Ok(())
}
