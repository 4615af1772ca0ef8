//! The episode's keyword arguments: one table of `keyword → configuration field`, read in both
//! directions, and the one validation of an episode's configuration, whose errors name the
//! keyword a user types (`robot_length`, not the core's `length`).
//!
//! Bindings hand over each keyword's value as a [`Value`] (a number, a flag, a string, a list,
//! or nothing); everything else — unknown keywords, wrong types, bounds, keywords that do not
//! apply to the site — is decided here.
//!
//! ```
//! use shieldnav_core::env::keywords::{episode_config, Value};
//! let (config, _) = episode_config(&[("gamma".into(), Value::Float(0.5))]).unwrap();
//! assert_eq!(config.shield.gamma, 0.5);
//! let err = episode_config(&[("robot_length".into(), Value::Float(-1.0))]).unwrap_err();
//! assert!(err.to_string().contains("robot_length"));
//! ```

use crate::env::{ActionMode, EpisodeConfig};
use crate::error::{Error, Result};
use crate::sensors::LidarMount;
use crate::shield::ShieldMethod;
use crate::world::generate::{GeneratorConfig, SiteKind};
use crate::world::{Footprint, RosMapOptions};

/// A keyword's value as a binding reads it.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// `None` / null.
    None,
    /// A flag (never read as a number).
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A floating-point number.
    Float(f64),
    /// A string.
    Str(String),
    /// A sequence.
    List(Vec<Value>),
}

impl Value {
    /// A short name of the value's kind, for errors.
    fn kind(&self) -> &'static str {
        match self {
            Value::None => "None",
            Value::Bool(_) => "a bool",
            Value::Int(_) => "an integer",
            Value::Float(_) => "a float",
            Value::Str(_) => "a string",
            Value::List(_) => "a sequence",
        }
    }
}

/// As YAML and ROS 2 parameters write it: `null`, `true`, `3`, `0.5`, `"text"`, `[0.9, 0.45]`.
impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::None => f.write_str("null"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(x) => write!(f, "{x}"),
            Value::Str(s) => write!(f, "{s:?}"),
            Value::List(l) => {
                f.write_str("[")?;
                for (k, v) in l.iter().enumerate() {
                    if k > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{v}")?;
                }
                f.write_str("]")
            }
        }
    }
}

/// A configuration field's type, read from a [`Value`]; the error says what was expected.
trait FromValue: Sized {
    fn from_value(v: &Value) -> std::result::Result<Self, String>;
    fn to_value(&self) -> Value;
}

impl FromValue for f64 {
    fn from_value(v: &Value) -> std::result::Result<Self, String> {
        match *v {
            Value::Float(x) => Ok(x),
            Value::Int(i) => Ok(i as f64),
            _ => Err(format!("expected a number, got {}", v.kind())),
        }
    }
    fn to_value(&self) -> Value {
        Value::Float(*self)
    }
}

impl FromValue for bool {
    fn from_value(v: &Value) -> std::result::Result<Self, String> {
        match *v {
            Value::Bool(b) => Ok(b),
            _ => Err(format!("expected True or False, got {}", v.kind())),
        }
    }
    fn to_value(&self) -> Value {
        Value::Bool(*self)
    }
}

impl FromValue for u64 {
    fn from_value(v: &Value) -> std::result::Result<Self, String> {
        match *v {
            Value::Int(i) if i >= 0 => Ok(i as u64),
            Value::Int(i) => Err(format!("expected a non-negative integer, got {i}")),
            _ => Err(format!("expected an integer, got {}", v.kind())),
        }
    }
    fn to_value(&self) -> Value {
        Value::Int(*self as i64)
    }
}

impl FromValue for usize {
    fn from_value(v: &Value) -> std::result::Result<Self, String> {
        u64::from_value(v).and_then(|u| usize::try_from(u).map_err(|_| format!("too large: {u}")))
    }
    fn to_value(&self) -> Value {
        Value::Int(*self as i64)
    }
}

impl<T: FromValue> FromValue for Option<T> {
    fn from_value(v: &Value) -> std::result::Result<Self, String> {
        match v {
            Value::None => Ok(None),
            _ => T::from_value(v).map(Some),
        }
    }
    fn to_value(&self) -> Value {
        self.as_ref().map_or(Value::None, T::to_value)
    }
}

