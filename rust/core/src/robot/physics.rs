//! The rapier scene: walls (fixed segments), scripted obstacles (kinematic, position-based)
//! and the robot (a dynamic body with the true footprint, driven by velocity each step).
//!
//! Rapier works in `f32`, in a local frame whose origin is the centre of the walls' bounding
//! box (the start if there are none), chosen when the scene is built: every pose crosses over
//! in `f64` relative to it, so that motion at 1e5 m from the world's origin is as accurate as
//! near it (`f32` at 1e5 m is 8 mm coarse; in the local frame it is about 1e-6 m at 10 m from
//! the walls' centre).
//!
//! Contacts are judged after each step at the final poses on the true footprint, exactly, in
//! `f64` ([`footprint`](super::footprint)): rapier's broad-phase tree only picks the walls
//! near the footprint, every obstacle is measured; touching within [`CONTACT_TOLERANCE`]
//! counts (see [`PhysicsScene::contacts`]).

use std::sync::atomic::{AtomicU32, Ordering};

use rapier2d::prelude::*;

use super::footprint::{inner_rect_signed_distance, RobotShape};
use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::{wrap_angle, MovingObstacle, Point2, Pose2, Segment};

/// Footprints closer than this (m) to a wall or obstacle count as touching it: rapier's
/// solver rests bodies up to about a millimetre apart (or into each other).
pub const CONTACT_TOLERANCE: Real = 1e-3;

/// Contacts of the robot after a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactReport {
    /// Walls and obstacles within [`CONTACT_TOLERANCE`] of the footprint.
    pub count: usize,
    /// Of those, walls (static geometry).
    pub with_walls: usize,
    /// Of those, moving obstacles.
    pub with_obstacles: usize,
    /// Deepest penetration (m), 0 if none.
    pub max_penetration: Real,
}

impl ContactReport {
    /// Whether the robot touches anything.
    pub fn any(&self) -> bool {
        self.count > 0
    }

    /// Counts a wall or an obstacle if it is within [`CONTACT_TOLERANCE`] (a distance measured
    /// that far is exact).
    fn tally(&mut self, m: Measured) {
        let (d, obstacle) = (m.d, m.obstacle);
        if d <= CONTACT_TOLERANCE {
            debug_assert!(m.exact);
            self.count += 1;
            if obstacle.is_none() {
                self.with_walls += 1;
            } else {
                self.with_obstacles += 1;
            }
            self.max_penetration = self.max_penetration.max(-d);
        }
    }
}

/// Robot, walls and moving obstacles in one rapier world.
pub struct PhysicsScene {
    world: PhysicsWorld,
    robot: RigidBodyHandle,
    /// Rapier's hook on the robot's contacts (see [`ContactGuard`]).
    guard: ContactGuard,
    /// The footprint's deepest penetration (m) at the last step's end (valid with `near`).
    deepest: Real,
    obstacles: Vec<RigidBodyHandle>,
    shape: RobotShape,
    /// The world-frame point at rapier's origin.
    origin: Point2,
    /// The walls in the local frame (`f64`), by each collider's `user_data`.
    walls: Vec<[Point2; 2]>,
    /// Each obstacle's outline (its own frame) and its pose in the local frame (`f64`).
    obstacle_shapes: Vec<Vec<Point2>>,
    obstacle_poses: Vec<Pose2>,
    /// Each obstacle's outline's greatest distance from its frame's origin.
    obstacle_radii: Vec<Real>,
    /// The body-frame velocity the robot achieved in the last step.
    achieved: [Real; 3],
    /// Rapier steps taken.
    substeps: u64,
    scratch: Vec<Point2>,
    /// The distances [`PhysicsScene::step`] measured at its end to every wall that may lie
    /// within [`NEAR_GROW`] of the footprint and to every obstacle, as
    /// [`PhysicsScene::measure`] gives them (an obstacle's a lower bound where it was far);
    /// `near_valid` while the robot and the obstacles are still where they were measured (the
    /// next step's start: it reads them instead of measuring again).
    near: Vec<Measured>,
    /// How far the robot can close in on a wall and on each obstacle in a step (scratch).
    closing: Vec<Real>,
    near_valid: bool,
    /// The pose (local frame, `f64`) the robot was placed at, until it moves: the pose reads
    /// exactly as given (`f32` rounding would move it by up to about 1e-6 m).
    placed: Option<Pose2>,
    /// Far obstacles' bounds the steps had to measure exactly (they might come within reach).
    #[cfg(test)]
    bounds_measured: usize,
    /// [`COARSE_SPLIT`] (tests compare with 1: every step split).
    coarse_split: usize,
    /// Coarse steps kept, and taken again split (see [`COARSE_SPLIT`]).
    #[cfg(test)]
    coarse_kept: usize,
    #[cfg(test)]
    coarse_redone: usize,
}

impl std::fmt::Debug for PhysicsScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PhysicsScene").field("bodies", &self.world.bodies.len()).field("colliders", &self.world.colliders.len()).field("origin", &self.origin).finish()
    }
}

#[inline]
fn v(x: Real, y: Real) -> Vector {
    Vector::new(x as f32, y as f32)
}

/// Velocities this close (m/s, rad/s) to the commanded ones are the command (`f32` rounding).
const VELOCITY_ROUNDING: Real = 1e-5;

