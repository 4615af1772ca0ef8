//! The node's decisions without the network: which messages it holds, when they are stale,
//! and the command it sends. [`ShieldNode`] takes each message with the time it arrived and
//! answers with an [`Output`]: the filtered command, or zero with the reason.

use std::time::{Duration, Instant};

use serde::Serialize;
use shieldnav_core::sensors::{Mover, MoverTracker};
use shieldnav_core::shield::{BodyState, Motion, Scan, Shield, ShieldMethod, ShieldOutcome};
use shieldnav_core::world::Pose2;

use crate::msg::{Imu, LaserScan, Odometry, PointCloud2, Twist, Vector3};
use crate::params::NodeParams;
use crate::translate::{laser_scan_points_with, point_cloud_points, BeamTable, Rejection};

/// What the node holds of one input.
#[derive(Debug, Clone, PartialEq)]
enum Held<T> {
    /// Nothing received yet.
    Missing,
    /// A usable message, and when it arrived.
    Valid(T, Instant),
    /// The last message was rejected: why.
    Rejected(Rejection),
}

impl<T> Held<T> {
    /// The value if it is younger than `timeout` at `now`, else the reason it is not usable.
    fn fresh(&self, what: &str, now: Instant, timeout: Duration) -> Result<&T, String> {
        match self {
            Held::Missing => Err(format!("no {what} received yet")),
            Held::Rejected(r) => Err(format!("{what} rejected: {r}")),
            Held::Valid(v, at) => {
                let age = now.saturating_duration_since(*at);
                if age > timeout {
                    Err(format!("stale {what}: {:.3} s old (timeout {:.3} s)", age.as_secs_f64(), timeout.as_secs_f64()))
                } else {
                    Ok(v)
                }
            }
        }
    }
}

/// The scan the node holds: its points are in [`ShieldNode`]'s buffer.
#[derive(Debug, Clone, PartialEq)]
struct ScanInfo {
    frame: String,
    points: usize,
    /// The body's dead-reckoned pose when the scan arrived.
    pose: Pose2,
}

/// The body's pose integrated from its measured velocity (dead reckoning from an arbitrary
/// origin): what moves the held scan into the body frame of the moment a command is made, as
/// the robot drives on between scans.
#[derive(Debug, Clone, Copy, Default)]
struct Reckoning {
    pose: Pose2,
    /// Body-frame `(v_x, v_y, ω)` held since `at`.
    velocity: [f64; 3],
    at: Option<Instant>,
}

impl Reckoning {
    /// The pose at `now`: the held velocity, a constant body twist, integrated exactly.
    fn at(&self, now: Instant) -> Pose2 {
        let Some(at) = self.at else { return self.pose };
        let dt = now.saturating_duration_since(at).as_secs_f64();
        let [vx, vy, w] = self.velocity;
        let turn = w * dt;
        let (dx, dy) = if turn.abs() < 1e-9 {
            (vx * dt, vy * dt)
        } else {
            let (s, c) = turn.sin_cos();
            ((s * vx - (1.0 - c) * vy) / w, ((1.0 - c) * vx + s * vy) / w)
        };
        self.pose.compose(&Pose2::new(dx, dy, turn))
    }

    /// Holds a new velocity from `now` on (`None` keeps that component).
    fn update(&mut self, now: Instant, linear: Option<[f64; 2]>, yaw_rate: Option<f64>) {
        self.pose = self.at(now);
        self.at = Some(now);
        if let Some([vx, vy]) = linear {
            self.velocity[0] = vx;
            self.velocity[1] = vy;
        }
        if let Some(w) = yaw_rate {
            self.velocity[2] = w;
        }
    }
}