impl<T: FromValue> FromValue for Vec<T> {
    fn from_value(v: &Value) -> std::result::Result<Self, String> {
        match v {
            Value::List(items) => items.iter().map(T::from_value).collect(),
            _ => Err(format!("expected a sequence, got {}", v.kind())),
        }
    }
    fn to_value(&self) -> Value {
        Value::List(self.iter().map(T::to_value).collect())
    }
}

impl<const N: usize> FromValue for [f64; N] {
    fn from_value(v: &Value) -> std::result::Result<Self, String> {
        let items = Vec::<f64>::from_value(v)?;
        <[f64; N]>::try_from(items.as_slice()).map_err(|_| format!("expected {N} numbers, got {}", items.len()))
    }
    fn to_value(&self) -> Value {
        Value::List(self.iter().map(f64::to_value).collect())
    }
}

impl FromValue for (f64, f64) {
    fn from_value(v: &Value) -> std::result::Result<Self, String> {
        <[f64; 2]>::from_value(v).map(|[a, b]| (a, b))
    }
    fn to_value(&self) -> Value {
        [self.0, self.1].to_value()
    }
}

/// Every plain `keyword → field` of the episode configuration.
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
        $f!("brake_margin", shield.braking.brake_margin);
        $f!("rotation_weight", shield.rotation_weight);
        $f!("tight_speed", shield.tight_speed);
        $f!("footprint", footprint);
        $f!("mover_accel", shield.mover_accel);
        $f!("track_movers", track_movers);
        $f!("odometry_velocity", odometry_velocity);
        $f!("mover_min_speed", movers.min_speed);
        $f!("mover_max_size", movers.max_size);
        $f!("mover_max_range", movers.max_range);
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

/// Keywords that are not plain fields: the method and action mode by name, the LIDAR's mount,
/// and the site options.
pub const SPECIAL: [&str; 7] = ["shield", "action_mode", "lidar_mount", "site_kind", "unknown_is_wall", "unreachable_walls", "simplify"];

/// Keywords of a procedural site only.
pub const PROCEDURAL_KEYS: [&str; 1] = ["site_kind"];
/// Keywords of a ROS map site only.
pub const ROS_MAP_KEYS: [&str; 3] = ["simplify", "unknown_is_wall", "unreachable_walls"];

/// Every keyword [`episode_config`] accepts.
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

/// That the site keywords given apply to the site: `site_kind` to a procedural site, the map
/// options to a ROS map (else they would be silently ignored). A keyword at its default
/// changes nothing and passes, so the defaults can be passed back in.
pub fn check_site_keys(procedural: bool, ros_map: bool, kwargs: &[(String, Value)]) -> Result<()> {
    let defaults = defaults();
    let same = |a: &Value, b: &Value| match (a, b) {
        (Value::Int(i), Value::Float(x)) | (Value::Float(x), Value::Int(i)) => *i as f64 == *x,
        _ => a == b,
    };
    let set = |key: &str| kwargs.iter().any(|(k, v)| k == key && !defaults.iter().any(|(d, dv)| *d == key && same(v, dv)));
    if !procedural {
        if let Some(&key) = PROCEDURAL_KEYS.iter().find(|k| set(k)) {
            return Err(Error::invalid(key, "applies to procedural sites only (procedural=True)"));
        }
    }
    if !ros_map {
        if let Some(&key) = ROS_MAP_KEYS.iter().find(|k| set(k)) {
            return Err(Error::invalid(key, "applies to ROS map sites only (ros_map=..., the environments' map_path=...)"));
        }
    }
    Ok(())
}

/// Site options that live outside [`EpisodeConfig`].
#[derive(Debug, Clone, Default)]
pub struct SiteOptions {
    /// The procedural generator's configuration (`site_kind`, the robot's footprint).
    pub generator: GeneratorConfig,
    /// How a ROS map is read (`simplify`, `unknown_is_wall`, `unreachable_walls`).
    pub ros_map: RosMapOptions,
}

fn read<T: FromValue>(key: &'static str, v: &Value) -> Result<T> {
    T::from_value(v).map_err(|reason| Error::invalid(key, reason))
}

