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

use std::sync::atomic::Ordering;

use rapier2d::prelude::*;

mod contact;

use super::footprint::{inner_rect_signed_distance, RobotShape};
use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::{wrap_angle, MovingObstacle, Point2, Pose2, Segment};
use contact::{ContactGuard, Measured};
pub use contact::{ContactReport, CONTACT_TOLERANCE};

/// What [`PhysicsScene::step`] did so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PhysicsStats {
    /// Rapier steps taken (more than the calls where steps near walls were split).
    pub rapier_steps: u64,
    /// Coarse steps kept (see [`COARSE_SPLIT`]).
    pub coarse_kept: u64,
    /// Coarse steps taken again split because the footprint ended too deep.
    pub coarse_redone: u64,
    /// Far obstacles' bounds measured exactly because the step might reach them.
    pub bounds_measured: u64,
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
    /// What the steps did so far.
    stats: PhysicsStats,
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
    /// [`COARSE_SPLIT`] (tests compare with 1: every step split).
    coarse_split: usize,
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
            stats: PhysicsStats::default(),
            scratch: Vec::new(),
            near: Vec::new(),
            closing: Vec::new(),
            near_valid: false,
            placed: Some(Pose2::new(s[0], s[1], wrap_angle(start.yaw))),
            coarse_split: COARSE_SPLIT,
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
                        self.stats.bounds_measured += 1;
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
                self.stats.coarse_kept += 1;
                self.renew_lost_contacts(start_deepest, seen);
                return Ok(rep);
            }
            self.stats.coarse_redone += 1;
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
        self.stats.rapier_steps += n as u64;
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
        self.stats.rapier_steps
    }

    /// What the steps did so far: rapier steps, coarse steps kept and taken again split, far
    /// obstacles measured exactly.
    pub fn stats(&self) -> PhysicsStats {
        self.stats
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
mod tests;
