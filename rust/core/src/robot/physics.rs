//! The rapier scene: walls (fixed segments), scripted obstacles (kinematic, position-based)
//! and the robot (a dynamic body with the true footprint, driven by velocity each step).
//!
//! Rapier works in `f32`; poses cross over at the boundary (about 1e-5 m at 100 m from the
//! origin). Contacts are measured after each step at the final poses with parry's exact
//! contact query (walls found through rapier's broad-phase tree, every obstacle), within
//! [`CONTACT_TOLERANCE`] (touching counts), and reported as the number of colliders in
//! contact and the deepest penetration (see [`PhysicsScene::contacts`]).

use rapier2d::prelude::*;

use super::footprint::RobotShape;
use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::{wrap_angle, MovingObstacle, Pose2, Segment};

/// Contact points closer than this (m) count as touching: rapier's solver rests bodies up to
/// about a millimetre apart (or into each other).
pub const CONTACT_TOLERANCE: Real = 1e-3;

/// Contacts of the robot after a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactReport {
    /// Contact points with the robot at distance at most [`CONTACT_TOLERANCE`].
    pub count: usize,
    /// Of those, points against walls (static geometry).
    pub with_walls: usize,
    /// Of those, points against moving obstacles.
    pub with_obstacles: usize,
    /// Deepest penetration (m), 0 if none.
    pub max_penetration: Real,
}

impl ContactReport {
    /// Whether the robot touches anything.
    pub fn any(&self) -> bool {
        self.count > 0
    }
}

/// Robot, walls and moving obstacles in one rapier world.
pub struct PhysicsScene {
    world: PhysicsWorld,
    robot: RigidBodyHandle,
    robot_collider: ColliderHandle,
    obstacles: Vec<RigidBodyHandle>,
}

impl std::fmt::Debug for PhysicsScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PhysicsScene").field("bodies", &self.world.bodies.len()).field("colliders", &self.world.colliders.len()).finish()
    }
}

#[inline]
fn v(x: Real, y: Real) -> Vector {
    Vector::new(x as f32, y as f32)
}

impl PhysicsScene {
    /// Builds the scene: `walls` fixed, `obstacles` at their poses at time `t0`, the robot at
    /// `start`.
    pub fn new(shape: RobotShape, walls: &[Segment], obstacles: &[MovingObstacle], start: Pose2, t0: Real) -> Result<Self> {
        shape.validate()?;
        start.validate("start")?;
        let mut world = PhysicsWorld { gravity: Vector::ZERO, ..Default::default() };
        // a velocity-driven body against static walls: two iterations resolve contacts; at
        // ≤ 1.6 m/s and dt ≤ 0.1 s the body moves less than its half width per step, so no CCD
        world.integration_parameters.num_solver_iterations = 2;
        let wall_body = world.insert_body(RigidBodyBuilder::fixed());
        for s in walls {
            s.validate("walls")?;
            world.insert_collider(ColliderBuilder::segment(v(s.a[0], s.a[1]), v(s.b[0], s.b[1])).friction(0.0), Some(wall_body));
        }
        let mut handles = Vec::with_capacity(obstacles.len());
        for o in obstacles {
            o.validate()?;
            let pts: Vec<Vector> = o.shape.vertices.iter().map(|p| v(p[0], p[1])).collect();
            let collider = ColliderBuilder::convex_polyline(pts).ok_or_else(|| Error::invalid("obstacle.shape", format!("`{}`: no convex hull", o.name)))?;
            let p = o.trajectory.pose_at(t0);
            let body = RigidBodyBuilder::kinematic_position_based().translation(v(p.x, p.y)).rotation(p.yaw as f32);
            let (h, _) = world.insert(body, collider.friction(0.0));
            handles.push(h);
        }
        let r = shape.corner_radius;
        let (hx, hy) = (0.5 * shape.length, 0.5 * shape.width);
        let collider = if r > 0.0 { ColliderBuilder::round_cuboid((hx - r) as f32, (hy - r) as f32, r as f32) } else { ColliderBuilder::cuboid(hx as f32, hy as f32) };
        let body = RigidBodyBuilder::dynamic().translation(v(start.x, start.y)).rotation(start.yaw as f32).can_sleep(false);
        // Spot's mass: ~32 kg over 0.55 m²
        let (robot, robot_collider) = world.insert(body, collider.density(58.0).friction(0.0));
        Ok(Self { world, robot, robot_collider, obstacles: handles })
    }

    /// The robot's true pose.
    pub fn robot_pose(&self) -> Pose2 {
        let b = &self.world.bodies[self.robot];
        let t = b.translation();
        Pose2::new(t.x as Real, t.y as Real, wrap_angle(b.rotation().angle() as Real))
    }