fn name_of(key: &'static str, v: &Value) -> Result<String> {
    match v {
        Value::Str(s) => Ok(s.clone()),
        _ => Err(Error::invalid(key, format!("expected a string, got {}", v.kind()))),
    }
}

/// The configuration `kwargs` give over the defaults: an unknown keyword, a value of the wrong
/// type or out of its bounds is an [`Error::InvalidArgument`] naming the keyword.
pub fn episode_config(kwargs: &[(String, Value)]) -> Result<(EpisodeConfig, SiteOptions)> {
    let mut c = EpisodeConfig::default();
    let mut site = SiteOptions::default();
    let known = known_keys();
    for (i, (k, _)) in kwargs.iter().enumerate() {
        if !known.contains(&k.as_str()) {
            let mut sorted = known.clone();
            sorted.sort();
            return Err(Error::invalid("kwargs", format!("unknown keyword argument `{k}`; known: {}", sorted.join(", "))));
        }
        if kwargs[..i].iter().any(|(j, _)| j == k) {
            return Err(Error::invalid("kwargs", format!("`{k}` given twice")));
        }
    }
    let get = |key: &str| kwargs.iter().find(|(k, _)| k == key).map(|(_, v)| v);
    macro_rules! set {
        ($key:literal, $($path:ident).+) => {
            if let Some(v) = get($key) {
                c.$($path).+ = read($key, v)?;
            }
        };
    }
    each_field!(set);
    if let Some(v) = get("shield") {
        let name = name_of("shield", v)?;
        c.shield.method = ShieldMethod::parse(&name).map_err(|_| Error::invalid("shield", format!("unknown shield {name:?}; expected one of {:?}", ShieldMethod::NAMES)))?;
    }
    if let Some(v) = get("action_mode") {
        c.action_mode = ActionMode::parse(&name_of("action_mode", v)?)?;
    }
    if let Some(v) = get("lidar_mount") {
        let [x, y, z, yaw] = read::<[f64; 4]>("lidar_mount", v).map_err(|_| Error::invalid("lidar_mount", "expected (x, y, z, yaw)"))?;
        c.world.lidar.mount = LidarMount { x, y, z, yaw };
    }
    if let Some(v) = get("site_kind") {
        site.generator.kind = match name_of("site_kind", v)?.as_str() {
            "office" => SiteKind::Office,
            "tunnel" => SiteKind::Tunnel,
            other => return Err(Error::invalid("site_kind", format!("expected \"office\" or \"tunnel\", got {other:?}"))),
        };
    }
    if let Some(v) = get("unknown_is_wall") {
        site.ros_map.unknown_is_wall = read("unknown_is_wall", v)?;
    }
    if let Some(v) = get("unreachable_walls") {
        site.ros_map.unreachable_walls = read("unreachable_walls", v)?;
    }
    if let Some(v) = get("simplify") {
        let t: f64 = read("simplify", v).map_err(|_| Error::invalid("simplify", "expected a number of cells"))?;
        if !(t.is_finite() && t >= 0.0) {
            return Err(Error::invalid("simplify", format!("must be finite and >= 0 cells, got {t}")));
        }
        site.ros_map.simplify = t;
    }
    let given: Vec<&str> = kwargs.iter().map(|(k, _)| k.as_str()).collect();
    if c.world.lidar.channels == 1 && c.world.lidar.vertical_fov != EpisodeConfig::default().world.lidar.vertical_fov {
        return Err(Error::invalid("lidar_vertical_fov", "applies to multi-channel LIDARs (lidar_channels > 1); a planar ring has none"));
    }
    // (the LIDAR's own check names `max_range` for the pair: name the one of the two given)
    let (lo, hi) = (c.world.lidar.min_range, c.world.lidar.max_range);
    if lo.is_finite() && hi.is_finite() && lo >= hi && given.contains(&"lidar_min_range") && !given.contains(&"lidar_max_range") {
        return Err(Error::invalid("lidar_min_range", format!("must be below lidar_max_range ({hi} m), got {lo}")));
    }
    c.world.lidar.validate().map_err(|e| keyed(e, &given))?;
    // (scans are taken at control steps: a faster rate would be capped silently)
    if c.world.dt.is_finite() && c.world.dt > 0.0 {
        c.world.lidar.check_rate(c.world.dt).map_err(|e| keyed(e, &given))?;
    }
    c.world.robot.validate().map_err(|e| keyed(e, &given))?;
    site.generator.footprint = Footprint { length: c.world.robot.length, width: c.world.robot.width };
    Ok((c, site))
}

