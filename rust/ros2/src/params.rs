//! The node's parameters: read from a ROS 2 parameter file (`node_name: ros__parameters:
//! {...}`) and `-p name:=value` overrides, each checked, the shield's through
//! [`Shield::new`] so an error names the parameter at fault.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Duration;

use shieldnav_core::robot::TrackerConfig;
use shieldnav_core::sensors::MoverTrackerConfig;
use shieldnav_core::shield::{BrakingModel, Footprint, ScanFilter, Shield, ShieldConfig, ShieldMethod};
use yaml_rust2::{Yaml, YamlLoader};

use crate::translate::Mount;

/// A parameter's value as a parameter file or `-p name:=value` writes it (`None` is `null` or
/// `~`: the option is off): the core's keyword value.
pub use shieldnav_core::env::keywords::Value;

fn value_from_yaml(y: &Yaml) -> Option<Value> {
    Some(match y {
        Yaml::Null => Value::None,
        Yaml::Boolean(b) => Value::Bool(*b),
        Yaml::Integer(i) => Value::Int(*i),
        Yaml::Real(s) => Value::Float(parse_real(s)?),
        Yaml::String(s) => Value::Str(s.clone()),
        Yaml::Array(a) => Value::List(a.iter().map(value_from_yaml).collect::<Option<_>>()?),
        _ => return None,
    })
}

/// Reads a value written as on a ROS 2 command line (`name:=value`): YAML scalars and flow
/// lists (`1.5`, `true`, `[0.9, 0.45]`, `null`, `braking`).
pub fn parse_value(text: &str) -> Value {
    match YamlLoader::load_from_str(text).ok().and_then(|docs| docs.into_iter().next()) {
        Some(y) => value_from_yaml(&y).unwrap_or_else(|| Value::Str(text.to_string())),
        None => Value::None,
    }
}

fn parse_real(s: &str) -> Option<f64> {
    match s.trim() {
        ".inf" | ".Inf" | ".INF" | "+.inf" | "+.Inf" | "+.INF" => Some(f64::INFINITY),
        "-.inf" | "-.Inf" | "-.INF" => Some(f64::NEG_INFINITY),
        ".nan" | ".NaN" | ".NAN" => Some(f64::NAN),
        t => t.parse().ok(),
    }
}

/// A parameter that cannot be used, with the parameter's name.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    /// The parameter (or file, or argument) at fault.
    pub name: String,
    /// What is wrong.
    pub reason: String,
}

impl ParamError {
    fn new(name: impl Into<String>, reason: impl Into<String>) -> Self {
        Self { name: name.into(), reason: reason.into() }
    }
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "parameter `{}`: {}", self.name, self.reason)
    }
}

impl std::error::Error for ParamError {}

