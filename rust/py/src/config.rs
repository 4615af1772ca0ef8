//! Keyword arguments ↔ `EpisodeConfig`: one table of `key → field`, read in both directions,
//! so the defaults Python shows are the core's `Default`s.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use shieldnav_core::env::{ActionMode, EpisodeConfig};
use shieldnav_core::shield::ShieldMethod;
use shieldnav_core::world::generate::{GeneratorConfig, SiteKind};
use shieldnav_core::world::RosMapOptions;

use std::path::PathBuf;

use shieldnav_core::env::Site;
use shieldnav_core::world::{load_ros_map, Scenario};

use crate::errors::invalid;

/// Where an episode's world comes from, as the Python keywords give it (exactly one).
pub struct SiteArgs {
    pub preset: Option<String>,
    pub procedural: bool,
    pub ros_map: Option<PathBuf>,
    pub scenario: Option<PathBuf>,
}

impl SiteArgs {
    /// Checks that exactly one source is given.
    pub fn check(&self) -> PyResult<()> {
        let n = self.preset.is_some() as u8 + self.procedural as u8 + self.ros_map.is_some() as u8 + self.scenario.is_some() as u8;
        if n != 1 {
            return Err(invalid("site", format!("give exactly one of preset, procedural=True, ros_map, scenario (got {n})")));
        }
        Ok(())
    }

    /// That the site keywords in `kwargs` apply to this site: `site_kind` to a procedural
    /// one, the map options to a ROS map (else they would be silently ignored).
    pub fn check_keys(&self, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let Some(kw) = kwargs else { return Ok(()) };
        // (a key at its default changes nothing: the defaults can be passed back in)
        let set = |key: &str, default: Bound<'_, PyAny>| -> PyResult<bool> {
            Ok(match kw.get_item(key)? {
                Some(v) => !v.eq(default)?,
                None => false,
            })
        };
        let py = kw.py();
        if !self.procedural && set("site_kind", "office".into_pyobject(py)?.into_any())? {
            return Err(invalid("site_kind", "applies to procedural sites only (procedural=True)"));
        }
        if self.ros_map.is_none() {
            let d = RosMapOptions::default();
            for (key, default) in [
                ("simplify", d.simplify.into_pyobject(py)?.into_any()),
                ("unknown_is_wall", d.unknown_is_wall.into_pyobject(py)?.to_owned().into_any()),
                ("unreachable_walls", d.unreachable_walls.into_pyobject(py)?.to_owned().into_any()),
            ] {
                if set(key, default)? {
                    return Err(invalid(key, "applies to ROS map sites only (ros_map=..., the environments' map_path=...)"));
                }
            }
        }
        Ok(())
    }

    /// The core's site (loads a map or scenario file; call detached from the GIL).
    pub fn load(self, opts: &SiteOptions) -> shieldnav_core::Result<Site> {
        Ok(if let Some(name) = self.preset {
            Site::Preset(name)
        } else if self.procedural {
            Site::Procedural(opts.generator)
        } else if let Some(path) = self.ros_map {
            Site::Scenario(Box::new(load_ros_map(path, &opts.ros_map)?.scenario))
        } else {
            Site::Scenario(Box::new(Scenario::from_json_file(self.scenario.unwrap_or_default())?))
        })
    }
}

