//! One running world: the scenario's walls and scripted obstacles, the robot body and tracker,
//! the LIDAR (looking from the true pose) and the odometry (what planners see), all driven by
//! one seeded RNG.
//!
//! ```
//! use shieldnav_core::sim::{World, WorldConfig};
//! let mut w = World::from_preset("dynamic_obstacles", WorldConfig::default()).unwrap();
//! let out = w.step([0.5, 0.0, 0.0]).unwrap();
//! assert!(out.true_pose.x > 1.0 && !out.contacts.any());
//! assert_eq!(w.scan().ranges.len(), 1024);
//! ```

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::error::{Error, Result};
use crate::math::Real;
use crate::robot::{footprint_segment_distance, ContactReport, PhysicsScene, RobotShape, Tracker, TrackerConfig};
use crate::sensors::{Lidar, LidarConfig, Odometry, Scan, ScanMesh};
use crate::world::generate::{generate, GeneratorConfig};
use crate::world::index::SegmentIndex;
use crate::world::{load_ros_map, preset, wrap_angle, Pose2, RosMapOptions, Scenario, Segment};

/// Distance (m) within which [`World::clearance`] first searches the wall index.
pub const CLEARANCE_SEARCH: Real = 2.0;
/// How far (m) footprint points may move before [`World::clearance`] searches the index again.
pub const CLEARANCE_BUDGET: Real = 0.25;

/// Margin (m) by which the clearance must exceed how far robot and obstacles can close in
/// during a step for the step to skip the contact solver (far above rapier's 2 mm contact
/// prediction and the 1 mm contact tolerance).
pub const FREE_STEP_MARGIN: Real = 0.05;

/// Worlds of at most this many walls are scanned by sweeping every wall ([`Lidar::scan_into`]),
/// bigger ones through their bucket index ([`Lidar::scan_indexed_into`]) or, planar scans, by
/// walking a triangulation of their walls (see [`SCAN_PROBE_EVERY`]); the ranges are the
/// same. Measured from a robot pacing near the start: the presets and generated sites (16–96
/// walls) 2.5–3.2 µs sweeping all against 2.6–4.8 µs indexed; the 200-wall world 14.1 against
/// 9.7 µs (walls two-sided), 8.8 against 8.4 µs (furniture solid).
pub const SCAN_ALL_WALLS_MAX: usize = 128;

/// Bigger worlds' planar scans go through the bucket index or walk a triangulation of the
/// walls ([`Lidar::scan_mesh_into`]), the same ranges either way, whichever has lately been
/// faster on this machine: each scan's time is kept as a running mean per way, the faster
/// way taken, and the other tried this many scans later. A try that finds the other way
/// still [`SCAN_PROBE_SLOWER`] times slower or more doubles the wait for the next (up to
/// [`SCAN_PROBE_MAX`] scans); one that finds it nearer starts again from this many, and so
/// does the way taken turning [`SCAN_PROBE_SLOWER`] times slower than at the last try (the
/// other is then tried at once). (The walk reads only what the sensor sees, and wins where it
/// sees far across clutter; the index wins where most walls in range are near.)
pub const SCAN_PROBE_EVERY: u64 = 32;
/// The most scans between two tries of the slower way (see [`SCAN_PROBE_EVERY`]): at a 10 Hz
/// scan rate, 25.6 s.
pub const SCAN_PROBE_MAX: u64 = 256;
/// How much slower the other way must stay for the tries to thin out (see
/// [`SCAN_PROBE_EVERY`]).
pub const SCAN_PROBE_SLOWER: f64 = 1.25;

/// The running mean time of each way to scan a big world (see [`SCAN_PROBE_EVERY`]).
#[derive(Debug, Clone, Copy, Default)]
struct ScanChoice {
    /// Nanoseconds per scan, through the index and by the walk (0: not yet timed).
    ns: [f64; 2],
    scans: u64,
    /// Scans between tries of the slower way, the scan of the next try (0: not set), and the
    /// mean time of the way taken after the last try.
    every: u64,
    next_try: u64,
    at_try: f64,
}