/// Every parameter name the node reads, with its help line (`--help` prints them).
pub const PARAMETERS: &[(&str, &str)] = &[
    ("method", "shield: braking | composite | distance | hardmin | none (default braking)"),
    ("semi_axes", "body ellipse semi-axes, m: 2 values planar, 3 values 3D (default [0.9, 0.45])"),
    ("gamma", "saturation γ of tanh(h/γ) (default 0.9)"),
    ("kappa", "soft-min sharpness κ (default 8)"),
    ("alpha", "class-K gain, α(h) = α h (default 2)"),
    ("crop_radius", "drop points farther than this, m; null keeps all (default 3.5)"),
    ("u_max", "velocity box |u_j| ≤ u_max_j, m/s, one per axis; null: the braking model's v_max (default null)"),
    ("safety_distance", "s_d of the distance baseline, m (default 0.8)"),
    ("height_band", "[z_lo, z_hi] of body-frame points a planar shield keeps, m; null keeps all (default [-0.4, 1.5])"),
    ("voxel_size", "keep one point per voxel of this edge, m; null: off (default null)"),
    ("angular_bins", "keep one point per azimuth bin; null: off (default null)"),
    ("grad_eps", "gradient norm below which the barrier counts as flat (default 1e-9)"),
    ("tracker_tau", "braking model: the base's velocity lag, s (default 0.15)"),
    ("a_max", "braking model: acceleration limits [ax, ay], m/s² (default [2, 2])"),
    ("w_max", "braking model: yaw-rate limit, rad/s (default 1.5)"),
    ("yaw_accel_max", "braking model: yaw acceleration limit, rad/s² (default 4)"),
    ("dt", "braking model: control period, s (default 0.02)"),
    ("brake_margin", "braking model: clearance kept between the footprint and every point beyond 3 lidar_noise_std, m (default 0.01)"),
    ("lidar_noise_std", "braking model: the scan's range noise, m; the check keeps 3 of them (default 0.01)"),
    ("footprint", "braking model: the body's convex outline, Nav2's convention: \"[[x, y], [x, y], ...]\" in m, body frame (default: 1.1 x 0.5 m)"),
    ("tight_speed", "braking shield: speed up to which the nominal command is followed where the ellipse stalls but the footprint passes, m/s (default 0.5)"),
    ("rotation_weight", "braking shield: weight of a change of ω against one of v (default 4)"),
    ("track_movers", "track small moving objects in the LaserScan (segments, a constant-velocity Kalman track each) and keep the robot from driving into their predicted paths (default true)"),
    ("mover_min_speed", "slowest object speed reported as moving, m/s (default 0.3)"),
    ("mover_max_size", "larger segments are structure, never movers, m (default 1.2)"),
    ("mover_max_range", "objects farther from the sensor are not tracked, m (default 6)"),
    ("mover_accel", "braking shield: the acceleration a mover may add toward the robot, m/s² (default 0.25)"),
    ("stop_when_infeasible", "send zero when the constraints cannot be met (the planar braking shield excepted: its braking check decides) (default true)"),
    ("scan_topic", "sensor_msgs/LaserScan in; empty: none (default /scan)"),
    ("cloud_topic", "sensor_msgs/PointCloud2 in; empty: none (default empty)"),
    ("nominal_topic", "nominal geometry_msgs/Twist in (default /cmd_vel_nominal)"),
    ("nominal_stamped", "the nominal command is a geometry_msgs/TwistStamped (default false)"),
    ("odom_topic", "nav_msgs/Odometry in: body velocity and ω; empty: none (default /odom)"),
    ("imu_topic", "sensor_msgs/Imu in: its angular velocity replaces odometry's (the translation stays odometry's); empty: none (default empty)"),
    ("cmd_topic", "filtered geometry_msgs/Twist out (default /cmd_vel)"),
    ("cmd_stamped", "the filtered command is a geometry_msgs/TwistStamped in base_frame, stamped as the stamped nominal command it answers, else at sending (default false)"),
    ("base_frame", "the body's frame: the stamped command's frame_id, and the frame a recording's /tf_static mounts the sensor on (default base_link)"),
    ("state_topic", "std_msgs/String out, one JSON object per command (default /shieldnav/state)"),
    ("scan_timeout", "a scan older than this stops the robot, s (default 0.5)"),
    ("command_timeout", "a nominal command older than this stops the robot, s (default 0.5)"),
    ("odom_timeout", "odometry / IMU older than this stops the robot, s (default 0.5)"),
    ("watchdog_rate", "rate of the zero commands sent while the nominal command is missing, Hz; 0: off (default 10)"),
    ("filter_on_scan", "also filter and publish on every scan, not only on every nominal command (default false)"),
    ("max_invalid_fraction", "a LaserScan with a larger share of NaN ranges (invalid, not \"no return\") is rejected; 1 switches the check off (default 0.9)"),
    ("sensor_frame", "the frame_id scans and clouds must carry; empty: any (default empty)"),
    ("mount_x", "sensor position in the body frame, m (default 0)"),
    ("mount_y", "sensor position in the body frame, m (default 0)"),
    ("mount_z", "sensor height in the body frame, m (default 0)"),
    ("mount_yaw", "sensor yaw in the body frame, rad (default 0)"),
    ("record", "write every nominal command heard, command sent and state to this new MCAP file (ros2 profile); empty: off (default empty)"),
    ("domain_id", "DDS domain (default: $ROS_DOMAIN_ID, else 0)"),
];