/// Every plain `key → field` of the episode configuration.
macro_rules! each_field {
    ($f:ident) => {
        $f!("dt", world.dt);
        $f!("robot_length", world.robot.length);
        $f!("robot_width", world.robot.width);
        $f!("corner_radius", world.robot.corner_radius);
        $f!("tracker_tau", world.tracker.tau);
        $f!("v_max", world.tracker.v_max);
        $f!("w_max", world.tracker.w_max);
        $f!("a_max", world.tracker.a_max);
        $f!("yaw_accel_max", world.tracker.alpha_max);
        $f!("lidar_channels", world.lidar.channels);
        $f!("lidar_columns", world.lidar.columns);
        $f!("lidar_vertical_fov", world.lidar.vertical_fov);
        $f!("lidar_min_range", world.lidar.min_range);
        $f!("lidar_max_range", world.lidar.max_range);
        $f!("lidar_noise_std", world.lidar.range_noise_std);
        $f!("lidar_dropout", world.lidar.dropout);
        $f!("lidar_rate_hz", world.lidar.rate_hz);
        $f!("semi_axes", shield.semi_axes);
        $f!("gamma", shield.gamma);
        $f!("kappa", shield.kappa);
        $f!("alpha", shield.alpha);
        $f!("u_max", shield.u_max);
        $f!("safety_distance", shield.safety_distance);
        $f!("crop_radius", shield.scan.crop_radius);
        $f!("height_band", shield.scan.height_band);
        $f!("voxel_size", shield.scan.voxel_size);
        $f!("angular_bins", shield.scan.angular_bins);
        $f!("grad_eps", shield.grad_eps);
        $f!("brake_margin", shield.braking.margin);
        $f!("rotation_weight", shield.rotation_weight);
        $f!("d_view", planner.d_view);
        $f!("gamma_h", planner.gamma_h);
        $f!("gamma_v", planner.gamma_v);
        $f!("fov_h", planner.fov_h);
        $f!("fov_v", planner.fov_v);
        $f!("horizon", planner.horizon);
        $f!("reach_threshold", planner.reach_threshold);
        $f!("kp", controller.kp);
        $f!("k_yaw", controller.k_yaw);
        $f!("controller_u_max", controller.u_max);
        $f!("omega_max", controller.omega_max);
        $f!("waypoint_reach", waypoint_reach);
        $f!("coverage_reward", reward.coverage);
        $f!("collision_penalty", reward.collision);
        $f!("intervention_penalty", reward.intervention);
        $f!("piece_length", coverage.piece_length);
        $f!("coverage_margin", coverage.margin);
        $f!("coverage_goal", coverage.goal);
        $f!("deadlock_window", deadlock.window);
        $f!("deadlock_displacement", deadlock.displacement);
        $f!("lidar_bins", observation.bins);
        $f!("terminate_on_contact", terminate_on_contact);
        $f!("truncate_on_deadlock", truncate_on_deadlock);
        $f!("terminate_at_goal", terminate_at_goal);
        $f!("goal_tolerance", goal_tolerance);
        $f!("stop_when_infeasible", stop_when_infeasible);
        $f!("time_limit", time_limit);
    };
}

/// Keys that are not plain fields.
const SPECIAL: [&str; 7] = ["shield", "action_mode", "lidar_mount", "site_kind", "unknown_is_wall", "unreachable_walls", "simplify"];

/// Every key [`episode_config`] accepts.
pub fn known_keys() -> Vec<&'static str> {
    let mut keys = Vec::new();
    macro_rules! key {
        ($key:literal, $($path:ident).+) => {
            keys.push($key);
        };
    }
    each_field!(key);
    keys.extend(SPECIAL);
    keys
}

/// A core error as a Python exception, a field of the configuration named by its keyword
/// here (`length` → `robot_length`, `alpha_max` → `yaw_accel_max`, ...); a core name shared
/// by several keywords (`u_max`: the shield's or the controller's) is the one of them given
/// in `kwargs`.
pub fn keyed(err: shieldnav_core::Error, kwargs: Option<&Bound<'_, PyDict>>) -> PyErr {
    let shieldnav_core::Error::InvalidArgument { name, reason } = &err else {
        return crate::errors::to_py(err);
    };
    let mut keys: Vec<&str> = Vec::new();
    macro_rules! pair {
        ($key:literal, $($path:ident).+) => {
            if stringify!($($path).+).rsplit('.').next().map(str::trim) == Some(*name) {
                keys.push($key);
            }
        };
    }
    each_field!(pair);
    match *name {
        "mount" => keys = vec!["lidar_mount"],
        // (the procedural generator's limits on the robot)
        "footprint" => keys = vec!["robot_length", "robot_width"],
        _ => {}
    }
    let given: Vec<&str> = keys.iter().copied().filter(|k| kwargs.is_some_and(|d| d.contains(k).unwrap_or(false))).collect();
    let key = match (keys.len(), given.len()) {
        (1, _) => keys[0].to_string(),
        (_, 1) => given[0].to_string(),
        (n, _) if n > 1 && *name == "footprint" => keys.join("/"),
        _ => return crate::errors::to_py(err),
    };
    if key != *name {
        return invalid(&key, reason);
    }
    crate::errors::to_py(err)
}

/// Whether a configuration field is a `bool` (the only fields a Python bool may set).
fn is_bool_field<T: 'static>(_: &T) -> bool {
    std::any::TypeId::of::<T>() == std::any::TypeId::of::<bool>()
}

/// Site options that live outside `EpisodeConfig`.
pub struct SiteOptions {
    pub generator: GeneratorConfig,
    pub ros_map: RosMapOptions,
}