impl PhysicsScene {
    /// Builds the scene: `walls` fixed, `obstacles` at their poses at time `t0`, the robot at
    /// `start`.
    pub fn new(shape: RobotShape, walls: &[Segment], obstacles: &[MovingObstacle], start: Pose2, t0: Real) -> Result<Self> {
        shape.validate()?;
        start.validate("start")?;
        for s in walls {
            s.validate("walls")?;
        }
        for o in obstacles {
            o.validate()?;
        }
        let origin = if walls.is_empty() {
            [start.x, start.y]
        } else {
            let (mut lo, mut hi) = ([Real::INFINITY; 2], [Real::NEG_INFINITY; 2]);
            for s in walls {
                for p in [s.a, s.b] {
                    for k in 0..2 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
            }
            // (a whole number of metres: shifting a site by whole metres shifts its frame)
            [(0.5 * (lo[0] + hi[0])).round(), (0.5 * (lo[1] + hi[1])).round()]
        };
        let local = |p: Point2| [p[0] - origin[0], p[1] - origin[1]];
        let mut world = PhysicsWorld { gravity: Vector::ZERO, ..Default::default() };
        world.integration_parameters.num_solver_iterations = SOLVER_SUBSTEPS;
        world.integration_parameters.normalized_allowed_linear_error = ALLOWED_LINEAR_ERROR as f32;
        world.integration_parameters.contact_recycling = false;
        let wall_body = world.insert_body(RigidBodyBuilder::fixed());
        let mut local_walls = Vec::with_capacity(walls.len());
        for (i, s) in walls.iter().enumerate() {
            let (a, b) = (local(s.a), local(s.b));
            world.insert_collider(ColliderBuilder::segment(v(a[0], a[1]), v(b[0], b[1])).friction(0.0).user_data(i as u128), Some(wall_body));
            local_walls.push([a, b]);
        }
        let mut handles = Vec::with_capacity(obstacles.len());
        let mut obstacle_poses = Vec::with_capacity(obstacles.len());
        for o in obstacles {
            let pts: Vec<Vector> = o.shape.vertices.iter().map(|p| v(p[0], p[1])).collect();
            let collider = ColliderBuilder::convex_polyline(pts).ok_or_else(|| Error::invalid("obstacle.shape", format!("`{}`: no convex hull", o.name)))?;
            let p = o.trajectory.pose_at(t0);
            let q = local([p.x, p.y]);
            let body = RigidBodyBuilder::kinematic_position_based().translation(v(q[0], q[1])).rotation(p.yaw as f32);
            let (h, _) = world.insert(body, collider.friction(0.0));
            handles.push(h);
            obstacle_poses.push(Pose2::new(q[0], q[1], p.yaw));
        }
        let r = shape.corner_radius;
        let (hx, hy) = (0.5 * shape.length, 0.5 * shape.width);
        let collider = if r > 0.0 { ColliderBuilder::round_cuboid((hx - r) as f32, (hy - r) as f32, r as f32) } else { ColliderBuilder::cuboid(hx as f32, hy as f32) };
        let s = local([start.x, start.y]);
        let body = RigidBodyBuilder::dynamic().translation(v(s[0], s[1])).rotation(start.yaw as f32).can_sleep(false);
        // Spot's mass: ~32 kg over 0.55 m²
        let (robot, _) = world.insert(body, collider.density(58.0).friction(0.0).active_hooks(ActiveHooks::MODIFY_SOLVER_CONTACTS));
        // a step of no time fills the broad phase (so that contacts can be measured at once);
        // the walls' boxes there are grown by half this prediction distance, for good
        world.integration_parameters.normalized_prediction_distance = WALL_PREDICTION as f32;
        world.integration_parameters.dt = 0.0;
        world.step();
        Ok(Self {
            world,
            robot,
            guard: ContactGuard::default(),
            deepest: 0.0,
            obstacles: handles,
            shape,
            origin,
            walls: local_walls,
            obstacle_shapes: obstacles.iter().map(|o| o.shape.vertices.clone()).collect(),
            obstacle_poses,
            obstacle_radii: obstacles.iter().map(|o| o.bounding_radius()).collect(),
            achieved: [0.0; 3],
            substeps: 0,
            scratch: Vec::new(),
            near: Vec::new(),
            closing: Vec::new(),
            near_valid: false,
            placed: Some(Pose2::new(s[0], s[1], wrap_angle(start.yaw))),
            #[cfg(test)]
            bounds_measured: 0,
            coarse_split: COARSE_SPLIT,
            #[cfg(test)]
            coarse_kept: 0,
            #[cfg(test)]
            coarse_redone: 0,
        })
    }

    /// The world-frame point at the origin of rapier's local frame.
    pub fn origin(&self) -> Point2 {
        self.origin
    }

    /// The robot's pose in the local frame.
    fn local_robot_pose(&self) -> Pose2 {
        if let Some(p) = self.placed {
            return p;
        }
        let b = &self.world.bodies[self.robot];
        let t = b.translation();
        Pose2::new(t.x as Real, t.y as Real, wrap_angle(b.rotation().angle() as Real))
    }

    /// The robot's true pose: until the robot moves, exactly where it was placed (at the
    /// start or by [`PhysicsScene::set_robot_pose`]).
    pub fn robot_pose(&self) -> Pose2 {
        let p = self.local_robot_pose();
        Pose2::new(p.x + self.origin[0], p.y + self.origin[1], p.yaw)
    }

    /// The robot's world-frame velocity `(vx, vy, ω)` after the last step.
    pub fn robot_velocity(&self) -> [Real; 3] {
        let b = &self.world.bodies[self.robot];
        let l = b.linvel();
        [l.x as Real, l.y as Real, b.angvel() as Real]
    }

    /// The body-frame velocity `(vx, vy, ω)` the robot achieved in the last step: the command
    /// unless contacts changed it (then the solver's velocity, in the body frame of the
    /// step's start, where the command applied); 0 before any step.
    pub fn achieved_velocity(&self) -> [Real; 3] {
        self.achieved
    }

    /// Places the robot (no physics).
    pub fn set_robot_pose(&mut self, p: Pose2) -> Result<()> {
        p.validate("pose")?;
        let (x, y) = (p.x - self.origin[0], p.y - self.origin[1]);
        let b = &mut self.world.bodies[self.robot];
        b.set_position(rapier2d::math::Pose::new(v(x, y), p.yaw as f32), true);
        self.near_valid = false;
        self.placed = Some(Pose2::new(x, y, wrap_angle(p.yaw)));
        Ok(())
    }

    fn obstacle_local_pose(&self, o: &MovingObstacle, t: Real) -> Pose2 {
        let p = o.trajectory.pose_at(t);
        Pose2::new(p.x - self.origin[0], p.y - self.origin[1], p.yaw)
    }

    /// One step of `dt` seconds: the robot moves with body-frame velocity `(vx, vy, ω)` unless
    /// contacts stop it; each obstacle moves to its pose at `t_next` (s). Returns the contacts.
    ///
    /// Where the robot and a wall or obstacle may meet during the step (their exact distance
    /// at its start below how far they can close in), the step is split into rapier steps in
    /// which they close in by at most [`SUBSTEP_REACH`] each (the command's world-frame
    /// velocity held, the obstacles at their scripted poses), contacts predicted that far
    /// ahead: rapier's solver keeps the footprint out of walls only for contacts it found at
    /// the start of its step. A step that would be split into at most [`COARSE_SPLIT`] rapier
    /// steps is first taken as one, its solver substepped as often, and kept if it ends with
    /// the footprint no deeper than [`DEEP_CONTACT`] in anything (measured exactly, as every
    /// step's contacts are); otherwise it is taken again from its start, split.
    pub fn step(&mut self, body_velocity: [Real; 3], dt: Real, obstacles: &[MovingObstacle], t_next: Real) -> Result<ContactReport> {
        self.check_step(body_velocity, dt, obstacles)?;
        let yaw = self.local_robot_pose().yaw;
        let (s, c) = yaw.sin_cos();
        let [bx, by, w] = body_velocity;
        let t0 = t_next - dt;
        let robot_reach = self.shape.step_reach(body_velocity, dt);
        // how far the robot and each thing near enough to meet it can close in (from the
        // distances the last step measured at its end where they reach far enough: the same
        // walls within `grow` are among them, so `need` is the same)
        let mut closing = std::mem::take(&mut self.closing);
        closing.clear();
        closing.push(robot_reach);
        closing.extend(obstacles.iter().zip(&self.obstacle_radii).map(|(o, &r)| robot_reach + o.travel(t0, t_next, r)));
        let closing_of = |obstacle: Option<usize>| closing[obstacle.map_or(0, |k| k + 1)];
        let mut need: Real = 0.0;
        let grow = robot_reach + PREDICTION_MARGIN;
        let reach = |obstacle: Option<usize>| closing_of(obstacle) + PREDICTION_MARGIN;
        let mut consider = |m: Measured| {
            if m.d <= reach(m.obstacle) {
                need = need.max(closing_of(m.obstacle));
            }
        };
        if self.near_valid && grow <= NEAR_GROW {
            let pose = self.local_robot_pose();
            for i in 0..self.near.len() {
                let m = self.near[i];
                // (a far obstacle's bound is measured exactly where the step may reach it)
                consider(match m.obstacle {
                    Some(k) if !m.exact && m.d <= reach(m.obstacle) => {
                        #[cfg(test)]
                        {
                            self.bounds_measured += 1;
                        }
                        Measured { d: self.obstacle_distance(pose, k), obstacle: Some(k), exact: true }
                    }
                    _ => m,
                });
            }
        } else {
            self.measure(grow, reach, &mut consider);
        }
        self.closing = closing;
        let n = ((need / SUBSTEP_REACH).ceil() as usize).clamp(1, MAX_SUBSTEPS);
        let lin = v(c * bx - s * by, s * bx + c * by);
        // (more solver sweeps while the footprint is in a wall deeper than the slop: at the
        // last step's end, then in the contacts of each rapier step)
        let start_deepest = if self.near_valid { self.deepest } else { 0.0 };
        let deep = start_deepest > DEEP_CONTACT;
        let start = (*self.world.bodies[self.robot].position(), self.placed);
        if n > 1 && n <= self.coarse_split && !deep {
            // one rapier step, its solver substepped as the split would be, kept if the
            // footprint ends no deeper than `DEEP_CONTACT` (see `COARSE_SPLIT`)
            let seen = self.advance(1, n, need, lin, w, dt, obstacles, t_next, false);
            let rep = self.finish(body_velocity, s, c);
            if rep.max_penetration <= DEEP_CONTACT {
                #[cfg(test)]
                {
                    self.coarse_kept += 1;
                }
                self.renew_lost_contacts(start_deepest, seen);
                return Ok(rep);
            }
            #[cfg(test)]
            {
                self.coarse_redone += 1;
            }
            self.restore(start, obstacles, t0);
        }
        let seen = self.advance(n, 1, need, lin, w, dt, obstacles, t_next, deep);
        let rep = self.finish(body_velocity, s, c);
        if rep.max_penetration > 2.0 * DEEP_CONTACT && seen < ALLOWED_LINEAR_ERROR {
            // more than twice `DEEP_CONTACT` deep in something that rapier's solver was given
            // no penetrating contact with in any of the step's rapier steps: lost (see
            // `renew_lost_contacts`; a solver that merely gave way in the last rapier step, its
            // contact still ahead at that step's start, ends shallower); once more, with the
            // robot's contacts found afresh
            self.restore(start, obstacles, t0);
            self.renew_collider();
            self.advance(n, 1, need, lin, w, dt, obstacles, t_next, deep);
            return Ok(self.finish(body_velocity, s, c));
        }
        self.renew_lost_contacts(start_deepest, seen);
        Ok(rep)
    }

    /// Where the footprint was `start_deepest` (m) in a wall or obstacle at a step's start
    /// but rapier's solver was given no contact that deep during the step (`seen`, the deepest
    /// it was given), rapier has lost the contact: the robot's collider is inserted afresh, so
    /// that the next step finds its contacts anew. Seen in `dynamic_obstacles`: the manifold
    /// rapier kept from step to step for the robot and a 30 m wall had normal (0.894, −0.447)
    /// and points 0.49 and 0.77 m apart while the footprint was 7.5 mm deep in that wall, and
    /// the robot sank into it by 2–6 mm a step, 1.2–1.5 cm in all, until parry found the
    /// contact again; with the collider inserted afresh it came back out at once.
    fn renew_lost_contacts(&mut self, start_deepest: Real, seen: Real) {
        if start_deepest > ALLOWED_LINEAR_ERROR && seen < start_deepest - ALLOWED_LINEAR_ERROR {
            self.renew_collider();
        }
    }

    /// Inserts the robot's collider afresh: rapier forgets the contacts it kept for it.
    fn renew_collider(&mut self) {
        let h = self.world.bodies[self.robot].colliders()[0];
        if let Some(co) = self.world.remove_collider(h) {
            self.world.insert_collider(co, Some(self.robot));
        }
    }

    /// Puts the robot back at `start` (its rapier pose and `placed`) and the obstacles at
    /// their poses at `t0`, the start of a step to be taken again.
    fn restore(&mut self, start: (rapier2d::math::Pose, Option<Pose2>), obstacles: &[MovingObstacle], t0: Real) {
        self.world.bodies[self.robot].set_position(start.0, true);
        self.placed = start.1;
        self.place_obstacles(obstacles, t0);
    }

    /// Puts each obstacle at its scripted pose at time `t` (no physics).
    fn place_obstacles(&mut self, obstacles: &[MovingObstacle], t: Real) {
        for (k, o) in obstacles.iter().enumerate() {
            let p = self.obstacle_local_pose(o, t);
            self.obstacle_poses[k] = p;
            self.world.bodies[self.obstacles[k]].set_position(rapier2d::math::Pose::new(v(p.x, p.y), p.yaw as f32), true);
        }
    }

    /// `n` rapier steps of `dt / n`, each solver-substepped `inner` times, the robot at world
    /// velocity `lin`, `w`, the obstacles moved to their scripted poses (see [`Self::step`]).
    /// Returns the deepest penetration (m) among the solver contacts rapier was given.
    #[allow(clippy::too_many_arguments)]
    fn advance(&mut self, n: usize, inner: usize, need: Real, lin: Vector, w: Real, dt: Real, obstacles: &[MovingObstacle], t_next: Real, mut deep: bool) -> Real {
        let t0 = t_next - dt;
        let h = dt / n as Real;
        self.world.integration_parameters.dt = h as f32;
        self.world.integration_parameters.num_solver_iterations = inner;
        self.world.integration_parameters.normalized_prediction_distance = (need / n as Real + PREDICTION_MARGIN) as f32;
        let mut seen: Real = 0.0;
        for i in 1..=n {
            let t = if i == n { t_next } else { t0 + i as Real * h };
            let rb = &mut self.world.bodies[self.robot];
            rb.set_linvel(lin, true);
            rb.set_angvel(w as f32, true);
            for (k, o) in obstacles.iter().enumerate() {
                let p = self.obstacle_local_pose(o, t);
                self.obstacle_poses[k] = p;
                self.world.bodies[self.obstacles[k]].set_next_kinematic_position(rapier2d::math::Pose::new(v(p.x, p.y), p.yaw as f32));
            }
            self.world.integration_parameters.num_internal_pgs_iterations = if deep { DEEP_PGS_ITERATIONS } else { 1 };
            self.guard.deepest.store(0.0f32.to_bits(), Ordering::Relaxed);
            self.world.step_with_events(&self.guard, &());
            let d = f32::from_bits(self.guard.deepest.load(Ordering::Relaxed)) as Real;
            seen = seen.max(d);
            deep |= d > DEEP_CONTACT;
        }
        self.placed = None;
        self.substeps += n as u64;
        seen
    }

    /// After a step's rapier steps: the achieved velocity (in the body frame of the step's
    /// start, yaw's sine and cosine `s`, `c`), the contacts, and the distances the next step
    /// starts from.
    fn finish(&mut self, body_velocity: [Real; 3], s: Real, c: Real) -> ContactReport {
        // the achieved velocity, in the body frame the command was given in
        let l = self.world.bodies[self.robot].linvel();
        let (lx, ly, aw) = (l.x as Real, l.y as Real, self.world.bodies[self.robot].angvel() as Real);
        let got = [c * lx + s * ly, -s * lx + c * ly, aw];
        for k in 0..3 {
            self.achieved[k] = if (got[k] - body_velocity[k]).abs() <= VELOCITY_ROUNDING { body_velocity[k] } else { got[k] };
        }
        // the contacts, and the distances the next step starts from
        let mut rep = ContactReport::default();
        let mut near = std::mem::take(&mut self.near);
        near.clear();
        self.measure(
            NEAR_GROW,
            |_| CONTACT_TOLERANCE,
            |m| {
                near.push(m);
                rep.tally(m);
            },
        );
        self.near = near;
        self.near_valid = true;
        self.deepest = rep.max_penetration;
        rep
    }

    /// Rapier steps taken by [`PhysicsScene::step`] so far (more than its calls where it split
    /// steps near walls; a coarse step taken again split counts its rapier step too).
    pub fn rapier_steps(&self) -> u64 {
        self.substeps
    }

    /// One step of `dt` seconds in which nothing can touch the robot (the caller checked the
    /// clearance against how far robot and obstacles move): the robot flies free and each
    /// obstacle moves to its pose at `t_next`, without the solver. The robot's pose is
    /// integrated as rapier's solver integrates a body free of constraints (its substeps, each
    /// a linearised rotation, renormalised, then the translation), so the two paths agree to
    /// rounding. Returns no contacts.
    pub fn step_free(&mut self, body_velocity: [Real; 3], dt: Real, obstacles: &[MovingObstacle], t_next: Real) -> Result<ContactReport> {
        self.check_step(body_velocity, dt, obstacles)?;
        let yaw = self.local_robot_pose().yaw;
        let (s, c) = yaw.sin_cos();
        let [bx, by, w] = body_velocity;
        let (lin, ang) = (v(c * bx - s * by, s * bx + c * by), w as f32);
        let substeps = SOLVER_SUBSTEPS;
        let h = dt as f32 / substeps as f32;
        let rb = &mut self.world.bodies[self.robot];
        rb.set_linvel(lin, true);
        rb.set_angvel(ang, true);
        let mut pose = *rb.position();
        for _ in 0..substeps {
            let (re, im, dang) = (pose.rotation.re, pose.rotation.im, ang * h);
            pose.rotation = rapier2d::math::Rotation::from_cos_sin_unchecked(re - dang * im, im + dang * re);
            pose.rotation.normalize_mut();
            pose.translation += lin * h;
        }
        rb.set_position(pose, true);
        self.placed = None;
        self.place_obstacles(obstacles, t_next);
        self.achieved = body_velocity;
        self.near_valid = false;
        Ok(ContactReport::default())
    }

    fn check_step(&self, body_velocity: [Real; 3], dt: Real, obstacles: &[MovingObstacle]) -> Result<()> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::invalid("dt", format!("must be finite and > 0, got {dt}")));
        }
        if !body_velocity.iter().all(|x| x.is_finite()) {
            return Err(Error::invalid("velocity", format!("must be finite, got {body_velocity:?}")));
        }
        if obstacles.len() != self.obstacles.len() {
            return Err(Error::DimensionMismatch { name: "obstacles", expected: self.obstacles.len(), got: obstacles.len() });
        }
        Ok(())
    }

    /// The robot's contacts at the current poses, judged exactly in `f64` on the true
    /// footprint (see [`super::footprint::footprint_signed_distance`]): every wall within
    /// [`CONTACT_TOLERANCE`] (candidates: the walls whose boxes in rapier's broad-phase tree
    /// meet the footprint's box grown by a centimetre; only fixed colliders, whose boxes never
    /// go stale) and every obstacle at its scripted pose.
    pub fn contacts(&mut self) -> ContactReport {
        let mut rep = ContactReport::default();
        self.measure(0.0, |_| CONTACT_TOLERANCE, |m| rep.tally(m));
        rep
    }

    /// Calls `f` with the exact signed distance (m) from the footprint to every wall that may
    /// lie within `grow` (plus a centimetre) of it, and to every obstacle at its current pose
    /// that may lie within `reach(Some(k))` of it; to an obstacle farther than that, with a
    /// lower bound of the distance above `reach` (from the two outlines' bounding circles).
    fn measure(&mut self, grow: Real, reach: impl Fn(Option<usize>) -> Real, mut f: impl FnMut(Measured)) {
        let pose = self.local_robot_pose();
        let shape = self.shape;
        let r = shape.corner_radius;
        // the footprint's box, grown by a centimetre (more than the tolerance and `f32`
        // rounding) and by `grow`
        let (s, c) = pose.yaw.sin_cos();
        let (hx, hy) = (0.5 * shape.length, 0.5 * shape.width);
        let g = grow + 0.01;
        let (ex, ey) = (hx * c.abs() + hy * s.abs() + g, hx * s.abs() + hy * c.abs() + g);
        let aabb = rapier2d::parry::bounding_volume::Aabb::new(v(pose.x - ex, pose.y - ey), v(pose.x + ex, pose.y + ey));
        let mut q = std::mem::take(&mut self.scratch);
        for (_, co) in self.world.intersect_aabb_conservative(aabb, QueryFilter::only_fixed()) {
            let [a, b] = self.walls[co.user_data as usize];
            q.clear();
            q.extend([pose.inverse_transform_point(a), pose.inverse_transform_point(b)]);
            f(Measured { d: inner_rect_signed_distance(&shape, &q) - r, obstacle: None, exact: true });
        }
        self.scratch = q;
        let robot_radius = shape.half_diagonal();
        for k in 0..self.obstacle_shapes.len() {
            let op = self.obstacle_poses[k];
            // (the footprint lies within `robot_radius` of its centre, the outline within its
            // radius of its origin; less a nanometre for rounding)
            let bound = (op.x - pose.x).hypot(op.y - pose.y) - robot_radius - self.obstacle_radii[k] - 1e-9;
            if bound > reach(Some(k)) {
                f(Measured { d: bound, obstacle: Some(k), exact: false });
            } else {
                f(Measured { d: self.obstacle_distance(pose, k), obstacle: Some(k), exact: true });
            }
        }
    }

    /// The exact signed distance (m) from the footprint at `pose` (local frame) to obstacle `k`
    /// at its current pose.
    fn obstacle_distance(&mut self, pose: Pose2, k: usize) -> Real {
        let op = self.obstacle_poses[k];
        let mut q = std::mem::take(&mut self.scratch);
        q.clear();
        q.extend(self.obstacle_shapes[k].iter().map(|&p| pose.inverse_transform_point(op.transform_point(p))));
        let d = inner_rect_signed_distance(&self.shape, &q) - self.shape.corner_radius;
        self.scratch = q;
        d
    }
}