impl ScanChoice {
    /// Whether the next scan walks the triangulation.
    fn walk(&self) -> bool {
        match self.scans {
            0 | 1 => self.scans == 1,
            k => (self.ns[1] < self.ns[0]) != (k == self.next_try),
        }
    }

    fn record(&mut self, walked: bool, ns: f64) {
        let tried = self.scans >= 2 && self.scans == self.next_try;
        let m = &mut self.ns[walked as usize];
        *m = if *m == 0.0 { ns } else { 0.75 * *m + 0.25 * ns };
        if self.scans == 1 || tried {
            // (after the second scan, each way timed once, and after each try)
            let (tried_ns, other) = (self.ns[walked as usize], self.ns[!walked as usize]);
            self.every = if tried && tried_ns >= SCAN_PROBE_SLOWER * other { (2 * self.every).min(SCAN_PROBE_MAX) } else { SCAN_PROBE_EVERY };
            self.next_try = self.scans + self.every;
            self.at_try = self.ns[0].min(self.ns[1]);
        } else if self.scans >= 2 && self.ns[walked as usize] > SCAN_PROBE_SLOWER * self.at_try && self.next_try > self.scans + 1 {
            // the way taken turned slower: the other tried next
            (self.every, self.next_try) = (SCAN_PROBE_EVERY, self.scans + 1);
        }
        self.scans += 1;
    }
}

/// Everything about a world that is not the scenario.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldConfig {
    /// The robot's true footprint.
    pub robot: RobotShape,
    /// Its low-level tracker.
    pub tracker: TrackerConfig,
    /// The LIDAR.
    pub lidar: LidarConfig,
    /// Control period (s): one [`World::step`].
    pub dt: Real,
    /// Seed of the world's RNG (LIDAR noise and dropout, odometry noise).
    pub seed: u64,
}

impl Default for WorldConfig {
    fn default() -> Self {
        Self { robot: RobotShape::default(), tracker: TrackerConfig::default(), lidar: LidarConfig::default(), dt: 0.02, seed: 0 }
    }
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOutcome {
    /// World time after the step (s).
    pub time: Real,
    /// The robot's true pose.
    pub true_pose: Pose2,
    /// The odometry estimate.
    pub estimated_pose: Pose2,
    /// The robot's body-frame velocity `(vx, vy, ω)` achieved in the step: the tracker's,
    /// unless contacts stopped or pushed the body (see [`PhysicsScene::achieved_velocity`]).
    pub velocity: [Real; 3],
    /// Contacts of the true footprint after the step.
    pub contacts: ContactReport,
    /// Whether a new LIDAR scan was taken in this step.
    pub scanned: bool,
    /// Whether the command exceeded the tracker's limits.
    pub saturated: bool,
}

/// A running world.
#[derive(Debug)]
pub struct World {
    scenario: Scenario,
    config: WorldConfig,
    physics: PhysicsScene,
    tracker: Tracker,
    lidar: Lidar,
    odometry: Odometry,
    rng: ChaCha8Rng,
    time: Real,
    /// Control periods stepped (the time is `steps · dt`).
    steps: u64,
    next_scan: Real,
    scan: Scan,
    scan_body_pose: Pose2,
    index: SegmentIndex,
    /// The walls triangulated for planar scans of big worlds (see [`SCAN_PROBE_EVERY`]);
    /// shared with the worlds of the same walls made by [`World::renew`].
    mesh: Option<Arc<ScanMesh>>,
    choice: ScanChoice,
    near: Vec<Segment>,
    /// Squared distances from the robot's centre to `near`.
    near_c2: Vec<Real>,
    /// The walls that can be the nearest while the robot stays within the clearance budget
    /// of `clearance_anchor` (see [`World::clearance`]).
    clearance_kept: Vec<Segment>,
    clearance_anchor: Option<Pose2>,
    /// `(time, pose, clearance)` of the latest [`World::clearance`].
    measured: Option<(Real, Pose2, Real)>,
    /// Steps that skipped the contact solver (see [`World::free_steps`]).
    free_steps: u64,
    moving_now: Vec<Segment>,
    moving: Vec<Segment>,
    contacts: ContactReport,
}

impl World {
    /// Builds a world from a scenario.
    pub fn new(scenario: Scenario, config: WorldConfig) -> Result<Self> {
        Self::build(scenario, config, None)
    }