    /// The robot's world-frame velocity `(vx, vy, ω)` after the last step.
    pub fn robot_velocity(&self) -> [Real; 3] {
        let b = &self.world.bodies[self.robot];
        let l = b.linvel();
        [l.x as Real, l.y as Real, b.angvel() as Real]
    }

    /// Places the robot (no physics).
    pub fn set_robot_pose(&mut self, p: Pose2) -> Result<()> {
        p.validate("pose")?;
        let b = &mut self.world.bodies[self.robot];
        b.set_position(rapier2d::math::Pose::new(v(p.x, p.y), p.yaw as f32), true);
        Ok(())
    }

    /// One step of `dt` seconds: the robot moves with body-frame velocity `(vx, vy, ω)` unless
    /// contacts stop it; each obstacle moves to its pose at `t_next` (s). Returns the contacts.
    pub fn step(&mut self, body_velocity: [Real; 3], dt: Real, obstacles: &[MovingObstacle], t_next: Real) -> Result<ContactReport> {
        self.check_step(body_velocity, dt, obstacles)?;
        let yaw = self.robot_pose().yaw;
        let (s, c) = yaw.sin_cos();
        let [bx, by, w] = body_velocity;
        let rb = &mut self.world.bodies[self.robot];
        rb.set_linvel(v(c * bx - s * by, s * bx + c * by), true);
        rb.set_angvel(w as f32, true);
        for (h, o) in self.obstacles.iter().zip(obstacles) {
            let p = o.trajectory.pose_at(t_next);
            self.world.bodies[*h].set_next_kinematic_position(rapier2d::math::Pose::new(v(p.x, p.y), p.yaw as f32));
        }
        self.world.integration_parameters.dt = dt as f32;
        self.world.step();
        Ok(self.contacts())
    }

    /// One step of `dt` seconds in which nothing can touch the robot (the caller checked the
    /// clearance against how far robot and obstacles move): the robot flies free and each
    /// obstacle moves to its pose at `t_next`, without the solver. The robot's pose is
    /// integrated as rapier's solver integrates a body free of constraints (its substeps, each
    /// a linearised rotation, renormalised, then the translation), so the two paths agree to
    /// rounding. Returns no contacts.
    pub fn step_free(&mut self, body_velocity: [Real; 3], dt: Real, obstacles: &[MovingObstacle], t_next: Real) -> Result<ContactReport> {
        self.check_step(body_velocity, dt, obstacles)?;
        let yaw = self.robot_pose().yaw;
        let (s, c) = yaw.sin_cos();
        let [bx, by, w] = body_velocity;
        let (lin, ang) = (v(c * bx - s * by, s * bx + c * by), w as f32);
        let substeps = self.world.integration_parameters.num_solver_iterations.max(1);
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
        for (h, o) in self.obstacles.iter().zip(obstacles) {
            let p = o.trajectory.pose_at(t_next);
            self.world.bodies[*h].set_position(rapier2d::math::Pose::new(v(p.x, p.y), p.yaw as f32), true);
        }
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

    /// The robot's contacts at the current poses: every wall collider whose shape comes within
    /// [`CONTACT_TOLERANCE`] of the footprint (candidates from rapier's broad-phase tree, only
    /// fixed colliders, whose boxes never go stale) and every obstacle, each measured with
    /// parry's exact contact query.
    pub fn contacts(&self) -> ContactReport {
        let mut rep = ContactReport::default();
        let robot = &self.world.colliders[self.robot_collider];
        let rpos = *robot.position();
        let tol = CONTACT_TOLERANCE as f32;
        let mut measure = |co: &Collider, is_wall: bool| {
            if let Ok(Some(c)) = rapier2d::parry::query::contact(&rpos, robot.shape(), co.position(), co.shape(), tol) {
                if c.dist <= tol {
                    rep.count += 1;
                    if is_wall {
                        rep.with_walls += 1;
                    } else {
                        rep.with_obstacles += 1;
                    }
                    rep.max_penetration = rep.max_penetration.max(-(c.dist as Real));
                }
            }
        };
        let aabb = robot.shape().compute_aabb(&rpos);
        let half = (aabb.maxs - aabb.mins) * 0.5 + Vector::splat(2.0 * tol);
        let probe = rapier2d::parry::shape::Cuboid::new(half);
        let probe_pos = rapier2d::math::Pose::from_translation((aabb.maxs + aabb.mins) * 0.5);
        let filter = QueryFilter::only_fixed().exclude_collider(self.robot_collider);
        for (_, co) in self.world.intersect_shape(probe_pos, &probe, filter) {
            measure(co, true);
        }
        for h in &self.obstacles {
            for &ch in self.world.bodies[*h].colliders() {
                measure(&self.world.colliders[ch], false);
            }
        }
        rep
    }
}

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
        assert_eq!(a.robot_velocity(), b.robot_velocity());
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
}