/// Reads `kwargs` over the defaults; an unknown key or a value of the wrong type is an
/// `InvalidArgumentError` naming the key.
pub fn episode_config(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<(EpisodeConfig, SiteOptions)> {
    let mut c = EpisodeConfig::default();
    let mut site = SiteOptions { generator: GeneratorConfig::default(), ros_map: RosMapOptions::default() };
    let Some(kw) = kwargs else {
        return Ok((c, site));
    };
    let known = known_keys();
    for k in kw.keys() {
        let k: String = k.extract().map_err(|_| invalid("kwargs", "keyword names must be strings"))?;
        if !known.contains(&k.as_str()) {
            let mut sorted = known.clone();
            sorted.sort();
            return Err(invalid(&k, format!("unknown keyword argument; known: {}", sorted.join(", "))));
        }
    }
    macro_rules! read {
        ($key:literal, $($path:ident).+) => {
            if let Some(v) = kw.get_item($key)? {
                // (a bool is an int to Python: `gamma=True` was read as 1)
                if !is_bool_field(&c.$($path).+) {
                    crate::errors::refuse_bool_complex(&v, $key)?;
                }
                c.$($path).+ = v.extract().map_err(|e| invalid($key, format!("wrong type: {e}")))?;
            }
        };
    }
    each_field!(read);
    if let Some(v) = kw.get_item("shield")? {
        let name: String = v.extract().map_err(|_| invalid("shield", "expected a string"))?;
        c.shield.method = ShieldMethod::parse(&name).map_err(|_| invalid("shield", format!("unknown shield {name:?}; expected one of {:?}", ShieldMethod::NAMES)))?;
    }
    if let Some(v) = kw.get_item("action_mode")? {
        let name: String = v.extract().map_err(|_| invalid("action_mode", "expected a string"))?;
        c.action_mode = ActionMode::parse(&name).map_err(crate::errors::to_py)?;
    }
    if let Some(v) = kw.get_item("lidar_mount")? {
        crate::errors::refuse_bool_complex(&v, "lidar_mount")?;
        let (x, y, z, yaw): (f64, f64, f64, f64) = v.extract().map_err(|_| invalid("lidar_mount", "expected (x, y, z, yaw)"))?;
        c.world.lidar.mount = shieldnav_core::sensors::LidarMount { x, y, z, yaw };
    }
    if let Some(v) = kw.get_item("site_kind")? {
        let name: String = v.extract().map_err(|_| invalid("site_kind", "expected a string"))?;
        site.generator.kind = match name.as_str() {
            "office" => SiteKind::Office,
            "tunnel" => SiteKind::Tunnel,
            other => return Err(invalid("site_kind", format!("expected \"office\" or \"tunnel\", got {other:?}"))),
        };
    }
    if let Some(v) = kw.get_item("unknown_is_wall")? {
        site.ros_map.unknown_is_wall = v.extract().map_err(|_| invalid("unknown_is_wall", "expected a bool"))?;
    }
    if let Some(v) = kw.get_item("unreachable_walls")? {
        site.ros_map.unreachable_walls = v.extract().map_err(|_| invalid("unreachable_walls", "expected a bool"))?;
    }
    if let Some(v) = kw.get_item("simplify")? {
        crate::errors::refuse_bool_complex(&v, "simplify")?;
        let t: f64 = v.extract().map_err(|_| invalid("simplify", "expected a number of cells"))?;
        if !(t.is_finite() && t >= 0.0) {
            return Err(invalid("simplify", format!("must be finite and >= 0 cells, got {t}")));
        }
        site.ros_map.simplify = t;
    }
    if c.world.lidar.channels == 1 && c.world.lidar.vertical_fov != EpisodeConfig::default().world.lidar.vertical_fov {
        return Err(invalid("lidar_vertical_fov", "applies to multi-channel LIDARs (lidar_channels > 1); a planar ring has none"));
    }
    c.world.lidar.validate().map_err(|e| keyed(e, Some(kw)))?;
    // (scans are taken at control steps: a faster rate would be capped silently)
    if c.world.dt.is_finite() && c.world.dt > 0.0 {
        c.world.lidar.check_rate(c.world.dt).map_err(|e| keyed(e, Some(kw)))?;
    }
    c.world.robot.validate().map_err(|e| keyed(e, Some(kw)))?;
    site.generator.footprint = shieldnav_core::world::Footprint { length: c.world.robot.length, width: c.world.robot.width };
    Ok((c, site))
}

/// The defaults as a dict of the keys [`episode_config`] reads.
pub fn episode_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let c = EpisodeConfig::default();
    let d = PyDict::new(py);
    macro_rules! write {
        ($key:literal, $($path:ident).+) => {
            d.set_item($key, c.$($path).+.clone())?;
        };
    }
    each_field!(write);
    d.set_item("shield", c.shield.method.name())?;
    d.set_item("action_mode", c.action_mode.name())?;
    let m = c.world.lidar.mount;
    d.set_item("lidar_mount", (m.x, m.y, m.z, m.yaw))?;
    d.set_item("site_kind", "office")?;
    d.set_item("unknown_is_wall", RosMapOptions::default().unknown_is_wall)?;
    d.set_item("unreachable_walls", RosMapOptions::default().unreachable_walls)?;
    d.set_item("simplify", RosMapOptions::default().simplify)?;
    Ok(d)
}