    /// A world like [`World::new`], sharing this world's triangulation of the walls when
    /// `scenario` has the same walls and the LIDAR is planar (an episode's reset on the same
    /// map: the triangulation of a real map takes milliseconds to build).
    pub fn renew(&self, scenario: Scenario, config: WorldConfig) -> Result<Self> {
        let same = self.mesh.is_some() && config.lidar.channels == 1 && scenario.map.segments == self.scenario.map.segments;
        Self::build(scenario, config, if same { self.mesh.clone() } else { None })
    }

    fn build(scenario: Scenario, config: WorldConfig, mesh: Option<Arc<ScanMesh>>) -> Result<Self> {
        scenario.validate()?;
        config.robot.validate()?;
        crate::robot::check_start(&config.robot, &scenario)?;
        if !(config.dt.is_finite() && config.dt > 0.0 && config.dt <= 0.1) {
            return Err(Error::invalid("dt", format!("must be in (0, 0.1] s, got {}", config.dt)));
        }
        let lidar = Lidar::new(config.lidar)?;
        // (scans are taken at control steps: a faster rate would be capped silently)
        config.lidar.check_rate(config.dt)?;
        let tracker = Tracker::new(config.tracker)?;
        let physics = PhysicsScene::new(config.robot, &scenario.map.segments, &scenario.obstacles, scenario.start, 0.0)?;
        let odometry = Odometry::new(scenario.odometry.clone(), scenario.start, 0.0)?;
        let index = SegmentIndex::new(scenario.map.segments.clone(), 2.0)?;
        // (a failed triangulation leaves the index alone)
        let big_planar = scenario.map.segments.len() > SCAN_ALL_WALLS_MAX && config.lidar.channels == 1;
        let mesh = if !big_planar { None } else { mesh.or_else(|| ScanMesh::new(&scenario.map.segments).ok().map(Arc::new)) };
        let mut w = Self {
            scenario,
            config,
            physics,
            tracker,
            lidar,
            odometry,
            rng: ChaCha8Rng::seed_from_u64(config.seed),
            time: 0.0,
            steps: 0,
            next_scan: 0.0,
            scan: Scan::default(),
            scan_body_pose: Pose2::default(),
            index,
            mesh,
            choice: ScanChoice::default(),
            near: Vec::new(),
            near_c2: Vec::new(),
            clearance_kept: Vec::new(),
            clearance_anchor: None,
            measured: None,
            free_steps: 0,
            moving_now: Vec::new(),
            moving: Vec::new(),
            contacts: ContactReport::default(),
        };
        w.take_scan()?;
        Ok(w)
    }

    /// A world of the named preset (see [`crate::world::preset()`]).
    pub fn from_preset(name: &str, config: WorldConfig) -> Result<Self> {
        Self::new(preset(name)?, config)
    }

    /// A world of the procedural site of `site_seed`.
    pub fn from_procedural(site_seed: u64, generator: &GeneratorConfig, config: WorldConfig) -> Result<Self> {
        Self::new(generate(site_seed, generator)?.scenario, config)
    }

    /// A world of a ROS map_server map, starting at its interior start.
    pub fn from_ros_map(yaml: impl AsRef<Path>, options: &RosMapOptions, config: WorldConfig) -> Result<Self> {
        Self::new(load_ros_map(yaml, options)?.scenario, config)
    }

    /// A world of a JSON scenario file (see [`Scenario`]).
    pub fn from_scenario_file(path: impl AsRef<Path>, config: WorldConfig) -> Result<Self> {
        Self::new(Scenario::from_json_file(path)?, config)
    }