/// The defaults of every keyword [`episode_config`] reads.
pub fn defaults() -> Vec<(&'static str, Value)> {
    let c = EpisodeConfig::default();
    let mut d = Vec::new();
    macro_rules! write {
        ($key:literal, $($path:ident).+) => {
            d.push(($key, c.$($path).+.to_value()));
        };
    }
    each_field!(write);
    let m = c.world.lidar.mount;
    let ros = RosMapOptions::default();
    d.extend([
        ("shield", Value::Str(c.shield.method.name().into())),
        ("action_mode", Value::Str(c.action_mode.name().into())),
        ("lidar_mount", [m.x, m.y, m.z, m.yaw].to_value()),
        ("site_kind", Value::Str("office".into())),
        ("unknown_is_wall", Value::Bool(ros.unknown_is_wall)),
        ("unreachable_walls", Value::Bool(ros.unreachable_walls)),
        ("simplify", Value::Float(ros.simplify)),
    ]);
    d
}

/// An error of the core with the configuration field it names given by its keyword
/// (`length` → `robot_length`, `alpha_max` → `yaw_accel_max`, ...); a field name several
/// keywords share (`u_max`: the shield's and the controller's) becomes the one of them in
/// `given`. Errors that name no field, or a name that is already a keyword, pass unchanged.
pub fn keyed(err: Error, given: &[&str]) -> Error {
    let Error::InvalidArgument { name, reason } = &err else {
        return err;
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
        "footprint" if given.contains(&"footprint") => keys = vec!["footprint"],
        "footprint" => keys = vec!["robot_length", "robot_width"],
        _ => {}
    }
    let chosen: Vec<&str> = keys.iter().copied().filter(|k| given.contains(k)).collect();
    let key = match (keys.len(), chosen.len()) {
        (1, _) => keys[0],
        (_, 1) => chosen[0],
        (n, _) if n > 1 && *name == "footprint" => "robot_length/robot_width",
        _ => return err,
    };
    if key == *name {
        return err;
    }
    Error::invalid(key, reason.clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_default_reads_back_as_itself() {
        let given: Vec<(String, Value)> = defaults().into_iter().map(|(k, v)| (k.to_string(), v)).collect();
        let (c, _) = episode_config(&given).unwrap();
        let d = EpisodeConfig::default();
        assert_eq!((c.world.dt, c.shield.gamma, c.time_limit, c.world.lidar.columns), (d.world.dt, d.shield.gamma, d.time_limit, d.world.lidar.columns));
        assert_eq!(known_keys().len(), defaults().len());
    }

    #[test]
    fn errors_name_the_keyword_a_user_types() {
        let err = |k: &str, v: Value| episode_config(&[(k.to_string(), v)]).unwrap_err().to_string();
        assert!(err("robot_length", Value::Float(-1.0)).contains("robot_length"));
        assert!(err("lidar_dropout", Value::Float(1.0)).contains("lidar_dropout"));
        assert!(err("gamma", Value::Bool(true)).contains("gamma") && err("gamma", Value::Bool(true)).contains("a bool"));
        assert!(err("lidar_columns", Value::Float(1024.0)).contains("expected an integer"));
        assert!(err("no_such_key", Value::None).contains("unknown keyword argument `no_such_key`"));
        assert!(err("semi_axes", Value::Str("x".into())).contains("expected a sequence"));
        assert!(err("lidar_mount", Value::List(vec![Value::Float(0.0)])).contains("(x, y, z, yaw)"));
        assert!(err("lidar_min_range", Value::Int(20)).contains("invalid `lidar_min_range`: must be below lidar_max_range"));
    }

    #[test]
    fn a_shared_field_name_becomes_the_keyword_given() {
        let e = Error::invalid("u_max", "bad");
        assert_eq!(keyed(e.clone(), &["controller_u_max"]), Error::invalid("controller_u_max", "bad"));
        assert_eq!(keyed(e.clone(), &["u_max"]), e);
        assert_eq!(keyed(Error::invalid("alpha_max", "bad"), &[]), Error::invalid("yaw_accel_max", "bad"));
    }
}