/// Everything the node runs with, checked.
#[derive(Debug, Clone)]
pub struct NodeParams {
    /// The node's name (`__node` remap, default `shieldnav_shield`).
    pub node_name: String,
    /// The shield, validated by [`Shield::new`].
    pub shield: ShieldConfig,
    /// Send zero when the constraints cannot be met (the planar braking shield excepted).
    pub stop_when_infeasible: bool,
    /// Topics (remaps applied); `None` when switched off.
    pub topics: Topics,
    /// The nominal command is a `TwistStamped`.
    pub nominal_stamped: bool,
    /// The filtered command is a `TwistStamped`.
    pub cmd_stamped: bool,
    /// The body's frame (the stamped command's `frame_id`).
    pub base_frame: String,
    /// A scan older than this stops the robot.
    pub scan_timeout: Duration,
    /// A nominal command older than this stops the robot.
    pub command_timeout: Duration,
    /// Odometry or IMU older than this stops the robot.
    pub odom_timeout: Duration,
    /// Period of the watchdog's zero commands; `None` when off.
    pub watchdog_period: Option<Duration>,
    /// Filter and publish on each scan as well.
    pub filter_on_scan: bool,
    /// The frame scans and clouds must carry.
    pub sensor_frame: Option<String>,
    /// A LaserScan with a larger share of NaN ranges is rejected (a blinded sensor).
    pub max_invalid_fraction: f64,
    /// The sensor's mount on the body.
    pub mount: Mount,
    /// DDS domain.
    pub domain_id: u16,
    /// The MCAP file the node records to; `None` when off.
    pub record: Option<std::path::PathBuf>,
    /// The mover tracker's parameters; `None` when off.
    pub movers: Option<MoverTrackerConfig>,
}

/// The node's topics.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topics {
    /// `sensor_msgs/LaserScan` in.
    pub scan: Option<String>,
    /// `sensor_msgs/PointCloud2` in.
    pub cloud: Option<String>,
    /// Nominal `Twist` / `TwistStamped` in.
    pub nominal: String,
    /// `nav_msgs/Odometry` in.
    pub odom: Option<String>,
    /// `sensor_msgs/Imu` in.
    pub imu: Option<String>,
    /// Filtered `Twist` out.
    pub cmd: String,
    /// State (`std_msgs/String`, JSON) out.
    pub state: String,
}

/// The default node name.
pub const NODE_NAME: &str = "shieldnav_shield";

/// Raw parameters by name, in the order they were given (later wins), and topic remaps.
#[derive(Debug, Clone, Default)]
pub struct RawParams {
    /// `name → value`.
    pub values: BTreeMap<String, Value>,
    /// `from → to` topic remaps (`-r from:=to`).
    pub remaps: BTreeMap<String, String>,
    /// The node name, if remapped (`-r __node:=name`).
    pub node_name: Option<String>,
}

impl RawParams {
    /// Adds the parameters a ROS 2 parameter file gives the node `node_name` (its own section,
    /// `/node_name`, or the wildcard `/**`; every section that matches, in file order).
    pub fn load_yaml(&mut self, text: &str, source: &str, node_name: &str) -> Result<(), ParamError> {
        let docs = YamlLoader::load_from_str(text).map_err(|e| ParamError::new(source, format!("not valid YAML: {e}")))?;
        let Some(Yaml::Hash(top)) = docs.first() else {
            return Err(ParamError::new(source, "expected a mapping `node_name: {ros__parameters: {...}}`"));
        };
        let mut matched = false;
        for (key, section) in top {
            let Yaml::String(key) = key else { continue };
            let k = key.trim_start_matches('/');
            if !(k == node_name || k == "**" || k == "*" || k.ends_with(&format!("/{node_name}"))) {
                continue;
            }
            matched = true;
            let params = match section {
                Yaml::Hash(h) => h.get(&Yaml::String("ros__parameters".into())),
                _ => None,
            };
            let Some(Yaml::Hash(params)) = params else {
                return Err(ParamError::new(source, format!("section `{key}` has no `ros__parameters` mapping")));
            };
            self.add_hash("", params, source)?;
        }
        if !matched {
            return Err(ParamError::new(source, format!("no section for the node `{node_name}` (nor `/**`)")));
        }
        Ok(())
    }