    fn take_scan(&mut self) -> Result<()> {
        let pose = self.physics.robot_pose();
        self.moving.clear();
        for o in &self.scenario.obstacles {
            o.segments_at(self.time, &mut self.moving);
        }
        // the same ranges either way (tested); sweeping every wall is faster on small worlds
        if self.index.segments().len() <= SCAN_ALL_WALLS_MAX {
            self.lidar.scan_into(&[self.index.segments(), &self.moving], pose, self.time, &mut self.rng, &mut self.scan)?;
        } else if let Some(mesh) = self.mesh.as_deref() {
            let walk = self.choice.walk();
            let t = Instant::now();
            if walk {
                self.lidar.scan_mesh_into(mesh, &self.index, &self.moving, pose, self.time, &mut self.rng, &mut self.scan)?;
            } else {
                self.lidar.scan_indexed_into(&self.index, &self.moving, pose, self.time, &mut self.rng, &mut self.scan)?;
            }
            self.choice.record(walk, t.elapsed().as_nanos() as f64);
        } else {
            self.lidar.scan_indexed_into(&self.index, &self.moving, pose, self.time, &mut self.rng, &mut self.scan)?;
        }
        self.scan_body_pose = pose;
        self.next_scan += self.lidar.period();
        Ok(())
    }

    /// Advances one control period with the body-frame command `(vx, vy, ω)` (m/s, m/s,
    /// rad/s). A scan is taken whenever the LIDAR's period has elapsed.
    pub fn step(&mut self, command: [Real; 3]) -> Result<StepOutcome> {
        let dt = self.config.dt;
        self.steer_chasers(dt);
        let tr = self.tracker.step(command, dt)?;
        // (the steps times dt, not a running sum: 1 000 steps of 0.02 s added up to 19.99999…,
        // and what is scheduled at 20 s came a step late)
        let t_next = (self.steps + 1) as Real * dt;
        self.contacts = if self.free_step(tr.velocity, dt, t_next) {
            self.free_steps += 1;
            self.physics.step_free(tr.velocity, dt, &self.scenario.obstacles, t_next)?
        } else {
            self.physics.step(tr.velocity, dt, &self.scenario.obstacles, t_next)?
        };
        // the tracker goes on from the velocity the body achieved (a wall or an obstacle may
        // have stopped or pushed it), so that its acceleration limits hold from the real
        // velocity and the velocity reported is the body's
        let velocity = self.physics.achieved_velocity();
        self.tracker.set_velocity(velocity);
        self.time = t_next;
        self.steps += 1;
        let true_pose = self.physics.robot_pose();
        let estimated_pose = self.odometry.update(self.time, true_pose, &mut self.rng);
        let scanned = self.time >= self.next_scan - 1e-9;
        if scanned {
            self.take_scan()?;
        }
        Ok(StepOutcome { time: self.time, true_pose, estimated_pose, velocity, contacts: self.contacts, scanned, saturated: tr.saturated })
    }

    /// Each chaser's key pose for the coming step: straight toward the robot's position by
    /// `speed · dt` (at most the distance), heading kept.
    fn steer_chasers(&mut self, dt: Real) {
        let robot = self.physics.robot_pose();
        let t_next = (self.steps + 1) as Real * dt;
        for c in &self.scenario.chasers {
            if t_next <= c.start_time {
                continue;
            }
            let tr = &mut self.scenario.obstacles[c.obstacle].trajectory;
            let p = tr.pose_at(self.time);
            let (dx, dy) = (robot.x - p.x, robot.y - p.y);
            let d = dx.hypot(dy);
            let s = if d > 1e-9 { (c.speed * dt).min(d) / d } else { 0.0 };
            if tr.keys.last().is_some_and(|(t, _)| *t < t_next) {
                tr.keys.push((t_next, Pose2::new(p.x + s * dx, p.y + s * dy, p.yaw)));
            }
        }
    }

    /// The latest scan.
    pub fn scan(&self) -> &Scan {
        &self.scan
    }

