//! Scripted moving obstacles: kinematic bodies that follow time-stamped key poses.
//!
//! A chair pushed toward the robot, a door swinging on its hinge, a pedestrian walking a
//! corridor: each is a solid polygon in its own frame plus a [`Trajectory`] of that frame.

use serde::{Deserialize, Serialize};

use super::geometry::{norm2, sub2, wrap_angle, Point2, Polygon, Pose2, Segment};
use crate::error::{Error, Result};
use crate::math::Real;

/// The latest time (s) of a scenario's scripts (obstacles' key poses, odometry faults).
pub const TIME_LIMIT: Real = 1.0e7;

/// How long (s) a walker ([`Trajectory::walk`]) takes to turn at a corner.
pub const WALK_TURN_TIME: Real = 0.2;

/// Piecewise-linear key poses `(t, pose)`; before the first key and after the last the pose is
/// held. Yaw is interpolated along the shorter arc.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Trajectory {
    /// Strictly increasing times (s) with the poses reached then.
    pub keys: Vec<(Real, Pose2)>,
}

impl Trajectory {
    /// A body that never moves.
    pub fn fixed(pose: Pose2) -> Self {
        Self { keys: vec![(0.0, pose)] }
    }

    /// Moves from `from` to `to` between `t_start` and `t_end` (an object pushed, a door swung).
    pub fn linear(from: Pose2, to: Pose2, t_start: Real, t_end: Real) -> Self {
        Self { keys: vec![(t_start, from), (t_end, to)] }
    }

    /// Walks through `waypoints` at constant `speed` (m/s) starting at `t_start`, facing the
    /// direction of travel: along each leg the heading is the leg's direction, except that at
    /// each corner it turns (along the shorter arc, at a constant rate) from the previous leg's
    /// direction to the new one during the first [`WALK_TURN_TIME`] seconds of the new leg, or
    /// over the whole leg if it is shorter than that. The walker keeps its speed through the
    /// turn.
    pub fn walk(waypoints: &[Point2], speed: Real, t_start: Real) -> Result<Self> {
        if !(speed.is_finite() && speed > 0.0) {
            return Err(Error::invalid("speed", format!("must be finite and > 0, got {speed}")));
        }
        if waypoints.len() < 2 {
            return Err(Error::invalid("waypoints", format!("need at least 2, got {}", waypoints.len())));
        }
        if !t_start.is_finite() || t_start.abs() > TIME_LIMIT {
            return Err(Error::invalid("start_time", format!("must be within {:?} s, got {t_start:?}", TIME_LIMIT)));
        }
        let mut t = t_start;
        let mut keys = Vec::with_capacity(2 * waypoints.len());
        for (i, w) in waypoints.windows(2).enumerate() {
            let d = sub2(w[1], w[0]);
            let len = norm2(d);
            if len == 0.0 {
                return Err(Error::invalid("waypoints", format!("waypoints {i} and {} coincide", i + 1)));
            }
            let yaw = d[1].atan2(d[0]);
            let duration = len / speed;
            if i == 0 {
                keys.push((t, Pose2::new(w[0][0], w[0][1], yaw)));
            } else if duration > WALK_TURN_TIME {
                // the corner's key holds the previous leg's heading; the turn ends a little
                // way along the new leg, at the same speed
                let s = WALK_TURN_TIME / duration;
                let tt = t + WALK_TURN_TIME;
                if tt > t && tt < t + duration {
                    keys.push((tt, Pose2::new(w[0][0] + s * d[0], w[0][1] + s * d[1], yaw)));
                }
            }
            t += duration;
            keys.push((t, Pose2::new(w[1][0], w[1][1], yaw)));
        }
        Ok(Self { keys })
    }

    /// Checks non-emptiness, finiteness and strictly increasing times.
    pub fn validate(&self) -> Result<()> {
        if self.keys.is_empty() {
            return Err(Error::invalid("trajectory", "needs at least one key pose"));
        }
        for (i, (t, p)) in self.keys.iter().enumerate() {
            if !t.is_finite() {
                return Err(Error::invalid("trajectory", format!("key {i}: time must be finite, got {t}")));
            }
            p.validate("trajectory")?;
            if i > 0 && *t <= self.keys[i - 1].0 {
                return Err(Error::invalid("trajectory", format!("key {i}: times must increase strictly")));
            }
        }
        Ok(())
    }

    /// The pose at time `t` (s).
    pub fn pose_at(&self, t: Real) -> Pose2 {
        let k = &self.keys;
        if t <= k[0].0 {
            return k[0].1;
        }
        let last = k[k.len() - 1];
        if t >= last.0 {
            return last.1;
        }
        let i = k.partition_point(|(ti, _)| *ti <= t);
        let (t0, p0) = k[i - 1];
        let (t1, p1) = k[i];
        let s = (t - t0) / (t1 - t0);
        Pose2::new(p0.x + s * (p1.x - p0.x), p0.y + s * (p1.y - p0.y), wrap_angle(p0.yaw + s * wrap_angle(p1.yaw - p0.yaw)))
    }
}

/// A scripted kinematic obstacle: a solid shape in its own frame moved along a trajectory.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MovingObstacle {
    /// A name for reports (`"chair"`, `"door"`, ...).
    pub name: String,
    /// The shape in the obstacle's frame (m).
    pub shape: Polygon,
    /// Where that frame is over time.
    pub trajectory: Trajectory,
}

