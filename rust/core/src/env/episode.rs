//! One episode of corridor inspection: the step pipeline, reward, metrics.

use super::action::{nominal_command, ActionMode};
use super::coverage::{Coverage, CoverageConfig};
use super::deadlock::{DeadlockConfig, DeadlockMonitor};
use super::observation::{bin_ranges, ObservationConfig};
use crate::control::{NominalController, NominalControllerConfig};
use crate::error::{Error, Result};
use crate::math::Real;
use crate::planner::ViewPlannerConfig;
use crate::sensors::{Mover, MoverTracker, MoverTrackerConfig};
use crate::shield::{move_points, BodyState, BrakingModel, Footprint, Motion, Scan as PointScan, Shield, ShieldConfig, ShieldMethod, ShieldOutcome};
use crate::sim::{World, WorldConfig};
use crate::world::generate::{generate, GeneratorConfig};
use crate::world::{preset, wrap_angle, Pose2, Scenario};

/// The largest magnitude of a reward weight: the weighted terms (metres inspected in a step, a
/// contact flag, a change of command in m/s) then stay far from overflowing to an infinite reward.
pub const REWARD_WEIGHT_LIMIT: Real = 1e6;

/// Reward weights: `r = coverage · (new inspected length, m) − collision · cost − intervention ·
/// ‖u* − u_nom‖`. `Default`: 1, 1, 0.05.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardConfig {
    /// Per metre of newly inspected wall.
    pub coverage: Real,
    /// Per step in contact.
    pub collision: Real,
    /// Per m/s of shield intervention per step.
    pub intervention: Real,
}

impl Default for RewardConfig {
    fn default() -> Self {
        Self { coverage: 1.0, collision: 1.0, intervention: 0.05 }
    }
}

/// Everything about an episode but its site. `Default` holds the paper's values.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeConfig {
    /// Robot, tracker, LIDAR, control period. Its `seed` is replaced at every reset.
    pub world: WorldConfig,
    /// The shield. Without `u_max` the box is the tracker's body-frame speed limits; its
    /// braking model is the world's tracker and control period.
    pub shield: ShieldConfig,
    /// The camera model of the coverage test (`fov_h`, `d_view`), shared with the planner.
    pub planner: ViewPlannerConfig,
    /// The P controller of the `"waypoint"` action mode; its `u_max` scales `"world"` actions.
    pub controller: NominalControllerConfig,
    /// How actions are read.
    pub action_mode: ActionMode,
    /// Reference offset (m) of a full `"waypoint"` action.
    pub waypoint_reach: Real,
    /// Reward weights.
    pub reward: RewardConfig,
    /// Coverage pieces and goal.
    pub coverage: CoverageConfig,
    /// Deadlock thresholds.
    pub deadlock: DeadlockConfig,
    /// The flat observation.
    pub observation: ObservationConfig,
    /// End the episode (terminated) at the first contact. Off: the cost is counted, the
    /// episode goes on.
    pub terminate_on_contact: bool,
    /// End the episode (truncated) when a deadlock is detected.
    pub truncate_on_deadlock: bool,
    /// End the episode (terminated) once the true position is within `goal_tolerance` of the
    /// scenario's goal; the mission then counts as complete (no deadlock after it).
    pub terminate_at_goal: bool,
    /// Radius (m) of the goal region.
    pub goal_tolerance: Real,
    /// Truncate the episode after this many steps (the registered time limit); `None`: never.
    pub time_limit: Option<u64>,
    /// When the shield reports its constraint infeasible, stop (translation and rotation).
    /// Off: send the shield's documented least-violating command. The braking shield's
    /// command is sent as it is: its braking check already decided it (or the brake).
    pub stop_when_infeasible: bool,
    /// The footprint the braking shield keeps off the points: a convex polygon (body frame,
    /// m, Nav2's `footprint` convention); `None`: the robot's `length × width` rectangle.
    pub footprint: Option<Vec<[Real; 2]>>,
    /// Track moving objects from the scans and the odometry ([`MoverTracker`]) and give them
    /// to the shield. Off: every return is taken as static.
    pub track_movers: bool,
    /// The mover tracker's parameters.
    pub movers: MoverTrackerConfig,
    /// The braking shield reads the body's velocity from the odometry (the estimate's change
    /// over the step, checked against what the tracker model predicts from the commands sent;
    /// see [`Episode::shield_velocity`]) instead of the simulator's.
    pub odometry_velocity: bool,
}