    /// The robot's true pose when the latest scan was taken (the scan's points are in this
    /// body frame).
    pub fn scan_body_pose(&self) -> Pose2 {
        self.scan_body_pose
    }

    /// The LIDAR.
    pub fn lidar(&self) -> &Lidar {
        &self.lidar
    }

    /// The true clearance (m): the distance from the robot's footprint to the nearest wall or
    /// moving obstacle, 0 in contact. Exact.
    ///
    /// Static walls: the wall index is searched within [`CLEARANCE_SEARCH`] of the footprint,
    /// then within twice that, and so on, until a wall lies inside the searched radius (or
    /// every wall has been measured). The walls that can become the nearest while the robot
    /// moves by a budget `B` ([`CLEARANCE_BUDGET`]: translation plus half diagonal × rotation,
    /// which bounds how far any footprint point moves) are kept: at most `d + 2B` away when
    /// the search found `d`. Until the budget is spent only those are measured; any other
    /// wall is then farther than `d + B`, and the kept nearest one nearer.
    ///
    /// The clearance also lets the next step skip the contact solver when nothing can touch
    /// the robot during it (see [`World::free_steps`]).
    pub fn clearance(&mut self) -> Real {
        let c = self.measure_clearance();
        self.measured = Some((self.time, self.physics.robot_pose(), c));
        c
    }

    /// How many steps skipped rapier's contact solver: a step right after [`World::clearance`]
    /// whose clearance exceeds how far robot and obstacles can close in (plus
    /// [`FREE_STEP_MARGIN`]) flies the robot free and moves the obstacles, as the solver
    /// would with no contact to resolve (to `f32` rounding, about 2e-7 m).
    pub fn free_steps(&self) -> u64 {
        self.free_steps
    }

    /// Whether the coming step of `dt` (body velocity `velocity`) can skip the contact
    /// solver: the clearance was measured at this time and pose, and exceeds how far the
    /// robot (translation plus half diagonal × turn) and the nearest-closing obstacle can move
    /// toward each other, plus [`FREE_STEP_MARGIN`]. Nothing can then touch the robot during
    /// the step, and free flight is what the solver would do.
    fn free_step(&self, velocity: [Real; 3], dt: Real, t_next: Real) -> bool {
        let Some((t, pose, clearance)) = self.measured else { return false };
        if t != self.time || pose != self.physics.robot_pose() {
            return false;
        }
        let shape = self.config.robot;
        let robot = shape.step_reach(velocity, dt);
        let obstacles = self.scenario.obstacles.iter().map(|o| o.max_travel(self.time, t_next)).fold(0.0, Real::max);
        clearance > robot + obstacles + FREE_STEP_MARGIN
    }

    fn measure_clearance(&mut self) -> Real {
        let pose = self.physics.robot_pose();
        let shape = self.config.robot;
        let half_diagonal = shape.half_diagonal();
        let moving = {
            self.moving_now.clear();
            for o in &self.scenario.obstacles {
                o.segments_at(self.time, &mut self.moving_now);
            }
            self.moving_now.iter().map(|s| footprint_segment_distance(&shape, pose, s)).fold(Real::INFINITY, Real::min)
        };
        if let Some(anchor) = self.clearance_anchor {
            let (dx, dy) = (pose.x - anchor.x, pose.y - anchor.y);
            let moved = (dx * dx + dy * dy).sqrt() + half_diagonal * wrap_angle(pose.yaw - anchor.yaw).abs();
            if moved <= CLEARANCE_BUDGET {
                return pruned_footprint_distance(&shape, pose, &self.clearance_kept, &mut self.near_c2).min(moving);
            }
        }
        let centre = [pose.x, pose.y];
        let mut radius = CLEARANCE_SEARCH;
        loop {
            // walls up to `2B` beyond the answer are kept, so the query reaches that far too
            self.index.query_into(centre, half_diagonal + radius + 2.0 * CLEARANCE_BUDGET, &mut self.near);
            let d = pruned_footprint_distance(&shape, pose, &self.near, &mut self.near_c2);
            let everything = self.near.len() == self.index.segments().len();
            if d <= radius || everything {
                // keep every wall that may lie within `d + 2B` of the footprint
                let keep = d + 2.0 * CLEARANCE_BUDGET + half_diagonal;
                self.clearance_kept.clear();
                self.clearance_kept.extend(self.near.iter().zip(&self.near_c2).filter(|(_, &c2)| c2 < keep * keep).map(|(s, _)| *s));
                // exact while searched: `near` holds every wall within `half_diagonal + radius
                // + 2B ≥ keep` of the centre (or every wall)
                self.clearance_anchor = Some(pose);
                return d.min(moving);
            }
            radius *= 2.0;
        }
    }