/// Rapier's physics hook on the robot's solver contacts, in one pass over them: it drops those
/// deeper than [`MAX_CONTACT_DEPTH`], and keeps the deepest penetration of the others in
/// `deepest` (`f32` bits, which order non-negative values as the values; reset before each
/// rapier step, see [`DEEP_CONTACT`]). No step sinks
/// the robot 20 cm, but parry can report such a contact where a corner of the footprint touches
/// a wall's end exactly (seen in a concave corner of walls: the manifold of the wall along
/// which the robot lay had the wall's direction as its normal and a point 10.1 m deep, and the
/// solver's correction threw the robot 1.9 cm sideways and 2.2° round in one 0.01 s step,
/// 2.1 cm into the other wall).
#[derive(Debug, Default)]
struct ContactGuard {
    deepest: AtomicU32,
}

impl PhysicsHooks for ContactGuard {
    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        if let Some(m) = context.rigid_mut() {
            m.solver_contacts.retain(|c| c.dist >= -MAX_CONTACT_DEPTH as f32);
            let deepest = m.solver_contacts.iter().fold(0.0f32, |d, c| d.max(-c.dist));
            self.deepest.fetch_max(deepest.to_bits(), Ordering::Relaxed);
        }
    }
}

/// The deepest solver contact (m) rapier's solver is given (see [`ContactGuard`]): far
/// beyond the depths steps reach (about a centimetre; 5.5 cm for a robot driving into a wall
/// at 16 m/s, see `a_fast_robot_stops_at_a_wall`), far below those of the contacts dropped.
const MAX_CONTACT_DEPTH: Real = 0.2;