/// The state topic's content (`std_msgs/String`, this as one JSON object).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct State {
    /// The filter ran and its command was sent (`false`: a zero command was sent, see `reason`).
    pub ok: bool,
    /// Why the command is zero, when it is.
    pub reason: Option<String>,
    /// The shield's method.
    pub method: &'static str,
    /// The barrier `H` (null when no point was used or the filter did not run).
    #[serde(rename = "H")]
    pub h: Option<f64>,
    /// `min_i h_i` (null as `H`).
    pub h_min: Option<f64>,
    /// The constraints changed the command.
    pub active: bool,
    /// The constraints could be met.
    pub feasible: bool,
    /// The braking check sent the brake.
    pub braked: bool,
    /// A point is inside the ellipse: the row's command is the recovery (still checked).
    pub recovering: bool,
    /// The braking shield sent the tight-space command (the ellipse stalls, the body passes).
    pub tight: bool,
    /// The standing footprint's least clearance to the scan (m; null when no check ran or no
    /// point is within reach).
    pub clearance: Option<f64>,
    /// Points the shield used (after crop, band and down-sampling).
    pub points_used: usize,
    /// Moving objects tracked in the scan held (each kept from the robot's path).
    pub movers: usize,
    /// Returns in the scan held, before the shield's crop.
    pub points_in_scan: usize,
    /// The frame of the scan held.
    pub scan_frame: Option<String>,
    /// Age of the scan held (s).
    pub scan_age: Option<f64>,
    /// The shield's time for this command (µs).
    pub solve_time_us: f64,
    /// Nominal command `[vx, vy, vz, wx, wy, wz]` (null when none is held).
    pub nominal: Option<[f64; 6]>,
    /// Command sent `[vx, vy, vz, wx, wy, wz]`.
    pub command: [f64; 6],
}

/// One command to send and its state.
#[derive(Debug, Clone, PartialEq)]
pub struct Output {
    /// The command (`Twist`).
    pub command: Twist,
    /// The state to publish beside it.
    pub state: State,
}

fn twist6(t: &Twist) -> [f64; 6] {
    [t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z]
}

fn finite_twist(t: &Twist) -> bool {
    twist6(t).iter().all(|v| v.is_finite())
}

/// The shield between a planner and a robot, without the network.
pub struct ShieldNode {
    params: NodeParams,
    shield: Shield,
    points: Vec<f64>,
    beams: BeamTable,
    scan: Held<ScanInfo>,
    /// Body velocity `(vx, vy, vz)` and angular velocity from odometry.
    velocity: Held<([f64; 3], [f64; 3])>,
    /// Angular velocity from the IMU.
    imu_omega: Held<[f64; 3]>,
    nominal: Held<Twist>,
    reckoning: Reckoning,
    /// The mover tracker (when `track_movers`), the beams it segments, the movers of the held
    /// scan (its frame) and as the shield takes them now.
    tracker: Option<MoverTracker>,
    beam_points: Vec<[f64; 3]>,
    movers_scan: Vec<Mover>,
    movers_now: Vec<Mover>,
    /// The tracker's clock: the first scan's arrival.
    origin: Option<Instant>,
}