    /// World time (s).
    pub fn time(&self) -> Real {
        self.time
    }

    /// The robot's true pose.
    pub fn true_pose(&self) -> Pose2 {
        self.physics.robot_pose()
    }

    /// The odometry estimate.
    pub fn estimated_pose(&self) -> Pose2 {
        self.odometry.estimate()
    }

    /// Contacts after the last step.
    pub fn contacts(&self) -> ContactReport {
        self.contacts
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The configuration.
    pub fn config(&self) -> &WorldConfig {
        &self.config
    }

    /// Every wall now: static walls and the moving obstacles' outlines at the current time.
    pub fn walls_now(&self) -> Vec<Segment> {
        let mut v = self.scenario.map.segments.clone();
        for o in &self.scenario.obstacles {
            o.segments_at(self.time, &mut v);
        }
        v
    }
}

/// The least distance from the footprint `shape` at `pose` to `walls` (∞ for none), with each
/// wall's squared centre distance left in `c2`.
///
/// The footprint holds the disc of radius `inner` (half its smaller side) about its centre and
/// lies inside the one of radius `half_diagonal`; with `c` the centre's distance to a wall,
/// the footprint's is in [c − half_diagonal, c − inner]. So the nearest centre distance bounds
/// the answer from above, and only walls whose centre distance is below that bound plus
/// `half_diagonal − inner` need the exact footprint test (compared squared: no root).
fn pruned_footprint_distance(shape: &RobotShape, pose: Pose2, walls: &[Segment], c2: &mut Vec<Real>) -> Real {
    let half_diagonal = shape.half_diagonal();
    let inner = 0.5 * shape.length.min(shape.width);
    let centre = [pose.x, pose.y];
    c2.clear();
    c2.extend(walls.iter().map(|s| s.distance2_to_point(centre)));
    let limit = c2.iter().fold(Real::INFINITY, |m, &x| m.min(x)).sqrt() - inner + half_diagonal;
    walls.iter().zip(c2.iter()).filter(|(_, &x)| x < limit * limit).map(|(s, _)| footprint_segment_distance(shape, pose, s)).fold(Real::INFINITY, Real::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A world's renewal with the same walls shares its triangulation, and scans as a world
    /// built anew; other walls get their own.
    #[test]
    fn a_renewed_world_shares_the_triangulation_of_the_same_walls() {
        let mut scenario = preset("constricted_passage").unwrap();
        for k in 0..40 {
            let (x, y) = (2.0 * (k % 10) as Real, 40.0 + 2.0 * (k / 10) as Real);
            let c = [[x, y], [x + 1.0, y], [x + 1.0, y + 1.0], [x, y + 1.0]];
            for i in 0..4 {
                scenario.map.segments.push(Segment::one_sided(c[i], c[(i + 1) % 4], 2.0));
            }
        }
        assert!(scenario.map.segments.len() > SCAN_ALL_WALLS_MAX);
        let config = WorldConfig::default();
        let w = World::new(scenario.clone(), config).unwrap();
        let mesh = w.mesh.clone().expect("a triangulation of the walls");
        let again = w.renew(scenario.clone(), config).unwrap();
        assert!(Arc::ptr_eq(&mesh, again.mesh.as_ref().unwrap()));
        // (the first scans go through the index, the second ones walk: see `ScanChoice`)
        let (mut a, mut b) = (again, World::new(scenario.clone(), config).unwrap());
        for _ in 0..40 {
            a.step([0.4, 0.0, 0.2]).unwrap();
            b.step([0.4, 0.0, 0.2]).unwrap();
            assert_eq!(a.scan().ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>(), b.scan().ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>());
        }
        assert!(a.choice.scans >= 3, "{:?}", a.choice);
        scenario.map.segments.pop();
        let other = w.renew(scenario, config).unwrap();
        assert!(!Arc::ptr_eq(&mesh, other.mesh.as_ref().unwrap()));
    }

    /// The scans at which `ways` (one per scan, whether it walked) took the way that is not
    /// the one most of `range` took.
    fn tries(ways: &[bool], range: std::ops::Range<usize>) -> Vec<usize> {
        let walked = ways[range.clone()].iter().filter(|&&w| w).count();
        let most = 2 * walked > range.len();
        range.filter(|&k| ways[k] != most).collect()
    }

    /// Each way is timed once first, then the faster is taken but for a try of the other
    /// [`SCAN_PROBE_EVERY`] scans later; while the other stays [`SCAN_PROBE_SLOWER`] times
    /// slower the tries thin out, doubling the wait up to [`SCAN_PROBE_MAX`]; a way that
    /// turns slower is left at once, and the tries start again from the shortest wait.
    #[test]
    fn the_faster_way_to_scan_is_taken_and_the_other_tried_ever_less_often() {
        let mut c = ScanChoice::default();
        let mut ways = Vec::new();
        let switch = 3000;
        for k in 0..6000 {
            let walk = c.walk();
            ways.push(walk);
            // the walk takes 10 µs, the index 20 µs, until the switch, then the other way round
            let fast = if k < switch { walk } else { !walk };
            c.record(walk, if fast { 10_000.0 } else { 20_000.0 });
        }
        assert_eq!((ways[0], ways[1]), (false, true));
        assert!(ways[2..switch].iter().filter(|&&w| w).count() > switch - 2 - 20);
        // tries of the index 32, 64, 128, 256, 256, ... scans apart
        let t = tries(&ways, 2..switch);
        let gaps: Vec<usize> = std::iter::once(t[0] - 1).chain(t.windows(2).map(|w| w[1] - w[0])).collect();
        assert_eq!(&gaps[..6], &[32, 64, 128, 256, 256, 256], "{t:?}");
        assert!(gaps.iter().all(|&g| g <= SCAN_PROBE_MAX as usize));
        // after the switch the walk's mean rises: the index is tried within two scans, and
        // taken from the first try after which its mean is the lesser (the means move a
        // quarter of the way to each new time); then tries of the walk, again from 32 apart
        assert!(!ways[switch + 2], "{:?}", &ways[switch..switch + 8]);
        let taken = (switch..6000).find(|&k| !ways[k] && !ways[k + 1]).unwrap();
        assert!(taken - switch <= 2 + 32 + 1, "{taken}");
        let t = tries(&ways, taken..6000);
        let gaps: Vec<usize> = t.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!(&gaps[..4], &[64, 128, 256, 256], "{t:?}");
        assert!(t[0] - taken <= 32, "{taken} {t:?}");
    }

    /// A try that finds the other way about as fast keeps the tries at the shortest wait.
    #[test]
    fn ways_about_as_fast_are_tried_every_few_scans() {
        let mut c = ScanChoice::default();
        let mut ways = Vec::new();
        for _ in 0..1000 {
            let walk = c.walk();
            ways.push(walk);
            c.record(walk, if walk { 10_000.0 } else { 11_000.0 });
        }
        let t = tries(&ways, 2..1000);
        assert!(t.windows(2).all(|w| w[1] - w[0] == SCAN_PROBE_EVERY as usize), "{t:?}");
        assert_eq!(t.len(), (1000 - 2) / SCAN_PROBE_EVERY as usize);
    }
}