    fn add_hash(&mut self, prefix: &str, h: &yaml_rust2::yaml::Hash, source: &str) -> Result<(), ParamError> {
        for (k, v) in h {
            let name = match k {
                Yaml::String(s) => format!("{prefix}{s}"),
                other => return Err(ParamError::new(source, format!("parameter name {other:?} is not a string"))),
            };
            match v {
                // nested parameters (`a: {b: 1}` is `a.b`)
                Yaml::Hash(inner) => self.add_hash(&format!("{name}."), inner, source)?,
                y => {
                    let value = value_from_yaml(y).ok_or_else(|| ParamError::new(&name, format!("cannot read the value {y:?}")))?;
                    self.values.insert(name, value);
                }
            }
        }
        Ok(())
    }

    /// Reads the command line: `--params FILE`, `--help`, and ROS 2 style `--ros-args` with
    /// `-p name:=value`, `--params-file FILE`, `-r from:=to` and `-r __node:=name`. Files are
    /// read after the arguments are parsed, so a `__node` remap selects their section; `-p`
    /// wins over files.
    pub fn from_args<I: IntoIterator<Item = String>>(args: I) -> Result<Self, ParamError> {
        let mut files = Vec::new();
        let mut sets = Vec::new();
        let mut raw = RawParams::default();
        let mut it = args.into_iter();
        while let Some(a) = it.next() {
            match a.as_str() {
                "--ros-args" | "--" => {}
                "--params" | "--params-file" => files.push(it.next().ok_or_else(|| ParamError::new(&a, "expects a file"))?),
                "-p" | "--param" => sets.push(it.next().ok_or_else(|| ParamError::new(&a, "expects name:=value"))?),
                "-r" | "--remap" => {
                    let r = it.next().ok_or_else(|| ParamError::new(&a, "expects from:=to"))?;
                    let (from, to) = r.split_once(":=").ok_or_else(|| ParamError::new("-r", format!("expects from:=to, got {r:?}")))?;
                    if from == "__node" || from == "__name" {
                        raw.node_name = Some(to.to_string());
                    } else {
                        raw.remaps.insert(from.to_string(), to.to_string());
                    }
                }
                other => return Err(ParamError::new(other, "unknown argument (see --help)")),
            }
        }
        let node = raw.node_name.clone().unwrap_or_else(|| NODE_NAME.to_string());
        for f in files {
            let text = std::fs::read_to_string(&f).map_err(|e| ParamError::new(&f, format!("cannot read: {e}")))?;
            raw.load_yaml(&text, &f, &node)?;
        }
        for s in sets {
            let (name, value) = s.split_once(":=").ok_or_else(|| ParamError::new("-p", format!("expects name:=value, got {s:?}")))?;
            raw.values.insert(name.to_string(), parse_value(value));
        }
        Ok(raw)
    }

    /// Sets one parameter.
    pub fn set(&mut self, name: &str, value: Value) -> &mut Self {
        self.values.insert(name.to_string(), value);
        self
    }