impl MovingObstacle {
    /// Checks the shape and trajectory.
    pub fn validate(&self) -> Result<()> {
        self.shape.validate("obstacle.shape")?;
        if !self.shape.is_convex() {
            // (the physics collides with the hull, the LIDAR would see the outline)
            return Err(Error::invalid(
                "obstacle.shape",
                format!("`{}`: must be convex (a moving body collides as its convex hull; make a non-convex one of several obstacles), got {:?}", self.name, self.shape.vertices),
            ));
        }
        self.trajectory.validate()
    }

    /// A bound on how far any point of the obstacle moves between its poses at `t0` and `t1`
    /// (moving straight and turning between them, as the physics moves it): the frame's
    /// displacement plus the farthest vertex's radius times the turn.
    pub fn max_travel(&self, t0: Real, t1: Real) -> Real {
        self.travel(t0, t1, self.bounding_radius())
    }

    /// [`MovingObstacle::max_travel`] given the obstacle's [`MovingObstacle::bounding_radius`].
    pub fn travel(&self, t0: Real, t1: Real, radius: Real) -> Real {
        let (a, b) = (self.trajectory.pose_at(t0), self.trajectory.pose_at(t1));
        (b.x - a.x).hypot(b.y - a.y) + radius * super::wrap_angle(b.yaw - a.yaw).abs()
    }

    /// The greatest distance (m) of the outline's vertices from the obstacle's frame's origin.
    pub fn bounding_radius(&self) -> Real {
        self.shape.vertices.iter().map(|p| p[0].hypot(p[1])).fold(0.0, Real::max)
    }

    /// The obstacle's walls in the world frame at time `t`, appended to `out`.
    pub fn segments_at(&self, t: Real, out: &mut Vec<Segment>) {
        let pose = self.trajectory.pose_at(t);
        let v: Vec<Point2> = self.shape.vertices.iter().map(|&p| pose.transform_point(p)).collect();
        out.extend(super::geometry::solid_edges(&v, self.shape.height, self.shape.signed_area() >= 0.0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn linear_trajectory_holds_before_and_after() {
        let tr = Trajectory::linear(Pose2::new(0.0, 0.0, 0.0), Pose2::new(2.0, 0.0, FRAC_PI_2), 9.0, 11.0);
        assert_eq!(tr.pose_at(0.0), Pose2::new(0.0, 0.0, 0.0));
        let mid = tr.pose_at(10.0);
        assert!((mid.x - 1.0).abs() < 1e-12 && (mid.yaw - FRAC_PI_2 / 2.0).abs() < 1e-12);
        assert_eq!(tr.pose_at(50.0).x, 2.0);
    }

    #[test]
    fn walk_keeps_the_speed() {
        let tr = Trajectory::walk(&[[0.0, 0.0], [3.0, 0.0], [3.0, 4.0]], 1.25, 2.0).unwrap();
        // the two corners' keys, and one where the turn at [3, 0] ends
        assert_eq!(tr.keys.len(), 4);
        assert!((tr.keys[3].0 - (2.0 + 7.0 / 1.25)).abs() < 1e-12);
        assert!(Trajectory::walk(&[[0.0, 0.0]], 1.0, 0.0).is_err());
        assert!(Trajectory::walk(&[[0.0, 0.0], [1.0, 0.0]], 0.0, 0.0).is_err());
    }

    /// A walker faces where it goes: after the corner of `[[0,0],[4,0],[4,4]]` at 1 m/s its
    /// heading is π/2 (it was 0.39, 0.79, 1.18 rad at 5, 6, 7 s: the turn spread over the leg),
    /// having turned within [`WALK_TURN_TIME`] of the corner, at the walking speed throughout.
    #[test]
    fn walker_faces_the_direction_of_travel_after_a_short_turn() {
        let tr = Trajectory::walk(&[[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]], 1.0, 0.0).unwrap();
        tr.validate().unwrap();
        for t in [0.5, 2.0, 3.99] {
            assert!(tr.pose_at(t).yaw.abs() < 1e-12, "t {t}: {:?}", tr.pose_at(t));
        }
        for t in [4.0 + WALK_TURN_TIME, 4.5, 5.0, 6.0, 7.0, 7.9, 9.0] {
            let p = tr.pose_at(t);
            assert!((p.yaw - FRAC_PI_2).abs() < 1e-12, "t {t}: {p:?}");
        }
        let mid = tr.pose_at(4.0 + 0.5 * WALK_TURN_TIME);
        assert!((mid.yaw - FRAC_PI_2 / 2.0).abs() < 1e-9, "{mid:?}");
        // the position moves at the speed along the legs, through the turn too
        for (t, x, y) in [(2.0, 2.0, 0.0), (4.1, 4.0, 0.1), (5.0, 4.0, 1.0), (7.0, 4.0, 3.0), (8.0, 4.0, 4.0)] {
            let p = tr.pose_at(t);
            assert!((p.x - x).abs() < 1e-12 && (p.y - y).abs() < 1e-12, "t {t}: {p:?}");
        }
        // a leg shorter than the turn: the turn spans it
        let short = Trajectory::walk(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.1], [2.0, 0.1]], 1.0, 0.0).unwrap();
        short.validate().unwrap();
        assert!((short.pose_at(1.1).yaw - FRAC_PI_2).abs() < 1e-12);
        assert!((short.pose_at(1.1 + WALK_TURN_TIME).yaw).abs() < 1e-12);
    }

    #[test]
    fn non_increasing_keys_are_rejected() {
        let p = Pose2::default();
        assert!(Trajectory { keys: vec![(1.0, p), (1.0, p)] }.validate().is_err());
    }
}
