//! Scripted moving obstacles: kinematic bodies that follow time-stamped key poses.
//!
//! A chair pushed toward the robot, a door swinging on its hinge, a pedestrian walking a
//! corridor: each is a solid polygon in its own frame plus a [`Trajectory`] of that frame.

use serde::{Deserialize, Serialize};

use super::geometry::{norm2, sub2, wrap_angle, Point2, Polygon, Pose2, Segment};
use crate::error::{Error, Result};
use crate::math::Real;

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
    /// direction of travel.
    pub fn walk(waypoints: &[Point2], speed: Real, t_start: Real) -> Result<Self> {
        if !(speed.is_finite() && speed > 0.0) {
            return Err(Error::invalid("speed", format!("must be finite and > 0, got {speed}")));
        }
        if waypoints.len() < 2 {
            return Err(Error::invalid("waypoints", format!("need at least 2, got {}", waypoints.len())));
        }
        if !t_start.is_finite() || t_start.abs() > super::scenario::TIME_LIMIT {
            return Err(Error::invalid("start_time", format!("must be within {:?} s, got {t_start:?}", super::scenario::TIME_LIMIT)));
        }
        let mut t = t_start;
        let mut keys = Vec::with_capacity(waypoints.len());
        for (i, w) in waypoints.windows(2).enumerate() {
            let d = sub2(w[1], w[0]);
            let yaw = d[1].atan2(d[0]);
            if i == 0 {
                keys.push((t, Pose2::new(w[0][0], w[0][1], yaw)));
            }
            let len = norm2(d);
            if len == 0.0 {
                return Err(Error::invalid("waypoints", format!("waypoints {i} and {} coincide", i + 1)));
            }
            t += len / speed;
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
            return Err(Error::invalid("obstacle.shape", format!("`{}`: must be convex (a moving body collides as its convex hull; make a non-convex one of several obstacles), got {:?}", self.name, self.shape.vertices)));
        }
        self.trajectory.validate()
    }

    /// A bound on how far any point of the obstacle moves between its poses at `t0` and `t1`
    /// (moving straight and turning between them, as the physics moves it): the frame's
    /// displacement plus the farthest vertex's radius times the turn.
    pub fn max_travel(&self, t0: Real, t1: Real) -> Real {
        let (a, b) = (self.trajectory.pose_at(t0), self.trajectory.pose_at(t1));
        let radius = self.shape.vertices.iter().map(|p| p[0].hypot(p[1])).fold(0.0, Real::max);
        (b.x - a.x).hypot(b.y - a.y) + radius * super::wrap_angle(b.yaw - a.yaw).abs()
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
        assert_eq!(tr.keys.len(), 3);
        assert!((tr.keys[2].0 - (2.0 + 7.0 / 1.25)).abs() < 1e-12);
        assert!(Trajectory::walk(&[[0.0, 0.0]], 1.0, 0.0).is_err());
        assert!(Trajectory::walk(&[[0.0, 0.0], [1.0, 0.0]], 0.0, 0.0).is_err());
    }

    #[test]
    fn non_increasing_keys_are_rejected() {
        let p = Pose2::default();
        assert!(Trajectory { keys: vec![(1.0, p), (1.0, p)] }.validate().is_err());
    }
}