    /// Checks every parameter and builds the node's configuration.
    pub fn build(&self) -> Result<NodeParams, ParamError> {
        if let Some(unknown) = self.values.keys().find(|k| !PARAMETERS.iter().any(|(n, _)| n == k) && *k != "use_sim_time") {
            return Err(ParamError::new(unknown, "unknown parameter (see --help for the list)"));
        }
        let g = Getter(&self.values);
        let d = ShieldConfig::default();
        let tracker_default = TrackerConfig::default();
        let braking_default = BrakingModel::default();
        let method_name = g.string("method", "braking")?;
        let method = ShieldMethod::parse(&method_name).map_err(core_error)?;
        let u_max = g.opt_floats("u_max", None)?;
        let mut tracker = TrackerConfig {
            tau: g.float("tracker_tau", tracker_default.tau)?,
            a_max: g.pair("a_max", tracker_default.a_max)?,
            w_max: g.float("w_max", tracker_default.w_max)?,
            alpha_max: g.float("yaw_accel_max", tracker_default.alpha_max)?,
            ..tracker_default
        };
        if let Some(m) = u_max.as_deref().filter(|m| m.len() == 2) {
            // the braking model's speed limit is the box
            tracker.v_max = [m[0], m[1]];
        }
        let height_band = match g.opt_floats("height_band", d.scan.height_band.map(|(a, b)| vec![a, b]))? {
            None => None,
            Some(v) if v.len() == 2 => Some((v[0], v[1])),
            Some(v) => return Err(ParamError::new("height_band", format!("expects [z_lo, z_hi] or null, got {} values", v.len()))),
        };
        let angular_bins = match g.get("angular_bins") {
            None | Some(Value::None) => d.scan.angular_bins,
            Some(Value::Int(i)) if *i >= 0 => Some(*i as usize),
            Some(v) => return Err(ParamError::new("angular_bins", format!("expects a non-negative integer or null, got {v}"))),
        };
        let shield = ShieldConfig {
            semi_axes: g.floats("semi_axes", d.semi_axes.clone())?,
            gamma: g.float("gamma", d.gamma)?,
            kappa: g.float("kappa", d.kappa)?,
            alpha: g.float("alpha", d.alpha)?,
            u_max,
            method,
            safety_distance: g.float("safety_distance", d.safety_distance)?,
            scan: ScanFilter { crop_radius: g.opt_float("crop_radius", d.scan.crop_radius)?, height_band, voxel_size: g.opt_float("voxel_size", d.scan.voxel_size)?, angular_bins },
            grad_eps: g.float("grad_eps", d.grad_eps)?,
            braking: BrakingModel {
                tracker,
                dt: g.float("dt", braking_default.dt)?,
                brake_margin: g.float("brake_margin", braking_default.brake_margin)?,
                lidar_noise_std: g.float("lidar_noise_std", braking_default.lidar_noise_std)?,
                footprint: g.footprint("footprint", braking_default.footprint)?,
            },
            rotation_weight: g.float("rotation_weight", d.rotation_weight)?,
            tight_speed: g.float("tight_speed", d.tight_speed)?,
            mover_accel: g.float("mover_accel", d.mover_accel)?,
        };
        // the core's checks, whose errors name the field (its names are the parameters')
        Shield::new(shield.clone()).map_err(core_error)?;

        let topic = |name: &str, default: &str| -> Result<Option<String>, ParamError> {
            let t = g.string(name, default)?;
            if t.is_empty() {
                return Ok(None);
            }
            let t = self.remaps.get(&t).cloned().unwrap_or(t);
            if t.contains(char::is_whitespace) || t.ends_with('/') {
                return Err(ParamError::new(name, format!("{t:?} is not a topic name")));
            }
            Ok(Some(t))
        };
        let required = |name: &str, default: &str| -> Result<String, ParamError> { topic(name, default)?.ok_or_else(|| ParamError::new(name, "must name a topic")) };
        let topics = Topics {
            scan: topic("scan_topic", "/scan")?,
            cloud: topic("cloud_topic", "")?,
            nominal: required("nominal_topic", "/cmd_vel_nominal")?,
            odom: topic("odom_topic", "/odom")?,
            imu: topic("imu_topic", "")?,
            cmd: required("cmd_topic", "/cmd_vel")?,
            state: required("state_topic", "/shieldnav/state")?,
        };
        if topics.scan.is_none() && topics.cloud.is_none() {
            return Err(ParamError::new("scan_topic", "no sensor: set scan_topic or cloud_topic"));
        }
        if method == ShieldMethod::Braking && topics.odom.is_none() {
            return Err(ParamError::new("odom_topic", "the braking shield needs the body's measured velocity: set odom_topic (nav_msgs/Odometry)"));
        }
        let seconds = |name: &str, default: f64| -> Result<Duration, ParamError> {
            let s = g.float(name, default)?;
            if !(s.is_finite() && s > 0.0 && s <= 3600.0) {
                return Err(ParamError::new(name, format!("must be in (0, 3600] s, got {s}")));
            }
            Ok(Duration::from_secs_f64(s))
        };
        let rate = g.float("watchdog_rate", 10.0)?;
        if !(rate.is_finite() && (0.0..=1000.0).contains(&rate)) {
            return Err(ParamError::new("watchdog_rate", format!("must be from 0 to 1000 Hz, got {rate}")));
        }
        let mount = Mount::new(g.float("mount_x", 0.0)?, g.float("mount_y", 0.0)?, g.float("mount_z", 0.0)?, g.float("mount_yaw", 0.0)?).map_err(|(n, r)| ParamError::new(n, r))?;
        let default_domain = std::env::var("ROS_DOMAIN_ID").ok().and_then(|s| s.trim().parse::<i64>().ok()).unwrap_or(0);
        let domain = g.int("domain_id", default_domain)?;
        if !(0..=232).contains(&domain) {
            return Err(ParamError::new("domain_id", format!("must be from 0 to 232, got {domain}")));
        }
        let movers = if g.bool("track_movers", true)? {
            let d = MoverTrackerConfig::default();
            let m =
                MoverTrackerConfig { min_speed: g.float("mover_min_speed", d.min_speed)?, max_size: g.float("mover_max_size", d.max_size)?, max_range: g.float("mover_max_range", d.max_range)?, ..d };
            m.validate().map_err(|e| match e {
                shieldnav_core::Error::InvalidArgument { name, reason } => ParamError::new(if name.starts_with("mover_") { name.to_string() } else { format!("mover_{name}") }, reason),
                other => ParamError::new("track_movers", other.to_string()),
            })?;
            Some(m)
        } else {
            None
        };
        let sensor_frame = g.string("sensor_frame", "")?;
        let base_frame = g.string("base_frame", "base_link")?;
        if base_frame.is_empty() || base_frame.contains(char::is_whitespace) {
            return Err(ParamError::new("base_frame", format!("{base_frame:?} is not a frame name")));
        }
        let max_invalid_fraction = g.float("max_invalid_fraction", 0.9)?;
        if !(0.0..=1.0).contains(&max_invalid_fraction) {
            return Err(ParamError::new("max_invalid_fraction", format!("must be from 0 to 1, got {max_invalid_fraction}")));
        }
        Ok(NodeParams {
            node_name: self.node_name.clone().unwrap_or_else(|| NODE_NAME.to_string()),
            shield,
            stop_when_infeasible: g.bool("stop_when_infeasible", true)?,
            topics,
            nominal_stamped: g.bool("nominal_stamped", false)?,
            cmd_stamped: g.bool("cmd_stamped", false)?,
            base_frame,
            scan_timeout: seconds("scan_timeout", 0.5)?,
            command_timeout: seconds("command_timeout", 0.5)?,
            odom_timeout: seconds("odom_timeout", 0.5)?,
            watchdog_period: (rate > 0.0).then(|| Duration::from_secs_f64(1.0 / rate)),
            filter_on_scan: g.bool("filter_on_scan", false)?,
            sensor_frame: (!sensor_frame.is_empty()).then_some(sensor_frame),
            max_invalid_fraction,
            mount,
            domain_id: domain as u16,
            record: Some(g.string("record", "")?).filter(|r| !r.is_empty()).map(std::path::PathBuf::from),
            movers,
        })
    }
}