impl ShieldNode {
    /// A node with checked parameters (see [`crate::params::RawParams::build`]).
    pub fn new(params: NodeParams) -> Result<Self, shieldnav_core::Error> {
        let shield = Shield::new(params.shield.clone())?;
        let tracker = params.movers.map(MoverTracker::new).transpose()?;
        Ok(Self {
            params,
            shield,
            points: Vec::new(),
            beams: BeamTable::default(),
            scan: Held::Missing,
            velocity: Held::Missing,
            imu_omega: Held::Missing,
            nominal: Held::Missing,
            reckoning: Reckoning::default(),
            tracker,
            beam_points: Vec::new(),
            movers_scan: Vec::new(),
            movers_now: Vec::new(),
            origin: None,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &NodeParams {
        &self.params
    }

    /// The held scan's returns as body-frame `(x, y, z)` rows (stride 3), before the shield's
    /// crop; empty when no scan is held or the last was rejected.
    pub fn points(&self) -> &[f64] {
        &self.points
    }

    fn check_frame(&self, frame: &str) -> Result<(), Rejection> {
        match &self.params.sensor_frame {
            Some(f) if f != frame => Err(format!("frame_id {frame:?} is not sensor_frame {f:?}")),
            _ => Ok(()),
        }
    }

    /// Takes a scan that arrived at `now`; a rejected scan stops the robot until a valid one
    /// arrives. Returns the reason it was rejected.
    pub fn on_scan(&mut self, msg: &LaserScan, now: Instant) -> Result<(), Rejection> {
        self.points.clear();
        self.beam_points.clear();
        let r = self.check_frame(&msg.header.frame_id).and_then(|_| self.check_invalid(msg)).and_then(|_| {
            let beams = self.tracker.is_some().then_some(&mut self.beam_points);
            laser_scan_points_with(msg, &self.params.mount, &mut self.beams, &mut self.points, beams)
        });
        let pose = self.reckoning.at(now);
        if r.is_ok() {
            self.track(pose, now);
        }
        self.hold_scan(r.map(|n| ScanInfo { frame: msg.header.frame_id.clone(), points: n, pose }), now)
    }

    /// The mover tracker on the scan's beams, with the dead-reckoned pose: the movers of the
    /// scan, in its frame. (A cloud is not tracked: its points are taken as static.)
    fn track(&mut self, pose: Pose2, now: Instant) {
        self.movers_scan.clear();
        let Some(tracker) = self.tracker.as_mut() else { return };
        let origin = *self.origin.get_or_insert(now);
        let time = now.saturating_duration_since(origin).as_secs_f64();
        match tracker.update(&self.beam_points, pose, time) {
            Ok(movers) => self.movers_scan.extend_from_slice(movers),
            // (a scan at the same arrival time as the last: the tracks start over)
            Err(_) => tracker.reset(),
        }
    }

    /// Takes a point cloud that arrived at `now` (as [`ShieldNode::on_scan`]).
    pub fn on_cloud(&mut self, msg: &PointCloud2, now: Instant) -> Result<(), Rejection> {
        self.points.clear();
        self.movers_scan.clear();
        let r = self.check_frame(&msg.header.frame_id).and_then(|_| point_cloud_points(msg, &self.params.mount, &mut self.points));
        self.hold_scan(r.map(|n| ScanInfo { frame: msg.header.frame_id.clone(), points: n, pose: self.reckoning.at(now) }), now)
    }

    /// A scan mostly of NaN ranges (invalid measurements, REP 117) is a blinded sensor, not
    /// free space.
    fn check_invalid(&self, msg: &LaserScan) -> Result<(), Rejection> {
        let nan = msg.ranges.iter().filter(|r| r.is_nan()).count();
        let n = msg.ranges.len();
        if n > 0 && self.params.max_invalid_fraction < 1.0 && nan as f64 > self.params.max_invalid_fraction * n as f64 {
            return Err(format!("LaserScan has {nan} of {n} ranges NaN (invalid), more than max_invalid_fraction {}", self.params.max_invalid_fraction));
        }
        Ok(())
    }

    fn hold_scan(&mut self, r: Result<ScanInfo, Rejection>, now: Instant) -> Result<(), Rejection> {
        match r {
            Ok(info) => {
                self.scan = Held::Valid(info, now);
                Ok(())
            }
            Err(reason) => {
                self.points.clear();
                self.movers_scan.clear();
                self.scan = Held::Rejected(reason.clone());
                Err(reason)
            }
        }
    }

    /// A scan or cloud that could not even be decoded.
    pub fn reject_scan(&mut self, reason: Rejection) {
        self.points.clear();
        self.movers_scan.clear();
        self.scan = Held::Rejected(reason);
    }

    /// Takes odometry: the body-frame velocity and angular velocity of its twist.
    pub fn on_odometry(&mut self, msg: &Odometry, now: Instant) -> Result<(), Rejection> {
        let t = &msg.twist.twist;
        let bound = shieldnav_core::shield::MAX_BODY_RATE;
        if !twist6(t).iter().all(|v| v.is_finite() && v.abs() <= bound) {
            let reason = format!("Odometry twist is not finite or beyond ±{bound}: {:?}", twist6(t));
            self.velocity = Held::Rejected(reason.clone());
            return Err(reason);
        }
        let v = |x: &Vector3| [x.x, x.y, x.z];
        self.velocity = Held::Valid((v(&t.linear), v(&t.angular)), now);
        let yaw_rate = self.params.topics.imu.is_none().then_some(t.angular.z);
        self.reckoning.update(now, Some([t.linear.x, t.linear.y]), yaw_rate);
        Ok(())
    }

    /// Takes the angular velocity of an IMU message.
    pub fn on_imu(&mut self, msg: &Imu, now: Instant) -> Result<(), Rejection> {
        let w = [msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z];
        let bound = shieldnav_core::shield::MAX_BODY_RATE;
        if !w.iter().all(|v| v.is_finite() && v.abs() <= bound) {
            let reason = format!("Imu angular_velocity is not finite or beyond ±{bound}: {w:?}");
            self.imu_omega = Held::Rejected(reason.clone());
            return Err(reason);
        }
        self.imu_omega = Held::Valid(w, now);
        self.reckoning.update(now, None, Some(w[2]));
        Ok(())
    }

    /// A malformed odometry or IMU message.
    pub fn reject_motion(&mut self, reason: Rejection) {
        if self.params.topics.odom.is_some() {
            self.velocity = Held::Rejected(reason.clone());
        }
        if self.params.topics.imu.is_some() {
            self.imu_omega = Held::Rejected(reason);
        }
    }

    /// Takes a nominal command and answers with the command to send.
    pub fn on_nominal(&mut self, msg: &Twist, now: Instant) -> Output {
        self.nominal = if finite_twist(msg) { Held::Valid(*msg, now) } else { Held::Rejected(format!("nominal Twist is not finite: {:?}", twist6(msg))) };
        self.command(now)
    }

    /// A nominal command that could not be decoded: zero, with the reason.
    pub fn reject_nominal(&mut self, reason: Rejection, now: Instant) -> Output {
        self.nominal = Held::Rejected(reason);
        self.command(now)
    }

    /// The watchdog: zero and the reason when the nominal command is missing or stale,
    /// `None` while it is fresh (the command goes out at the nominal command's rate).
    pub fn tick(&mut self, now: Instant) -> Option<Output> {
        match self.nominal.fresh("nominal command", now, self.params.command_timeout) {
            Ok(_) => None,
            Err(reason) => Some(self.stop(reason, now)),
        }
    }

    fn stop(&self, reason: String, now: Instant) -> Output {
        let (scan_frame, scan_age, points_in_scan) = match &self.scan {
            Held::Valid(info, at) => (Some(info.frame.clone()), Some(now.saturating_duration_since(*at).as_secs_f64()), info.points),
            _ => (None, None, 0),
        };
        let nominal = match &self.nominal {
            Held::Valid(t, _) => Some(twist6(t)),
            _ => None,
        };
        Output {
            command: Twist::default(),
            state: State {
                ok: false,
                reason: Some(reason),
                method: self.params.shield.method.name(),
                h: None,
                h_min: None,
                active: false,
                feasible: false,
                braked: false,
                recovering: false,
                tight: false,
                clearance: None,
                points_used: 0,
                movers: 0,
                points_in_scan,
                scan_frame,
                scan_age,
                solve_time_us: 0.0,
                nominal,
                command: [0.0; 6],
            },
        }
    }

    /// The command for the inputs held at `now`: the filtered nominal command, or zero with
    /// the reason when an input is missing, stale or rejected, or the filter fails.
    pub fn command(&mut self, now: Instant) -> Output {
        match self.try_command(now) {
            Ok(out) => out,
            Err(reason) => self.stop(reason, now),
        }
    }

    fn try_command(&mut self, now: Instant) -> Result<Output, String> {
        let p = &self.params;
        let nominal = *self.nominal.fresh("nominal command", now, p.command_timeout)?;
        let (info, at) = match &self.scan {
            Held::Valid(info, at) => (info.clone(), *at),
            other => return Err(other.fresh("scan", now, p.scan_timeout).err().unwrap_or_default()),
        };
        self.scan.fresh("scan", now, p.scan_timeout)?;
        let method = p.shield.method;
        // the measured motion: odometry if configured, the IMU's ω (over odometry's) if
        // configured, else at rest
        let velocity = match p.topics.odom {
            Some(_) => Some(*self.velocity.fresh("odometry", now, p.odom_timeout)?),
            None => None,
        };
        let imu = match p.topics.imu {
            Some(_) => Some(*self.imu_omega.fresh("IMU", now, p.odom_timeout)?),
            None => None,
        };
        let omega_measured = imu.or(velocity.map(|v| v.1)).unwrap_or([0.0; 3]);
        let dim = self.shield.dim();
        let n = twist6(&nominal);
        let u_nom = &n[..dim];
        let state = if dim == 2 {
            if method == ShieldMethod::Braking {
                // the translation from odometry, the yaw rate from the IMU where one is set
                let (v, w) = velocity.ok_or("the braking shield needs odometry")?;
                let wz = imu.map_or(w[2], |i| i[2]);
                BodyState::planar(0.0, nominal.angular.z).and_then(|s| s.with_velocity([v[0], v[1], wz]))
            } else {
                BodyState::planar(0.0, omega_measured[2])
            }
        } else {
            let eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            let omega = if method == ShieldMethod::Braking { [n[3], n[4], n[5]] } else { omega_measured };
            BodyState::spatial(eye, omega)
        }
        .map_err(|e| format!("body state: {e}"))?;
        let mut scan = Scan::new_f64(&self.points, 3).map_err(|e| format!("scan: {e}"))?;
        self.movers_now.clear();
        if dim == 2 {
            // the scan moved into the body frame of now by the motion measured since it arrived,
            // its movers along their tracks as well
            let rel = self.reckoning.at(now).between(&info.pose);
            if rel != Pose2::default() {
                scan = scan.moved(Motion::planar(rel.yaw, rel.x, rel.y));
            }
            let age = now.saturating_duration_since(at).as_secs_f64();
            self.movers_now.extend(self.movers_scan.iter().map(|m| m.advanced(age).moved(rel.yaw, rel.x, rel.y)));
            scan = scan.with_movers(&self.movers_now);
        }
        let out: ShieldOutcome = self.shield.filter(&scan, &state, u_nom).map_err(|e| format!("shield: {e}"))?;
        // the planar braking shield's command passed its braking check whatever the row said
        let checked = method == ShieldMethod::Braking && dim == 2;
        if !out.feasible && !checked && p.stop_when_infeasible {
            return Err(format!("infeasible: no command in the box meets the barrier's row (H = {:.4}, h_min = {:.4})", out.value, out.h_min));
        }
        let mut cmd = Twist::default();
        cmd.linear.x = out.u[0];
        cmd.linear.y = out.u[1];
        if dim == 3 {
            cmd.linear.z = out.u[2];
        }
        if method == ShieldMethod::Braking {
            if dim == 2 {
                cmd.angular.z = out.omega[2];
            } else {
                cmd.angular = Vector3 { x: out.omega[0], y: out.omega[1], z: out.omega[2] };
            }
        } else {
            cmd.angular = nominal.angular;
        }
        let used = out.num_points > 0;
        Ok(Output {
            command: cmd,
            state: State {
                ok: true,
                reason: None,
                method: method.name(),
                h: used.then_some(out.value),
                h_min: used.then_some(out.h_min),
                active: out.active,
                feasible: out.feasible,
                braked: out.braked,
                recovering: out.recovering,
                tight: out.tight,
                clearance: (out.clearance.is_finite() && out.clearance < f64::MAX).then_some(out.clearance),
                points_used: out.num_points,
                movers: self.movers_now.len(),
                points_in_scan: info.points,
                scan_frame: Some(info.frame),
                scan_age: Some(now.saturating_duration_since(at).as_secs_f64()),
                solve_time_us: out.solve_time_ns as f64 * 1e-3,
                nominal: Some(n),
                command: twist6(&cmd),
            },
        })
    }
}

impl State {
    /// The JSON text the state topic carries.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| format!("{{\"ok\":false,\"reason\":\"state not serialisable: {e}\"}}"))
    }
}
