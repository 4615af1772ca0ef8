//! A scenario: static map, start (and goal), moving obstacles and the odometry faults.
//!
//! Scenarios come from the named presets ([`super::preset`]), the procedural generator, an
//! imported occupancy map, or a user's JSON file ([`Scenario::from_json_file`]):
//!
//! ```json
//! {
//!   "name": "my_corridor",
//!   "walls":    [{"a": [0, -1], "b": [20, -1], "height": 2.0}],
//!   "polygons": [{"vertices": [[5, 0.4], [5.6, 0.4], [5.6, 1], [5, 1]], "height": 0.8}],
//!   "start": {"x": 1, "y": 0, "yaw": 0},
//!   "goal":  {"x": 18, "y": 0, "yaw": 0},
//!   "obstacles": [{"name": "chair",
//!                  "shape": {"vertices": [[-0.25, -0.25], [0.25, -0.25], [0.25, 0.25], [-0.25, 0.25]], "height": 0.9},
//!                  "trajectory": {"keys": [[9.0, {"x": 9, "y": 0.5, "yaw": 0}], [11.0, {"x": 7.5, "y": 0.2, "yaw": 0}]]}}],
//!   "odometry": {"translation_noise": 0.0, "yaw_noise": 0.0, "yaw_bias": 0.0,
//!                "faults": [{"kind": "jump", "time": 20.0, "dx": 120.0, "dy": 0.0}]}
//! }
//! ```
//! Lengths in metres, angles in radians, times in seconds; `polygons`, `goal`, `obstacles` and
//! `odometry` may be left out; unknown keys are errors. Instead of `trajectory` an obstacle may
//! `chase`: `{"start": [x, y], "speed": 1.0, "start_time": 0.0}` (it steers at the robot,
//! see [`Chaser`]), or `walk`: `{"waypoints": [[x, y], ...], "speed": 1.2, "start_time": 0.0}` (a pedestrian at
//! 1–1.5 m/s, facing where it goes).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::geometry::{Polygon, Pose2, Segment};
use super::map::StaticMap;
use super::moving::{MovingObstacle, Trajectory, TIME_LIMIT};
use super::odometry::{OdometryConfig, OdometryFault};
use crate::error::{Error, Result};
use crate::math::Real;

/// How far from the origin (m) everything of a scenario may lie: walls, start, goal,
/// obstacles' shapes and key poses, odometry jumps (the physics runs in `f32`).
pub const COORDINATE_LIMIT: Real = 1.0e5;
/// The largest yaw (rad) of a scenario's poses and odometry yaw jumps.
pub const YAW_LIMIT: Real = 1.0e4;

/// The fastest chaser (m/s).
pub const MAX_CHASE_SPEED: Real = 10.0;

/// An obstacle that steers at the robot: each control period it moves straight toward the
/// robot's true position at `speed` (from `start_time` on), keeping its heading. It stands
/// for an adversary in the red team (`"chase": {"start": [x, y], "speed": 1.0}` in a file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Chaser {
    /// Index into [`Scenario::obstacles`].
    pub obstacle: usize,
    /// Speed (m/s).
    pub speed: Real,
    /// When it starts (s).
    pub start_time: Real,
}

/// Everything that defines an episode's world before any command is given.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scenario {
    /// A name for reports.
    pub name: String,
    /// Static walls and furniture.
    pub map: StaticMap,
    /// The robot's true start pose.
    pub start: Pose2,
    /// Where the mission wants the robot, if the scenario has a goal.
    pub goal: Option<Pose2>,
    /// Scripted moving obstacles.
    pub obstacles: Vec<MovingObstacle>,
    /// Obstacles that steer at the robot instead of following their trajectory.
    #[serde(default)]
    pub chasers: Vec<Chaser>,
    /// Odometry drift and faults.
    pub odometry: OdometryConfig,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioFile {
    name: Option<String>,
    walls: Vec<Segment>,
    #[serde(default)]
    polygons: Vec<Polygon>,
    start: Pose2,
    goal: Option<Pose2>,
    #[serde(default)]
    obstacles: Vec<ObstacleFile>,
    #[serde(default)]
    odometry: OdometryConfig,
}