/// A distance [`PhysicsScene::measure`] gives: to a wall (`obstacle` None) or an obstacle, `d`
/// exact or (`exact` false, a far obstacle) a lower bound.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Measured {
    d: Real,
    obstacle: Option<usize>,
    exact: bool,
}

/// How far (m) the robot and a wall or obstacle may close in during one rapier step (see
/// [`PhysicsScene::step`]).
pub const SUBSTEP_REACH: Real = 0.01;
/// How far (m) beyond the footprint [`PhysicsScene::step`] measures the walls at its end, for
/// the next step to start from (a step reaching farther, above about 3 m/s at 0.02 s, measures
/// again).
const NEAR_GROW: Real = 0.08;
/// Steps that the split would cut into at most this many rapier steps are first taken as one
/// rapier step whose solver is substepped as often (contacts found once, at the step's start),
/// and kept if the footprint ends no deeper than [`DEEP_CONTACT`] in any wall or obstacle,
/// which [`PhysicsScene::step`] measures exactly at every step's end; otherwise the robot and
/// the obstacles go back to the step's start and the step is split. Measured: the physics
/// bench's steps pressed into walls reach 1.06 cm (two rapier steps); taken coarse, 1.27
/// rapier steps per step instead of 1.97. Taking every step coarse first kept the contacts
/// rigid, but stale contacts hold the robot back where it only passes by a corner: steps that
/// ended out of contact with a velocity other than the command rose from 670 to 2 241 (in
/// 192 000 steps of a random drive), 731 with two, 747 with three.
const COARSE_SPLIT: usize = 2;
/// The most rapier steps one step is split into.
const MAX_SUBSTEPS: usize = 64;
/// Solver substeps per rapier step: one (the steps near walls are split already; with two,
/// penetrations under a random stress test were up to 1.3 cm, with one 0.7 cm).
const SOLVER_SUBSTEPS: usize = 1;
/// A penetration (m) past which the solver sweeps the contacts [`DEEP_PGS_ITERATIONS`] times
/// instead of once.
const DEEP_CONTACT: Real = 0.004;
/// See [`DEEP_CONTACT`].
const DEEP_PGS_ITERATIONS: usize = 4;
/// Rapier's slop (m).
const ALLOWED_LINEAR_ERROR: Real = 0.001;
/// Added to how far bodies can move in a step for the contacts' prediction (m).
const PREDICTION_MARGIN: Real = 0.01;
/// The prediction distance (m) the walls' broad-phase boxes are grown for (by half of it, once).
/// With the robot's box, grown by half the last rapier step's prediction (at least
/// [`PREDICTION_MARGIN`]), every wall within a rapier step's prediction is paired with the robot
/// while that is at most 5.5 cm: for steps closing in by up to `MAX_SUBSTEPS` × 4.5 cm = 2.9 m
/// (29 m/s at 0.1 s). At 0.6 the robot driving down a 1.2 m lane was
/// paired with both walls, and rapier's narrow phase tested them every step (a fifth of a
/// free step's time).
const WALL_PREDICTION: Real = 0.1;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::footprint::footprint_segment_distance;
    use crate::world::{Polygon, Trajectory};
    use rand::{Rng, SeedableRng};

    fn corridor() -> Vec<Segment> {
        vec![Segment::new([-5.0, -0.6], [20.0, -0.6], 2.0), Segment::new([-5.0, 0.6], [20.0, 0.6], 2.0), Segment::new([6.0, -0.6], [6.0, 0.6], 2.0)]
    }

    #[test]
    fn free_driving_follows_the_command_without_contacts() {
        let mut sc = PhysicsScene::new(RobotShape::default(), &corridor(), &[], Pose2::default(), 0.0).unwrap();
        for _ in 0..50 {
            let rep = sc.step([1.0, 0.0, 0.0], 0.02, &[], 0.0).unwrap();
            assert!(!rep.any());
        }
        let p = sc.robot_pose();
        assert!((p.x - 1.0).abs() < 1e-3 && p.y.abs() < 1e-4 && p.yaw.abs() < 1e-4, "{p:?}");
    }

    /// Free flight without the solver lands where rapier's solver puts the robot.
    #[test]
    fn free_steps_agree_with_the_solver_away_from_walls() {
        let walls = [Segment::new([-50.0, -20.0], [50.0, -20.0], 2.0)];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let mut a = PhysicsScene::new(RobotShape::default(), &walls, &[], Pose2::new(0.0, 0.0, 0.3), 0.0).unwrap();
        let mut b = PhysicsScene::new(RobotShape::default(), &walls, &[], Pose2::new(0.0, 0.0, 0.3), 0.0).unwrap();
        let (mut worst, mut path): (Real, Real) = (0.0, 0.0);
        for k in 0..500 {
            let before = a.robot_pose();
            let cmd = [rng.random_range(-1.6..1.6), rng.random_range(-0.8..0.8), rng.random_range(-1.5..1.5)];
            a.step(cmd, 0.02, &[], 0.0).unwrap();
            b.step_free(cmd, 0.02, &[], 0.0).unwrap();
            let (pa, pb) = (a.robot_pose(), b.robot_pose());
            path += (pa.x - before.x).hypot(pa.y - before.y);
            worst = worst.max((pa.x - pb.x).abs()).max((pa.y - pb.y).abs()).max(wrap_angle(pa.yaw - pb.yaw).abs());
            if k % 50 == 0 {
                // resynchronise, so each stretch compares fresh rounding
                b.set_robot_pose(pa).unwrap();
            }
        }
        assert!(worst < 1e-6, "free flight off the solver's pose by {worst}");
        // (the solver's velocity after a step is the command's to `f32` rounding)
        let (va, vb) = (a.robot_velocity(), b.robot_velocity());
        assert!((0..3).all(|k| (va[k] - vb[k]).abs() < 1e-6), "{va:?} vs {vb:?}");
        assert_eq!(a.achieved_velocity(), b.achieved_velocity());
        assert!(path > 5.0, "the robot moved ({path} m)");
        println!("free flight against the solver: worst {worst:e}");
    }

    #[test]
    fn driving_into_the_end_wall_is_reported_and_stopped() {
        let walls = corridor();
        let mut sc = PhysicsScene::new(RobotShape::default(), &walls, &[], Pose2::new(4.0, 0.0, 0.0), 0.0).unwrap();
        let mut touched = false;
        for _ in 0..150 {
            let rep = sc.step([1.0, 0.0, 0.0], 0.02, &[], 0.0).unwrap();
            touched |= rep.with_walls > 0;
        }
        let p = sc.robot_pose();
        assert!(touched);
        // front at x = p.x + 0.55 must not be (much) beyond the wall at 6
        assert!(p.x + 0.55 < 6.0 + 0.05, "{p:?}");
    }

    /// Pressed into the walls and obstacles of `dynamic_obstacles` (and a pedestrian walking
    /// into it) as the physics bench presses it, at 1.06 cm a step: the steps the split would
    /// cut in two are taken as one rapier step and kept, and the walls stay as rigid as with
    /// every step split.
    #[test]
    fn pressed_steps_are_taken_coarse_and_the_walls_stay_rigid() {
        let s = crate::world::preset("dynamic_obstacles").unwrap();
        let mut obstacles = s.obstacles.clone();
        obstacles.push(MovingObstacle { name: "pedestrian".into(), shape: Polygon::rect(-0.2, -0.25, 0.2, 0.25, 1.8), trajectory: Trajectory::walk(&[[25.0, 0.3], [2.0, 0.3]], 1.2, 0.0).unwrap() });
        let drive = |coarse_split: usize| {
            let mut sc = PhysicsScene::new(RobotShape::default(), &s.map.segments, &obstacles, s.start, 0.0).unwrap();
            sc.coarse_split = coarse_split;
            let (mut deepest, mut touching): (Real, usize) = (0.0, 0);
            for k in 1..=1500 {
                let rep = sc.step([0.5, 0.0, 0.05], 0.02, &obstacles, k as Real * 0.02).unwrap();
                deepest = deepest.max(rep.max_penetration);
                touching += rep.any() as usize;
            }
            (sc.rapier_steps() as Real / 1500.0, deepest, touching, sc.coarse_kept)
        };
        let (split_steps, split_deepest, split_touching, _) = drive(1);
        let (steps, deepest, touching, kept) = drive(COARSE_SPLIT);
        assert!(split_touching > 1000 && touching > 1000, "{split_touching} / {touching} steps in contact");
        assert!(split_steps > 1.9 && steps < 1.4 && kept > 900, "{split_steps} → {steps} rapier steps per step, {kept} kept coarse");
        assert!(split_deepest < 0.01 && deepest < 0.01, "{split_deepest} / {deepest} m deep");
    }

    /// Turning into a corridor's wall at 0.01 s steps, a coarse step that ends deeper than
    /// `DEEP_CONTACT` is taken again from its start, split: the footprint never ends a step
    /// that deep.
    #[test]
    fn a_coarse_step_that_sinks_in_is_taken_again_split() {
        let mut sc = PhysicsScene::new(RobotShape::default(), &corridor(), &[], Pose2::new(0.0, 0.0, 0.0), 0.0).unwrap();
        let mut deepest: Real = 0.0;
        for k in 1..=200 {
            let rep = sc.step([0.3, 0.0, 1.5], 0.01, &[], k as Real * 0.01).unwrap();
            deepest = deepest.max(rep.max_penetration);
        }
        assert!(sc.coarse_kept > 100 && sc.coarse_redone > 0 && deepest > 0.001 && deepest <= DEEP_CONTACT, "{} kept, {} taken again, {deepest} m deep", sc.coarse_kept, sc.coarse_redone);
    }

    /// Fast robots stop at the end wall: at 4 m/s (0.4 m per 0.1 s step, 40 rapier steps of
    /// 1 cm) within 1 cm of it; at 8 and 16 m/s (`MAX_SUBSTEPS` rapier steps of 1.25 and 2.5 cm,
    /// the walls' broad-phase boxes still pairing them with the robot in time) they sink in
    /// deeper (2.7 and 5.5 cm) but stop.
    #[test]
    fn a_fast_robot_stops_at_a_wall() {
        for (speed, rigid) in [(4.0, 0.01), (8.0, 0.03), (16.0, 0.06)] {
            let mut sc = PhysicsScene::new(RobotShape::default(), &corridor(), &[], Pose2::new(-4.0, 0.0, 0.0), 0.0).unwrap();
            let mut deepest: Real = 0.0;
            for k in 1..=40 {
                let rep = sc.step([speed, 0.0, 0.0], 0.1, &[], k as Real * 0.1).unwrap();
                deepest = deepest.max(rep.max_penetration);
            }
            let front = sc.robot_pose().x + 0.55;
            assert!(deepest > 0.0 && deepest < rigid && (front - 6.0).abs() <= deepest + 1e-9, "{speed} m/s: front at {front}, deepest penetration {deepest}");
        }
    }

    #[test]
    fn contact_report_agrees_with_the_exact_footprint_distance() {
        let walls = corridor();
        // overlapping the end wall by 3 cm, then clear of it by 3 cm
        for (x, expect_contact) in [(6.0 - 0.55 + 0.03, true), (6.0 - 0.55 - 0.03, false)] {
            let pose = Pose2::new(x, 0.0, 0.0);
            let exact = walls.iter().map(|s| footprint_segment_distance(&RobotShape::default(), pose, s)).fold(f64::INFINITY, f64::min);
            let mut sc = PhysicsScene::new(RobotShape::default(), &walls, &[], pose, 0.0).unwrap();
            let rep = sc.step([0.0, 0.0, 0.0], 1e-4, &[], 0.0).unwrap();
            assert_eq!(rep.with_walls > 0, expect_contact, "x {x}: {rep:?}");
            assert_eq!(exact == 0.0, expect_contact);
            if expect_contact {
                assert!((rep.max_penetration - 0.03).abs() < 2e-3, "{rep:?}");
            }
        }
    }

    #[test]
    fn moving_obstacle_hits_the_robot() {
        let chair = MovingObstacle {
            name: "chair".into(),
            shape: Polygon::rect(-0.25, -0.25, 0.25, 0.25, 0.9),
            trajectory: Trajectory::linear(Pose2::new(3.0, 0.0, 0.0), Pose2::new(0.0, 0.0, 0.0), 0.0, 2.0),
        };
        let obstacles = [chair];
        let mut sc = PhysicsScene::new(RobotShape::default(), &corridor(), &obstacles, Pose2::default(), 0.0).unwrap();
        let mut hit = false;
        for k in 1..=100 {
            let rep = sc.step([0.0, 0.0, 0.0], 0.02, &obstacles, k as Real * 0.02).unwrap();
            hit |= rep.with_obstacles > 0;
        }
        assert!(hit);
        assert!(sc.robot_pose().x < -0.5, "the chair pushed the robot back: {:?}", sc.robot_pose());
    }

    /// Steps `cached` (reading the distances the last step measured at its end) and `fresh`
    /// (measuring afresh) alike for `steps` steps of random commands held `hold` steps, at
    /// 0.02 s and every third hundred at 0.1 s, and checks that they agree bit for bit.
    /// Returns how many steps read the distances and how many touched something.
    fn cached_and_fresh_agree(walls: &[Segment], obstacles: &[MovingObstacle], steps: usize, hold: usize, speed: Real) -> (PhysicsScene, usize, usize) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut cached = PhysicsScene::new(RobotShape::default(), walls, obstacles, Pose2::default(), 0.0).unwrap();
        let mut fresh = PhysicsScene::new(RobotShape::default(), walls, obstacles, Pose2::default(), 0.0).unwrap();
        let (mut t, mut read, mut touching) = (0.0, 0, 0);
        let mut cmd = [0.0; 3];
        for k in 0..steps {
            if k % hold == 0 {
                cmd = [speed * rng.random_range(-1.6..1.6), speed * rng.random_range(-0.8..0.8), rng.random_range(-1.5..1.5)];
            }
            let dt = if (k / 100) % 3 == 2 { 0.1 } else { 0.02 };
            t += dt;
            read += cached.near_valid as usize;
            fresh.near_valid = false;
            let a = cached.step(cmd, dt, obstacles, t).unwrap();
            let b = fresh.step(cmd, dt, obstacles, t).unwrap();
            assert_eq!(a, b, "step {k}");
            assert_eq!(cached.world.bodies[cached.robot].position(), fresh.world.bodies[fresh.robot].position(), "step {k}");
            assert_eq!(cached.achieved_velocity(), fresh.achieved_velocity(), "step {k}");
            touching += a.any() as usize;
        }
        assert_eq!(cached.rapier_steps(), fresh.rapier_steps());
        (cached, read, touching)
    }

    /// The distances a step measures at its end, read by the next step instead of measuring
    /// again, give the same steps bit for bit as measuring afresh: a random drive through a
    /// corridor with a box pushed into it, at 0.02 s (distances read) and 0.1 s (at speed
    /// measured again), splitting steps near the walls.
    #[test]
    fn steps_from_the_last_steps_distances_are_the_steps_measured_afresh() {
        let pushed =
            MovingObstacle { name: "box".into(), shape: Polygon::rect(-0.3, -0.3, 0.3, 0.3, 1.0), trajectory: Trajectory::linear(Pose2::new(8.0, 0.0, 0.0), Pose2::new(1.0, 0.1, 0.5), 2.0, 12.0) };
        let (sc, read, touching) = cached_and_fresh_agree(&corridor(), &[pushed], 1500, 25, 1.0);
        assert!(sc.rapier_steps() > 1500 + 500, "{} rapier steps for 1500", sc.rapier_steps());
        assert!(read > 1000 && touching > 100, "{read} steps read the distances, {touching} touching");
    }

    /// Far obstacles are measured by a bound, and exactly where a step may reach them, with the
    /// same steps as measuring each exactly: a robot dithering about in the open while
    /// pedestrians circle it at 1.5 m/s, passing within reach and bumping into it.
    #[test]
    fn far_obstacles_bounds_give_the_steps_measured_exactly() {
        let ring = |r: Real, phase: Real| -> Vec<Point2> { (0..=40).map(|i| phase + i as Real * std::f64::consts::PI / 5.0).map(|a| [r * a.cos(), r * a.sin()]).collect() };
        let walker = |name: &str, path: Vec<Point2>| MovingObstacle { name: name.into(), shape: Polygon::rect(-0.2, -0.25, 0.2, 0.25, 1.8), trajectory: Trajectory::walk(&path, 1.5, 0.0).unwrap() };
        let obstacles = [walker("near", ring(0.95, 0.0)), walker("passing", ring(1.05, 1.0)), walker("far", ring(3.0, 2.0))];
        let walls = [Segment::new([-20.0, -20.0], [20.0, -20.0], 2.0)];
        let (sc, read, touching) = cached_and_fresh_agree(&walls, &obstacles, 1500, 5, 0.1);
        assert!(read > 1000 && touching > 50, "{read} steps read the distances, {touching} touching");
        assert!(sc.bounds_measured > 50, "{} bounds measured exactly", sc.bounds_measured);
    }

    /// A placed robot reads exactly where it was placed (rapier's `f32` pose is up to about
    /// 1e-6 m off), at the start and after `set_robot_pose`, and from the first step on where
    /// rapier moved it.
    #[test]
    fn a_placed_robot_reads_exactly_where_it_was_placed() {
        let walls = [Segment::new([0.0, 30.0], [40.0, 30.0], 2.0), Segment::new([0.0, 45.0], [40.0, 45.0], 2.0)];
        let start = Pose2::new(20.05, 38.05, 0.3);
        let mut sc = PhysicsScene::new(RobotShape::default(), &walls, &[], start, 0.0).unwrap();
        assert_eq!(sc.robot_pose(), start);
        let b = &sc.world.bodies[sc.robot];
        let rapier = [b.translation().x as Real + sc.origin[0], b.translation().y as Real + sc.origin[1]];
        assert_ne!(rapier, [start.x, start.y], "the start lies on the f32 grid: the test proves nothing");
        sc.step([0.5, 0.0, 0.0], 0.02, &[], 0.02).unwrap();
        let p = sc.robot_pose();
        assert!((p.x - start.x - 0.01 * start.yaw.cos()).abs() < 1e-5 && p.x != start.x, "{p:?}");
        let again = Pose2::new(12.3456789, 37.1, -2.0);
        sc.set_robot_pose(again).unwrap();
        assert_eq!(sc.robot_pose(), again);
        // an unwrapped yaw reads wrapped
        sc.set_robot_pose(Pose2::new(12.0, 37.0, 7.0)).unwrap();
        assert_eq!(sc.robot_pose().yaw, wrap_angle(7.0));
    }
}