impl Default for EpisodeConfig {
    fn default() -> Self {
        Self {
            world: WorldConfig::default(),
            shield: ShieldConfig { method: ShieldMethod::Braking, ..ShieldConfig::default() },
            planner: ViewPlannerConfig::default(),
            controller: NominalControllerConfig::default(),
            action_mode: ActionMode::Body,
            waypoint_reach: 2.0,
            reward: RewardConfig::default(),
            coverage: CoverageConfig::default(),
            deadlock: DeadlockConfig::default(),
            observation: ObservationConfig::default(),
            terminate_on_contact: false,
            truncate_on_deadlock: false,
            terminate_at_goal: false,
            goal_tolerance: 0.5,
            stop_when_infeasible: true,
            time_limit: None,
            footprint: None,
            track_movers: true,
            movers: MoverTrackerConfig::default(),
            odometry_velocity: false,
        }
    }
}

/// Where an episode's world comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Site {
    /// A paper preset by name, the same every reset.
    Preset(String),
    /// A new procedural site every reset, generated from the reset's seed.
    Procedural(GeneratorConfig),
    /// A fixed scenario (a loaded ROS map or scenario file).
    Scenario(Box<Scenario>),
}

impl Site {
    /// The scenario of an episode reset with `seed`.
    pub fn scenario(&self, seed: u64) -> Result<Scenario> {
        match self {
            Site::Preset(name) => preset(name),
            Site::Procedural(g) => Ok(generate(seed, g)?.scenario),
            Site::Scenario(s) => Ok((**s).clone()),
        }
    }
}

/// What one step did, in the units of the `info` dict.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepReport {
    /// Reward of the step.
    pub reward: Real,
    /// Coverage complete, the goal reached with `terminate_at_goal`, or contact with
    /// `terminate_on_contact`.
    pub terminated: bool,
    /// A deadlock with `truncate_on_deadlock`, or the time limit.
    pub truncated: bool,
    /// 1 while the true footprint is in contact, else 0.
    pub cost: Real,
    /// Contact points of the true footprint.
    pub contacts: usize,
    /// True distance from the footprint to the nearest obstacle (m).
    pub clearance: Real,
    /// The shield's barrier value (composite `H` for composite and none).
    pub h: Real,
    /// `min_i h_i`.
    pub h_min: Real,
    /// The shield changed the command.
    pub shield_active: bool,
    /// The shield's constraints could be met.
    pub shield_feasible: bool,
    /// The braking shield's check refused the row's command: the robot brakes.
    pub shield_braked: bool,
    /// The braking shield is moving the robot out of an ellipse that holds a point.
    pub shield_recovering: bool,
    /// The braking shield sent the tight-space command: the ellipse does not fit, the body does.
    pub shield_tight: bool,
    /// `‖u* − u_nom‖` (m/s).
    pub intervention: Real,
    /// Nominal body-frame command `(v_x, v_y, ω)`.
    pub u_nom: [Real; 3],
    /// Filtered body-frame command `(v_x, v_y, ω)` sent to the tracker.
    pub u_filtered: [Real; 3],
    /// Inspected fraction.
    pub coverage: Real,
    /// Newly inspected length this step (m).
    pub new_coverage: Real,
    /// Deadlocked now.
    pub deadlock: bool,
    /// Distance between the odometry estimate and the true position (m).
    pub odometry_error: Real,
    /// Shield wall time (ns).
    pub solve_time_ns: u64,
    /// Points the shield used.
    pub num_points: usize,
    /// Moving objects the shield was given.
    pub movers: usize,
    /// A scan was taken this step.
    pub scanned: bool,
    /// Episode time (s).
    pub time: Real,
}