/// An obstacle in the file: key poses, or a walk through waypoints at a speed.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObstacleFile {
    name: String,
    shape: Polygon,
    trajectory: Option<Trajectory>,
    walk: Option<WalkFile>,
    chase: Option<ChaseFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ChaseFile {
    start: [Real; 2],
    speed: Real,
    #[serde(default)]
    start_time: Real,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WalkFile {
    waypoints: Vec<[Real; 2]>,
    speed: Real,
    #[serde(default)]
    start_time: Real,
}

impl Scenario {
    /// A scenario with only a static map and a start pose.
    pub fn new(name: impl Into<String>, map: StaticMap, start: Pose2) -> Self {
        Self { name: name.into(), map, start, goal: None, obstacles: Vec::new(), chasers: Vec::new(), odometry: OdometryConfig::default() }
    }

    /// Checks every part; the error names the part at fault. Coordinates must lie within
    /// [`COORDINATE_LIMIT`] of the origin (the physics runs in `f32`), yaws within
    /// [`YAW_LIMIT`], script times within [`TIME_LIMIT`].
    pub fn validate(&self) -> Result<()> {
        let far = |p: [Real; 2]| p[0].abs() > COORDINATE_LIMIT || p[1].abs() > COORDINATE_LIMIT;
        for s in &self.map.segments {
            s.validate("walls")?;
            if far(s.a) || far(s.b) {
                return Err(Error::invalid("walls", format!("end points must be within {COORDINATE_LIMIT} m of the origin, got {s:?}")));
            }
        }
        for p in &self.map.polygons {
            p.validate("polygons")?;
            if p.vertices.iter().any(|&v| far(v)) {
                return Err(Error::invalid("polygons", format!("vertices must be within {COORDINATE_LIMIT} m of the origin, got {:?}", p.vertices)));
            }
        }
        let pose = |p: &Pose2, what: &'static str| {
            p.validate(what)?;
            if far([p.x, p.y]) || p.yaw.abs() > YAW_LIMIT {
                return Err(Error::invalid(what, format!("must be within {COORDINATE_LIMIT} m of the origin with |yaw| at most {YAW_LIMIT} rad, got {p:?}")));
            }
            Ok(())
        };
        pose(&self.start, "start")?;
        if let Some(g) = &self.goal {
            pose(g, "goal")?;
        }
        let time = |t: Real, what: &'static str| {
            if t.abs() > TIME_LIMIT {
                return Err(Error::invalid(what, format!("times must be within {TIME_LIMIT:?} s, got {t:?}")));
            }
            Ok(())
        };
        for c in &self.chasers {
            if c.obstacle >= self.obstacles.len() {
                return Err(Error::invalid("chase", format!("obstacle {} does not exist ({} obstacles)", c.obstacle, self.obstacles.len())));
            }
            if !(c.speed.is_finite() && c.speed > 0.0 && c.speed <= MAX_CHASE_SPEED) {
                return Err(Error::invalid("chase.speed", format!("must be in (0, {MAX_CHASE_SPEED}] m/s, got {}", c.speed)));
            }
            time(c.start_time, "chase.start_time")?;
        }
        for o in &self.obstacles {
            o.validate()?;
            if let Some(v) = o.shape.vertices.iter().find(|&&v| far(v)) {
                return Err(Error::invalid("obstacle.shape", format!("{}: vertices must be within {COORDINATE_LIMIT} m of its frame, got {v:?}", o.name)));
            }
            for (t, p) in &o.trajectory.keys {
                time(*t, "trajectory")?;
                pose(p, "trajectory")?;
            }
        }
        self.odometry.validate()?;
        for f in &self.odometry.faults {
            match *f {
                OdometryFault::Jump { time: t, dx, dy } => {
                    time(t, "odometry.faults")?;
                    if dx.abs() > COORDINATE_LIMIT || dy.abs() > COORDINATE_LIMIT {
                        return Err(Error::invalid("odometry.faults", format!("a jump must be within {COORDINATE_LIMIT:?} m, got ({dx:?}, {dy:?})")));
                    }
                }
                OdometryFault::YawJump { time: t, dyaw } => {
                    time(t, "odometry.faults")?;
                    if dyaw.abs() > YAW_LIMIT {
                        return Err(Error::invalid("odometry.faults", format!("a yaw jump must be within {YAW_LIMIT:?} rad, got {dyaw:?}")));
                    }
                }
                OdometryFault::Freeze { start, end } => {
                    time(start, "odometry.faults")?;
                    time(end, "odometry.faults")?;
                }
            }
        }
        Ok(())
    }

    /// Parses the JSON scenario format above; `path` only names the source in errors.
    pub fn from_json_str(text: &str, path: &str) -> Result<Self> {
        if let Some((k, line)) = text.lines().enumerate().find(|(_, l)| !l.trim().is_empty()) {
            if !line.trim_start().starts_with('{') {
                // (most often a YAML file: the ROS maps' own files are YAML)
                let shown: String = line.trim().chars().take(40).collect();
                return Err(Error::map_file(path, format!("line {}", k + 1), format!("a scenario file is one JSON object, `{{ ... }}` (docs/world.md, \"Scenario file\"), not `{shown}`")));
            }
        }
        let f: ScenarioFile = serde_json::from_str(text).map_err(|e| Error::map_file(path, format!("line {} column {}", e.line(), e.column()), e.to_string()))?;
        let mut map = StaticMap::new();
        for (i, w) in f.walls.into_iter().enumerate() {
            w.validate("walls").map_err(|e| Error::map_file(path, format!("walls[{i}]"), e.to_string()))?;
            map.segments.push(w);
        }
        for (i, p) in f.polygons.into_iter().enumerate() {
            map.add_polygon(p).map_err(|e| Error::map_file(path, format!("polygons[{i}]"), e.to_string()))?;
        }
        let mut obstacles = Vec::with_capacity(f.obstacles.len());
        let mut chasers = Vec::new();
        for (i, o) in f.obstacles.into_iter().enumerate() {
            let at = format!("obstacles[{i}]");
            let trajectory = match (o.trajectory, o.walk, o.chase) {
                (Some(t), None, None) => t,
                (None, Some(w), None) => Trajectory::walk(&w.waypoints, w.speed, w.start_time).map_err(|e| Error::map_file(path, format!("{at}.walk"), e.to_string()))?,
                (None, None, Some(c)) => {
                    chasers.push(Chaser { obstacle: i, speed: c.speed, start_time: c.start_time });
                    Trajectory::fixed(Pose2::new(c.start[0], c.start[1], 0.0))
                }
                _ => return Err(Error::map_file(path, at, "give exactly one of `trajectory`, `walk` and `chase`")),
            };
            obstacles.push(MovingObstacle { name: o.name, shape: o.shape, trajectory });
        }
        let sc = Scenario { name: f.name.unwrap_or_else(|| "scenario".into()), map, start: f.start, goal: f.goal, obstacles, chasers, odometry: f.odometry };
        sc.start.validate("start").map_err(|e| Error::map_file(path, "start", e.to_string()))?;
        for (i, o) in sc.obstacles.iter().enumerate() {
            o.validate().map_err(|e| Error::map_file(path, format!("obstacles[{i}]"), e.to_string()))?;
        }
        sc.validate().map_err(|e| Error::map_file(path, "scenario", e.to_string()))?;
        Ok(sc)
    }

    /// Reads a JSON scenario file.
    pub fn from_json_file(path: impl AsRef<Path>) -> Result<Self> {
        let p = path.as_ref();
        let text = std::fs::read_to_string(p).map_err(|e| Error::map_file(p, "file", e.to_string()))?;
        Self::from_json_str(&text, &p.display().to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC_EXAMPLE: &str = r#"{
      "name": "my_corridor",
      "walls":    [{"a": [0, -1], "b": [20, -1], "height": 2.0}],
      "polygons": [{"vertices": [[5, 0.4], [5.6, 0.4], [5.6, 1], [5, 1]], "height": 0.8}],
      "start": {"x": 1, "y": 0, "yaw": 0},
      "goal":  {"x": 18, "y": 0, "yaw": 0},
      "obstacles": [{"name": "chair",
                     "shape": {"vertices": [[-0.25, -0.25], [0.25, -0.25], [0.25, 0.25], [-0.25, 0.25]], "height": 0.9},
                     "trajectory": {"keys": [[9.0, {"x": 9, "y": 0.5, "yaw": 0}], [11.0, {"x": 7.5, "y": 0.2, "yaw": 0}]]}}],
      "odometry": {"translation_noise": 0.0, "yaw_noise": 0.0, "yaw_bias": 0.0,
                   "faults": [{"kind": "jump", "time": 20.0, "dx": 120.0, "dy": 0.0}]}
    }"#;

    #[test]
    fn documented_example_parses() {
        let s = Scenario::from_json_str(DOC_EXAMPLE, "doc.json").unwrap();
        assert_eq!(s.map.segments.len(), 5);
        assert_eq!(s.obstacles[0].name, "chair");
        assert_eq!(s.odometry.faults.len(), 1);
    }

    #[test]
    fn syntax_error_names_file_and_line() {
        let err = Scenario::from_json_str("{\n \"walls\": [,\n}", "bad.json").unwrap_err().to_string();
        assert!(err.starts_with("bad.json: line 2"), "{err}");
    }

    #[test]
    fn yaml_is_named_as_not_json() {
        let err = Scenario::from_json_str("\n# my corridor\nwalls:\n  - {a: [0, 0], b: [1, 0]}\n", "s.yaml").unwrap_err().to_string();
        assert!(err.starts_with("s.yaml: line 2") && err.contains("one JSON object") && err.contains("`# my corridor`"), "{err}");
    }

    #[test]
    fn bad_wall_names_its_index() {
        let text = r#"{"walls": [{"a": [0, 0], "b": [1, 0], "height": 1}, {"a": [0, 0], "b": [0, 0], "height": 1}],
                       "start": {"x": 0, "y": 0, "yaw": 0}}"#;
        let err = Scenario::from_json_str(text, "w.json").unwrap_err().to_string();
        assert!(err.contains("w.json: walls[1]"), "{err}");
    }

    #[test]
    fn pedestrian_walks_at_its_speed() {
        let text = r#"{"walls": [], "start": {"x": 0, "y": 0, "yaw": 0},
            "obstacles": [{"name": "pedestrian", "shape": {"vertices": [[-0.2, -0.25], [0.2, -0.25], [0.2, 0.25], [-0.2, 0.25]], "height": 1.8},
                           "walk": {"waypoints": [[10, 0.3], [2, 0.3]], "speed": 1.25, "start_time": 1.0}}]}"#;
        let s = Scenario::from_json_str(text, "p.json").unwrap();
        let p = s.obstacles[0].trajectory.pose_at(3.0);
        assert!((p.x - (10.0 - 2.0 * 1.25)).abs() < 1e-12 && (p.yaw - std::f64::consts::PI).abs() < 1e-12);
        let bad = text.replace("1.25", "-1");
        assert!(Scenario::from_json_str(&bad, "p.json").unwrap_err().to_string().contains("obstacles[0].walk"));
    }

    #[test]
    fn far_away_start_is_an_error() {
        let text = r#"{"walls": [], "start": {"x": 1e9, "y": 0, "yaw": 0}}"#;
        assert!(Scenario::from_json_str(text, "f.json").unwrap_err().to_string().contains("start"));
    }

    /// Every coordinate, yaw and script time of a scenario is bounded, not only the walls'
    /// and the start's position (a goal at 1e7 m, a key pose at 1e9, a jump of 1e300 were
    /// accepted; a start yaw of 1e300 failed later as "yaw: NaN" naming no file).
    #[test]
    fn far_or_huge_values_anywhere_name_the_file_and_the_part() {
        let wall = r#""walls": [{"a": [0, -1], "b": [20, -1], "height": 2.0}]"#;
        let tri = r#""shape": {"vertices": [[0, 0], [1, 0], [1, 1]], "height": 1}"#;
        let odo = r#""translation_noise": 0.0, "yaw_noise": 0.0, "yaw_bias": 0.0"#;
        let cases = [
            (format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 1e300}}}}"#), "`start`"),
            (format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "goal": {{"x": 1e7, "y": 0, "yaw": 0}}}}"#), "`goal`"),
            (format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "obstacles": [{{"name": "c", {tri}, "trajectory": {{"keys": [[0.0, {{"x": 1e9, "y": 0, "yaw": 0}}]]}}}}]}}"#), "`trajectory`"),
            (format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "obstacles": [{{"name": "c", {tri}, "trajectory": {{"keys": [[1e300, {{"x": 1, "y": 0, "yaw": 0}}]]}}}}]}}"#), "`trajectory`"),
            (format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "obstacles": [{{"name": "p", {tri}, "walk": {{"waypoints": [[1e9, 0], [2, 0]], "speed": 1.0}}}}]}}"#), "`trajectory`"),
            (
                format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "obstacles": [{{"name": "p", {tri}, "walk": {{"waypoints": [[5, 0], [2, 0]], "speed": 1.0, "start_time": 1e308}}}}]}}"#),
                "`start_time`",
            ),
            (
                format!(
                    r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "obstacles": [{{"name": "v", "shape": {{"vertices": [[0, 0], [1e9, 0], [1, 1]], "height": 1}}, "trajectory": {{"keys": [[0.0, {{"x": 1, "y": 0, "yaw": 0}}]]}}}}]}}"#
                ),
                "`obstacle.shape`",
            ),
            (format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "odometry": {{{odo}, "faults": [{{"kind": "jump", "time": 1.0, "dx": 1e300, "dy": 0.0}}]}}}}"#), "`odometry.faults`"),
            (format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "odometry": {{{odo}, "faults": [{{"kind": "yaw_jump", "time": 1.0, "dyaw": 1e9}}]}}}}"#), "`odometry.faults`"),
        ];
        for (text, part) in cases {
            let err = Scenario::from_json_str(&text, "mine.json").unwrap_err().to_string();
            assert!(err.starts_with("mine.json: ") && err.contains(part), "{err}");
        }
        // the paper's jump of 100 m is well within
        let ok = format!(r#"{{{wall}, "start": {{"x": 2, "y": 0, "yaw": 0}}, "odometry": {{{odo}, "faults": [{{"kind": "jump", "time": 20.0, "dx": 100.0, "dy": 1.5}}]}}}}"#);
        Scenario::from_json_str(&ok, "mine.json").unwrap();
    }

    /// Unknown keys anywhere are errors naming them (in walls, poses, shapes, trajectories,
    /// the odometry and its faults they were ignored: a misspelt `one_sided` left a wall
    /// two-sided); a crossed polygon and a non-convex obstacle too.
    #[test]
    fn unknown_keys_at_any_depth_and_bad_shapes_are_errors() {
        let base = DOC_EXAMPLE.to_string();
        for (from, to, key) in [
            (r#""height": 2.0}]"#, r#""height": 2.0, "one_sidd": true}]"#, "one_sidd"),
            (r#""start": {"x": 1, "y": 0, "yaw": 0}"#, r#""start": {"x": 1, "y": 0, "yaw": 0, "theta": 1}"#, "theta"),
            (r#""height": 0.8}"#, r#""height": 0.8, "colour": "red"}"#, "colour"),
            (r#""trajectory": {"keys""#, r#""trajectory": {"loop": true, "keys""#, "loop"),
            (r#"[9.0, {"x": 9, "y": 0.5, "yaw": 0}]"#, r#"[9.0, {"x": 9, "y": 0.5, "yaw": 0, "z": 1}]"#, "`z`"),
            (r#""yaw_bias": 0.0,"#, r#""yaw_bias": 0.0, "drift": 1,"#, "drift"),
            (r#""dx": 120.0, "dy": 0.0}"#, r#""dx": 120.0, "dy": 0.0, "dyaw": 0.3}"#, "dyaw"),
        ] {
            assert!(base.contains(from), "{from}");
            let err = Scenario::from_json_str(&base.replacen(from, to, 1), "k.json").unwrap_err().to_string();
            assert!(err.starts_with("k.json: ") && err.contains(key), "{key}: {err}");
        }
        let crossed = base.replace("[[5, 0.4], [5.6, 0.4], [5.6, 1], [5, 1]]", "[[5, 0.4], [5.6, 1], [5.6, 0.4], [5, 1]]");
        let err = Scenario::from_json_str(&crossed, "k.json").unwrap_err().to_string();
        assert!(err.contains("polygons[0]") && err.contains("simple polygon"), "{err}");
        let notch = base.replace("[[-0.25, -0.25], [0.25, -0.25], [0.25, 0.25], [-0.25, 0.25]]", "[[-0.25, -0.25], [0.25, -0.25], [0.25, 0.25], [0.0, 0.0], [-0.25, 0.25]]");
        let err = Scenario::from_json_str(&notch, "k.json").unwrap_err().to_string();
        assert!(err.contains("obstacles[0]") && err.contains("must be convex"), "{err}");
    }

    #[test]
    fn unknown_key_is_an_error() {
        let text = r#"{"walls": [], "start": {"x": 0, "y": 0, "yaw": 0}, "colour": "red"}"#;
        assert!(Scenario::from_json_str(text, "k.json").unwrap_err().to_string().contains("colour"));
    }
}