/// The parameter a core error names (the core's field names are the parameters' but for one).
fn parameter_of(field: &str) -> &str {
    match field {
        "v_max" => "u_max",
        f => f,
    }
}

fn core_error(e: shieldnav_core::Error) -> ParamError {
    match &e {
        shieldnav_core::Error::InvalidArgument { name, reason } => ParamError::new(parameter_of(name), reason.clone()),
        shieldnav_core::Error::DimensionMismatch { name, expected, got } => ParamError::new(*name, format!("expects {expected} values (one per axis of semi_axes), got {got}")),
        other => ParamError::new("shield", other.to_string()),
    }
}

struct Getter<'a>(&'a BTreeMap<String, Value>);

impl Getter<'_> {
    fn get(&self, name: &str) -> Option<&Value> {
        self.0.get(name)
    }

    fn float(&self, name: &str, default: f64) -> Result<f64, ParamError> {
        match self.get(name) {
            None => Ok(default),
            Some(Value::Float(x)) => Ok(*x),
            Some(Value::Int(i)) => Ok(*i as f64),
            Some(v) => Err(ParamError::new(name, format!("expects a number, got {v}"))),
        }
    }

    fn opt_float(&self, name: &str, default: Option<f64>) -> Result<Option<f64>, ParamError> {
        match self.get(name) {
            None => Ok(default),
            Some(Value::None) => Ok(None),
            Some(_) => self.float(name, 0.0).map(Some),
        }
    }

    fn int(&self, name: &str, default: i64) -> Result<i64, ParamError> {
        match self.get(name) {
            None => Ok(default),
            Some(Value::Int(i)) => Ok(*i),
            Some(v) => Err(ParamError::new(name, format!("expects an integer, got {v}"))),
        }
    }

    fn bool(&self, name: &str, default: bool) -> Result<bool, ParamError> {
        match self.get(name) {
            None => Ok(default),
            Some(Value::Bool(b)) => Ok(*b),
            Some(v) => Err(ParamError::new(name, format!("expects true or false, got {v}"))),
        }
    }

    fn string(&self, name: &str, default: &str) -> Result<String, ParamError> {
        match self.get(name) {
            None => Ok(default.to_string()),
            Some(Value::Str(s)) => Ok(s.clone()),
            Some(Value::None) => Ok(String::new()),
            Some(v) => Err(ParamError::new(name, format!("expects a string, got {v}"))),
        }
    }

    /// A footprint polygon as Nav2 writes it, the string `"[[x, y], [x, y], ...]"`, or the
    /// same as a list of pairs.
    fn footprint(&self, name: &str, default: Footprint) -> Result<Footprint, ParamError> {
        let bad = |what: String| ParamError::new(name, format!("expects \"[[x, y], [x, y], ...]\" (m, a convex polygon), {what}"));
        let pair = |v: &Value| -> Option<[f64; 2]> {
            let num = |v: &Value| match v {
                Value::Float(x) => Some(*x),
                Value::Int(i) => Some(*i as f64),
                _ => None,
            };
            match v {
                Value::List(p) if p.len() == 2 => Some([num(&p[0])?, num(&p[1])?]),
                _ => None,
            }
        };
        let vertices: Vec<[f64; 2]> = match self.get(name) {
            None => return Ok(default),
            Some(Value::Str(s)) => {
                let body = s.trim();
                let inner = body.strip_prefix('[').and_then(|b| b.strip_suffix(']')).ok_or_else(|| bad(format!("got {s:?}")))?;
                let mut out = Vec::new();
                for part in inner.split(']') {
                    let part = part.trim().trim_start_matches(',').trim();
                    if part.is_empty() {
                        continue;
                    }
                    let nums = part.strip_prefix('[').ok_or_else(|| bad(format!("got {s:?}")))?;
                    let xy: Vec<f64> = nums.split(',').map(|t| t.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad(format!("got {s:?}")))?;
                    match xy[..] {
                        [x, y] => out.push([x, y]),
                        _ => return Err(bad(format!("got {s:?}"))),
                    }
                }
                out
            }
            Some(Value::List(l)) => l.iter().map(|v| pair(v).ok_or_else(|| bad(format!("found {v}")))).collect::<Result<_, _>>()?,
            Some(v) => return Err(bad(format!("got {v}"))),
        };
        Footprint::polygon(&vertices).map_err(core_error)
    }

    fn floats(&self, name: &str, default: Vec<f64>) -> Result<Vec<f64>, ParamError> {
        self.opt_floats(name, Some(default))?.ok_or_else(|| ParamError::new(name, "expects a list of numbers, got null"))
    }

    fn opt_floats(&self, name: &str, default: Option<Vec<f64>>) -> Result<Option<Vec<f64>>, ParamError> {
        match self.get(name) {
            None => Ok(default),
            Some(Value::None) => Ok(None),
            Some(Value::List(l)) => l
                .iter()
                .map(|v| match v {
                    Value::Float(x) => Ok(*x),
                    Value::Int(i) => Ok(*i as f64),
                    other => Err(ParamError::new(name, format!("expects a list of numbers, found {other}"))),
                })
                .collect::<Result<Vec<_>, _>>()
                .map(Some),
            Some(v) => Err(ParamError::new(name, format!("expects a list of numbers, got {v}"))),
        }
    }

    fn pair(&self, name: &str, default: [f64; 2]) -> Result<[f64; 2], ParamError> {
        let v = self.floats(name, default.to_vec())?;
        <[f64; 2]>::try_from(v.as_slice()).map_err(|_| ParamError::new(name, format!("expects 2 values, got {}", v.len())))
    }
}