/// Totals of an episode so far.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EpisodeSummary {
    /// Steps taken.
    pub steps: u64,
    /// Episode time (s).
    pub time: Real,
    /// Contact onsets (a contact after a contact-free step).
    pub collisions: u64,
    /// Contact events: contact onsets after at least [`CONTACT_EVENT_GAP`] without contact (a
    /// body pushed away and caught again is one event).
    pub contact_events: u64,
    /// Contact events that began with the robot moving under its own power: a point of its
    /// footprint faster than [`MOVING_CONTACT_SPEED`] at the starts of the step and of the one
    /// before (the robot drove into it; at rest, something else came), and no push since the
    /// time its brake needs to stop from the pushed speed (a robot shoved by a mover and still
    /// coasting to rest under the brake is the mover's doing; see [`pushed`]).
    pub moving_collisions: u64,
    /// Steps at which the shield was given at least one moving object.
    pub mover_steps: u64,
    /// Steps at which the odometry's velocity disagreed with the tracker model's prediction
    /// beyond [`ODOMETRY_TRUST`] and the shield took the model's (`odometry_velocity`).
    pub odometry_distrusted_steps: u64,
    /// Steps in contact.
    pub contact_steps: u64,
    /// Time in contact (s).
    pub contact_time: Real,
    /// A deadlock was detected.
    pub deadlock: bool,
    /// The episode ended with its mission complete (coverage goal, or the goal reached with
    /// `terminate_at_goal`).
    pub success: bool,
    /// Time of the first deadlock detection (s), NaN if none.
    pub deadlock_time: Real,
    /// Final coverage fraction.
    pub coverage: Real,
    /// True path length (m).
    pub path_length: Real,
    /// Mean `‖u* − u_nom‖` (m/s).
    pub intervention_mean: Real,
    /// Steps where the shield changed the command.
    pub shield_active_steps: u64,
    /// Steps where the shield was infeasible.
    pub shield_infeasible_steps: u64,
    /// Steps where the braking shield braked.
    pub shield_braked_steps: u64,
    /// Steps where the braking shield recovered from an ellipse holding a point.
    pub shield_recovering_steps: u64,
    /// Steps where the braking shield sent the tight-space command.
    pub shield_tight_steps: u64,
    /// Smallest true clearance (m).
    pub min_clearance: Real,
    /// Smallest `min_i h_i`.
    pub min_h: Real,
    /// Mean shield time (ns).
    pub solve_time_mean_ns: Real,
    /// Longest shield time (ns).
    pub solve_time_max_ns: u64,
    /// Sum of rewards.
    pub total_reward: Real,
}

/// One running episode.
#[derive(Debug)]
pub struct Episode {
    site: Site,
    config: EpisodeConfig,
    world: World,
    shield: Shield,
    controller: NominalController,
    coverage: Coverage,
    deadlock: DeadlockMonitor,
    cos_el: Vec<Real>,
    /// The valid returns of the latest scan (its body frame) that can lie inside the shield's
    /// crop radius until the next scan (range at most `crop + near_margin`), `f32` rows
    /// `[x, y, z]`.
    near: Vec<f32>,
    near_margin: Real,
    /// The motion from the scan's body frame to the current one.
    motion: Motion,
    /// The range bins of the latest scan (the observation's first block).
    bins: Vec<f32>,
    last_estimate: Pose2,
    estimate_change: Pose2,
    velocity: [Real; 3],
    /// The footprint's fastest point's speed (m/s) at the starts of the latest two steps the
    /// body moved under its own power (see [`EpisodeSummary::moving_collisions`]).
    own_speeds: [Real; 2],
    /// The velocity the shield took last step (`odometry_velocity`).
    believed: [Real; 3],
    last_command: [Real; 3],
    last: StepReport,
    last_shield: Option<ShieldOutcome>,
    summary: EpisodeSummary,
    intervention_sum: Real,
    solve_time_sum: Real,
    in_contact: bool,
    /// Time of the latest step in contact (−∞ before any).
    last_contact: Real,
    /// Until when (s) the body's motion is a push's doing (−∞ before any push).
    pushed_until: Real,
    seed: u64,
    tracker: MoverTracker,
    /// The movers of the latest scan (its body frame) and as the shield takes them now.
    movers_scan: Vec<Mover>,
    movers_now: Vec<Mover>,
}

/// Speed (m/s) of the footprint's fastest point above which a contact onset counts as the
/// robot's ([`EpisodeSummary::moving_collisions`]).
pub const MOVING_CONTACT_SPEED: Real = 0.05;

/// Contact-free time (s) that separates two contact events.
pub const CONTACT_EVENT_GAP: Real = 0.5;

/// Whether the body's velocity change over one step of `dt` (world frame translation, and the
/// turn rate) is more than the tracker can command: an outside force (a mover's push, a
/// contact's impulse) moved the body. The tracker changes the translation by at most
/// `|a_max| dt` and the turn rate by `alpha_max dt`; half as much again and 0.01 m/s
/// (0.05 rad/s) of slack absorb the solver's rounding.
pub fn pushed(before: [Real; 3], after: [Real; 3], tracker: &crate::robot::TrackerConfig, dt: Real) -> bool {
    let dv = (after[0] - before[0]).hypot(after[1] - before[1]);
    dv > 1.5 * tracker.a_max[0].hypot(tracker.a_max[1]) * dt + 0.01 || (after[2] - before[2]).abs() > 1.5 * tracker.alpha_max * dt + 0.05
}

/// How far (m/s) the odometry's velocity may lie from the tracker model's prediction and still
/// be taken; beyond it (a jump, a freeze, a slip) the model's is.
pub const ODOMETRY_TRUST: Real = 0.25;
/// The velocity error (m/s) the braking check allows for when the odometry is not taken.
pub const ODOMETRY_DISTRUST_ERROR: Real = 0.25;

/// Mixes the reset seed into the world's RNG seed, distinct from the site generator's.
fn world_seed(seed: u64) -> u64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Episode {
    /// Validates `config`, builds the site of `seed` and resets.
    pub fn new(site: Site, mut config: EpisodeConfig, seed: u64) -> Result<Self> {
        if config.shield.semi_axes.len() != 2 {
            return Err(Error::invalid("semi_axes", format!("the robot is planar: give 2 semi-axes, got {}", config.shield.semi_axes.len())));
        }
        config.world.tracker.validate()?;
        if config.shield.u_max.is_none() {
            config.shield.u_max = Some(config.world.tracker.v_max.to_vec());
        }
        config.world.robot.validate()?;
        let footprint = match &config.footprint {
            Some(v) => Footprint::polygon(v)?,
            None => Footprint::rectangle(config.world.robot.length, config.world.robot.width)?,
        };
        // the check keeps three standard deviations of the LIDAR's range noise beyond brake_margin
        config.shield.braking = BrakingModel { tracker: config.world.tracker, dt: config.world.dt, lidar_noise_std: config.world.lidar.range_noise_std, footprint, ..config.shield.braking };
        if config.time_limit == Some(0) {
            return Err(Error::invalid("time_limit", "must be at least 1 step (or None)"));
        }
        if !(config.goal_tolerance.is_finite() && config.goal_tolerance > 0.0) {
            return Err(Error::invalid("goal_tolerance", format!("must be finite and > 0 m, got {}", config.goal_tolerance)));
        }
        if !(config.waypoint_reach.is_finite() && config.waypoint_reach > 0.0) {
            return Err(Error::invalid("waypoint_reach", format!("must be finite and > 0 m, got {}", config.waypoint_reach)));
        }
        for (name, v) in [("coverage_reward", config.reward.coverage), ("collision_penalty", config.reward.collision), ("intervention_penalty", config.reward.intervention)] {
            if !(v.is_finite() && v.abs() <= REWARD_WEIGHT_LIMIT) {
                return Err(Error::invalid(name, format!("must be within ±{REWARD_WEIGHT_LIMIT:e}, got {v}")));
            }
        }
        config.observation.validate(config.world.lidar.columns)?;
        let shield = Shield::new(config.shield.clone())?;
        let controller = NominalController::new(config.controller)?;
        crate::planner::ViewPlanner::new(config.planner)?;
        let deadlock = DeadlockMonitor::new(config.deadlock)?;
        let tracker = MoverTracker::new(config.movers)?;
        let scenario = site.scenario(seed)?;
        let mut wc = config.world;
        wc.seed = world_seed(seed);
        let world = World::new(scenario, wc)?;
        let coverage = Coverage::new(&world.scenario().map.segments, [world.true_pose().x, world.true_pose().y], &config.coverage)?;
        let cos_el = config.world.lidar.elevations().iter().map(|e| e.cos()).collect();
        let mut ep = Self {
            site,
            config,
            world,
            shield,
            controller,
            coverage,
            deadlock,
            cos_el,
            near: Vec::new(),
            near_margin: 0.0,
            motion: Motion::planar(0.0, 0.0, 0.0),
            bins: Vec::new(),
            last_estimate: Pose2::default(),
            estimate_change: Pose2::default(),
            velocity: [0.0; 3],
            own_speeds: [0.0; 2],
            believed: [0.0; 3],
            last_command: [0.0; 3],
            last: StepReport::default(),
            last_shield: None,
            summary: EpisodeSummary::default(),
            intervention_sum: 0.0,
            solve_time_sum: 0.0,
            in_contact: false,
            last_contact: Real::NEG_INFINITY,
            pushed_until: Real::NEG_INFINITY,
            seed,
            tracker,
            movers_scan: Vec::new(),
            movers_now: Vec::new(),
        };
        ep.start()?;
        Ok(ep)
    }

    /// Starts a new episode from `seed`: a new site for procedural sources, a new world RNG.
    pub fn reset(&mut self, seed: u64) -> Result<()> {
        let scenario = self.site.scenario(seed)?;
        let mut wc = self.config.world;
        wc.seed = world_seed(seed);
        let same_site = !matches!(self.site, Site::Procedural(_));
        let world = self.world.renew(scenario, wc)?;
        let start = world.true_pose();
        self.coverage = if same_site {
            let mut c = self.coverage.clone();
            c.clear();
            c
        } else {
            Coverage::new(&world.scenario().map.segments, [start.x, start.y], &self.config.coverage)?
        };
        self.world = world;
        self.seed = seed;
        self.start()
    }

    fn start(&mut self) -> Result<()> {
        self.deadlock.reset();
        self.last_estimate = self.world.estimated_pose();
        self.estimate_change = Pose2::default();
        self.velocity = [0.0; 3];
        self.own_speeds = [0.0; 2];
        self.believed = [0.0; 3];
        self.last_command = [0.0; 3];
        self.summary = EpisodeSummary { min_clearance: Real::INFINITY, min_h: Real::INFINITY, deadlock_time: Real::NAN, ..Default::default() };
        self.intervention_sum = 0.0;
        self.solve_time_sum = 0.0;
        self.in_contact = false;
        self.last_contact = Real::NEG_INFINITY;
        self.pushed_until = Real::NEG_INFINITY;
        self.last_shield = None;
        self.tracker.reset();
        self.shield.reset();
        self.index_scan()?;
        self.compensate_points();
        self.inspect();
        let p = self.world.true_pose();
        let complete = self.coverage.fraction() >= self.config.coverage.goal;
        self.deadlock.update(0.0, [p.x, p.y], self.coverage.inspected_count(), complete);
        let clearance = self.world.clearance();
        self.summary.coverage = self.coverage.fraction();
        self.summary.min_clearance = clearance;
        self.last = StepReport { clearance, coverage: self.coverage.fraction(), h: Real::NAN, h_min: Real::NAN, shield_feasible: true, scanned: true, ..Default::default() };
        Ok(())
    }

    /// Inspects what the latest scan sees; returns the new length (m).
    fn inspect(&mut self) -> Real {
        let range = self.config.planner.d_view + self.config.coverage.margin;
        self.coverage.update(self.world.scan(), &self.cos_el, self.config.planner.fov_h, range)
    }

    /// The robot's motion since the latest scan: the pose of the scan's body frame in the
    /// current one (its own short-horizon motion, which the odometry faults do not touch).
    fn since_scan(&self) -> Pose2 {
        self.world.true_pose().between(&self.world.scan_body_pose())
    }

    /// After a scan: the range bins, and which returns the shield may need until the next one.
    /// A return at range `r` lies at least `r − |t|` from the robot after it moved by `t`, so
    /// returns beyond `crop + margin` stay outside the crop while `|t| ≤ margin`.
    fn index_scan(&mut self) -> Result<()> {
        let scan = self.world.scan();
        let lidar = self.config.world.lidar;
        self.bins.resize(self.config.observation.bins, 1.0);
        bin_ranges(scan, &self.cos_el, lidar.max_range, &mut self.bins);
        let t = &self.config.world.tracker;
        self.near_margin = t.v_max[0].hypot(t.v_max[1]) / lidar.rate_hz + 0.05;
        self.select_near();
        self.movers_scan.clear();
        if self.config.track_movers {
            // the scan and the odometry's pose: nothing from the simulator's truth
            let scan = self.world.scan();
            let movers = self.tracker.update(&scan.points, self.world.estimated_pose(), scan.stamp)?;
            self.movers_scan.extend_from_slice(movers);
        }
        Ok(())
    }

    fn select_near(&mut self) {
        let scan = self.world.scan();
        let limit = self.config.shield.scan.crop_radius.map_or(Real::INFINITY, |c| c + self.near_margin);
        // every return is written, only the valid kept ones advance (no branches)
        self.near.resize(3 * scan.points.len() + 3, 0.0);
        let mut k = 0;
        for (p, &r) in scan.points.iter().zip(&scan.ranges) {
            self.near[k..k + 3].copy_from_slice(&p.map(|v| v as f32));
            k += 3 * (!p[0].is_nan() & (r <= limit)) as usize;
        }
        self.near.truncate(k);
    }

    /// The velocity the shield takes, a bound on its error (m/s), and whether the odometry was
    /// distrusted. The simulator's body velocity, exact; with `odometry_velocity`, the
    /// odometry estimate's change over the last step (body frame, per second) where it lies
    /// within [`ODOMETRY_TRUST`] of what the tracker model predicts from the velocity taken
    /// last step and the command sent (their distance is the error bound), else the model's
    /// prediction with [`ODOMETRY_DISTRUST_ERROR`]: a frozen odometry (zero while the body
    /// moves) or a jump is not believed.
    fn shield_velocity(&self) -> ([Real; 3], Real, bool) {
        if !self.config.odometry_velocity {
            return (self.velocity, 0.0, false);
        }
        let dt = self.config.world.dt;
        let c = self.estimate_change;
        let odo = [c.x / dt, c.y / dt, c.yaw / dt];
        let t = &self.config.world.tracker;
        let model = t.next_velocity(self.believed, self.last_command, t.gain(dt), dt).0;
        let error = (odo[0] - model[0]).hypot(odo[1] - model[1]);
        let turn = (odo[2] - model[2]).abs();
        if error <= ODOMETRY_TRUST && turn <= 2.0 * ODOMETRY_TRUST && odo.iter().all(|v| v.is_finite()) {
            (odo, error, false)
        } else {
            (model, ODOMETRY_DISTRUST_ERROR, true)
        }
    }

    /// The motion that takes the kept returns (scan frame) into the current body frame; the
    /// shield applies it in its kernel.
    fn compensate_points(&mut self) {
        let rel = self.since_scan();
        if rel.x.hypot(rel.y) > self.near_margin {
            // pushed farther than the tracker's limits allow (a moving obstacle): widen
            self.near_margin = 2.0 * rel.x.hypot(rel.y);
            self.select_near();
        }
        self.motion = Motion::planar(rel.yaw, rel.x, rel.y);
        let age = self.world.time() - self.world.scan().stamp;
        self.movers_now.clear();
        self.movers_now.extend(self.movers_scan.iter().map(|m| m.advanced(age).moved(rel.yaw, rel.x, rel.y)));
    }

    /// One control period: `action` (in `[-1, 1]³`, read by the action mode) → `u_nom` →
    /// shield → tracker and physics → LIDAR (at its rate) → coverage, reward, metrics.
    pub fn step(&mut self, action: [Real; 3]) -> Result<StepReport> {
        let estimate = self.world.estimated_pose();
        let u_nom = nominal_command(self.config.action_mode, &action, estimate, &self.config.world.tracker, &self.controller, self.config.waypoint_reach)?;
        let w_max = self.config.world.tracker.w_max;
        let omega = u_nom[2].clamp(-w_max, w_max);
        let scan = PointScan::new_f32(&self.near, 3)?.moved(self.motion).with_movers(&self.movers_now);
        let movers = self.movers_now.len();
        let r = self.config.shield.braking.footprint.radius();
        // the robot's own motion: its speed over the two steps before (a push that is about to
        // become a contact moves the body a step or two early: pushed steps are not its own)
        let speed = |v: &[Real; 3]| v[0].hypot(v[1]) + r * v[2].abs();
        let speed_before = self.own_speeds[0].min(self.own_speeds[1]);
        let (v_shield, v_error, distrusted) = self.shield_velocity();
        self.believed = v_shield;
        let state = BodyState::planar(0.0, omega)?.with_velocity(v_shield)?.with_velocity_error(v_error)?;
        let out = self.shield.filter(&scan, &state, &u_nom[..2])?;
        let u = if self.config.shield.method == ShieldMethod::Braking {
            // every command of the braking shield passed its braking check (the brake included)
            [out.u[0], out.u[1], out.omega[2]]
        } else if out.feasible || !self.config.stop_when_infeasible {
            [out.u[0], out.u[1], omega]
        } else {
            [0.0; 3]
        };
        let intervention = (u[0] - u_nom[0]).hypot(u[1] - u_nom[1]);
        let before = self.world.true_pose();
        let step = self.world.step(u)?;
        if step.scanned {
            self.index_scan()?;
        }
        self.compensate_points();
        let new_coverage = if step.scanned { self.inspect() } else { 0.0 };
        let clearance = self.world.clearance();
        let coverage = self.coverage.fraction();
        let p = step.true_pose;
        let at_goal = self.config.terminate_at_goal && self.world.scenario().goal.is_some_and(|g| (g.x - p.x).hypot(g.y - p.y) <= self.config.goal_tolerance);
        let complete = coverage >= self.config.coverage.goal || at_goal;
        let deadlock = self.deadlock.update(step.time, [p.x, p.y], self.coverage.inspected_count(), complete);
        let contact = step.contacts.any();
        let cost = if contact { 1.0 } else { 0.0 };
        let r = &self.config.reward;
        let reward = r.coverage * new_coverage - r.collision * cost - r.intervention * intervention;
        self.estimate_change = self.last_estimate.between(&step.estimated_pose);
        self.last_estimate = step.estimated_pose;
        // a push (a velocity change the tracker cannot command) or a contact makes the body's
        // motion the pusher's until the brake could have stopped it from the speed it has
        let world_v = |v: &[Real; 3], yaw: Real| {
            let (sn, cs) = yaw.sin_cos();
            [cs * v[0] - sn * v[1], sn * v[0] + cs * v[1], v[2]]
        };
        let tracker = &self.config.world.tracker;
        if contact || pushed(world_v(&self.velocity, before.yaw), world_v(&step.velocity, p.yaw), tracker, self.config.world.dt) {
            let stop = step.velocity[0].hypot(step.velocity[1]) / tracker.a_max[0].min(tracker.a_max[1]) + 2.0 * tracker.tau + self.config.world.dt;
            self.pushed_until = self.pushed_until.max(step.time + stop);
        } else if step.time > self.pushed_until {
            self.own_speeds = [self.own_speeds[1], speed(&step.velocity)];
        }
        self.velocity = step.velocity;
        self.last_command = u;
        let odometry_error = (step.estimated_pose.x - p.x).hypot(step.estimated_pose.y - p.y);
        let terminated = complete || (contact && self.config.terminate_on_contact);
        let out_of_time = self.config.time_limit.is_some_and(|n| self.summary.steps + 1 >= n);
        let report = StepReport {
            reward,
            terminated,
            truncated: !terminated && ((deadlock && self.config.truncate_on_deadlock) || out_of_time),
            cost,
            contacts: step.contacts.count,
            clearance,
            h: out.value,
            h_min: out.h_min,
            shield_active: out.active,
            shield_feasible: out.feasible,
            shield_braked: out.braked,
            shield_recovering: out.recovering,
            shield_tight: out.tight,
            intervention,
            u_nom: [u_nom[0], u_nom[1], omega],
            u_filtered: u,
            coverage,
            new_coverage,
            deadlock,
            odometry_error,
            solve_time_ns: out.solve_time_ns,
            num_points: out.num_points,
            movers,
            scanned: step.scanned,
            time: step.time,
        };
        let s = &mut self.summary;
        s.steps += 1;
        s.time = step.time;
        s.collisions += (contact && !self.in_contact) as u64;
        let event = contact && step.time - self.last_contact > CONTACT_EVENT_GAP;
        s.contact_events += event as u64;
        s.moving_collisions += (event && speed_before > MOVING_CONTACT_SPEED) as u64;
        if contact {
            self.last_contact = step.time;
        }
        s.mover_steps += (movers > 0) as u64;
        s.odometry_distrusted_steps += distrusted as u64;
        s.contact_steps += contact as u64;
        s.contact_time += cost * self.config.world.dt;
        if deadlock && !s.deadlock {
            s.deadlock = true;
            s.deadlock_time = step.time;
        }
        s.coverage = coverage;
        s.success = complete;
        s.path_length += (p.x - before.x).hypot(p.y - before.y);
        self.intervention_sum += intervention;
        s.intervention_mean = self.intervention_sum / s.steps as Real;
        s.shield_active_steps += out.active as u64;
        s.shield_infeasible_steps += !out.feasible as u64;
        s.shield_braked_steps += out.braked as u64;
        s.shield_recovering_steps += out.recovering as u64;
        s.shield_tight_steps += out.tight as u64;
        s.min_clearance = s.min_clearance.min(clearance);
        s.min_h = s.min_h.min(out.h_min);
        self.solve_time_sum += out.solve_time_ns as Real;
        s.solve_time_mean_ns = self.solve_time_sum / s.steps as Real;
        s.solve_time_max_ns = s.solve_time_max_ns.max(out.solve_time_ns);
        s.total_reward += reward;
        self.in_contact = contact;
        self.last = report;
        self.last_shield = Some(out);
        Ok(report)
    }

    /// Writes the flat observation (laid out as the `env::observation` module says) into `out`.
    pub fn observe(&self, out: &mut [f32]) -> Result<()> {
        let bins = self.config.observation.bins;
        if out.len() != self.config.observation.len() {
            return Err(Error::DimensionMismatch { name: "observation", expected: self.config.observation.len(), got: out.len() });
        }
        out[..bins].copy_from_slice(&self.bins);
        let t = &self.config.world.tracker;
        let scale = [t.v_max[0], t.v_max[1], t.w_max];
        let d = self.estimate_change;
        let rest = &mut out[bins..];
        rest[0] = d.x as f32;
        rest[1] = d.y as f32;
        rest[2] = d.yaw as f32;
        for k in 0..3 {
            rest[3 + k] = (self.velocity[k] / scale[k]) as f32;
            rest[6 + k] = (self.last_command[k] / scale[k]) as f32;
        }
        Ok(())
    }

    /// Length of the flat observation.
    pub fn observation_len(&self) -> usize {
        self.config.observation.len()
    }

    /// The flat observation's bounds `(low, high)` under this episode's configuration (see
    /// `env::observation::observation_bounds`).
    pub fn observation_bounds(&self) -> (Vec<f32>, Vec<f32>) {
        let c = &self.config;
        let t = &c.world.tracker;
        let shield_box = c.shield.u_max.as_ref().map(|m| [m[0], m[1]]);
        super::observation::observation_bounds(c.observation.bins, t.v_max, t.w_max, shield_box, c.controller.u_max, c.controller.omega_max)
    }

    /// Every valid return of the latest scan in the current body frame, `[x, y, z]` rows (m),
    /// with its scan index (`channel · columns + column`). Computed on each call.
    pub fn points(&self) -> (Vec<Real>, Vec<u32>) {
        let rel = self.since_scan();
        let (s, c) = rel.yaw.sin_cos();
        let mut out = Vec::with_capacity(3 * self.world.scan().points.len());
        let mut ids = Vec::with_capacity(self.world.scan().points.len());
        for (k, p) in self.world.scan().points.iter().enumerate() {
            if !p[0].is_nan() {
                out.extend_from_slice(&[rel.x + c * p[0] - s * p[1], rel.y + s * p[0] + c * p[1], p[2]]);
                ids.push(k as u32);
            }
        }
        (out, ids)
    }

    /// The returns the shield sees this step (`f32` rows `[x, y, z]`, current body frame):
    /// those of [`Episode::points`] that can lie inside its crop radius.
    pub fn shield_points(&self) -> Vec<f32> {
        let mut out = Vec::new();
        move_points(&self.near, 3, &self.motion, &mut out);
        out
    }

    /// The body velocity `(v_x, v_y, ω)` the last step left the robot at (body frame).
    pub fn velocity(&self) -> [Real; 3] {
        self.velocity
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The moving objects the shield takes now (current body frame; empty with
    /// `track_movers` off).
    pub fn movers(&self) -> &[Mover] {
        &self.movers_now
    }

    /// The mover tracker.
    pub fn mover_tracker(&self) -> &MoverTracker {
        &self.tracker
    }

    /// The coverage state.
    pub fn coverage(&self) -> &Coverage {
        &self.coverage
    }

    /// The configuration (with the shield's box filled in).
    pub fn config(&self) -> &EpisodeConfig {
        &self.config
    }

    /// The site source.
    pub fn site(&self) -> &Site {
        &self.site
    }

    /// The last step's report (after a reset: clearance and coverage only).
    pub fn last_report(&self) -> &StepReport {
        &self.last
    }

    /// The shield's outcome at the last step, `None` right after a reset.
    pub fn last_shield(&self) -> Option<&ShieldOutcome> {
        self.last_shield.as_ref()
    }

    /// Totals so far.
    pub fn summary(&self) -> &EpisodeSummary {
        &self.summary
    }

    /// The seed of the last reset.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The estimated pose change over the last step (previous estimate's body frame).
    pub fn estimate_change(&self) -> Pose2 {
        Pose2::new(self.estimate_change.x, self.estimate_change.y, wrap_angle(self.estimate_change.yaw))
    }
}
