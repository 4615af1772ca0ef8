//! The paper's three experiment scenarios (Sec. IV) as named presets.
//!
//! - `"constricted_passage"` (Scenario 1): two rooms joined by a 1.6 m doorway; a cabinet
//!   misplaced in front of it leaves a 1.1 m gap. The 1.1 × 0.5 m robot passes lengthwise;
//!   a 0.8 m-radius sphere (the distance baseline's safety distance) needs 1.6 m and does not.
//! - `"odometry_jump"` (Scenario 2): a 150 m self-similar 2.4 m corridor with side doorways
//!   (1.0 m) into identical rooms every 12 m; at t = 20 s the odometry jumps 100 m along the
//!   corridor and 1.5 m across it.
//! - `"dynamic_obstacles"` (Scenario 3): a 1.8 m corridor with clutter on both sides; a chair
//!   is pushed 2 m toward the robot and into its lane from t = 9 s to 11 s, and a side door
//!   swings open across the lane from t = 20 s to 22 s; they leave 1.1 m and 1.05 m.
//!
//! ```
//! use shieldnav_core::world::preset;
//! let s = preset("constricted_passage").unwrap();
//! assert_eq!(s.name, "constricted_passage");
//! assert!(preset("nowhere").is_err());
//! ```

use std::f64::consts::FRAC_PI_2;

use super::geometry::{Polygon, Pose2};
use super::map::StaticMap;
use super::moving::{MovingObstacle, Trajectory};
use super::odometry::{OdometryConfig, OdometryFault};
use super::scenario::Scenario;
use crate::error::{Error, Result};
use crate::math::Real;

/// The preset names [`preset`] accepts.
pub const PRESET_NAMES: [&str; 3] = ["constricted_passage", "odometry_jump", "dynamic_obstacles"];

/// Height of the building's walls in the presets (m).
pub const WALL_HEIGHT: Real = 2.5;

/// The scenario preset called `name`; an unknown name is [`Error::UnknownPreset`].
pub fn preset(name: &str) -> Result<Scenario> {
    let s = match name {
        "constricted_passage" => constricted_passage(),
        "odometry_jump" => odometry_jump(),
        "dynamic_obstacles" => dynamic_obstacles(),
        _ => return Err(Error::UnknownPreset { name: name.to_string(), known: PRESET_NAMES.join(", ") }),
    }?;
    s.validate()?;
    Ok(s)
}

fn rect_walls(m: &mut StaticMap, x0: Real, y0: Real, x1: Real, y1: Real) -> Result<()> {
    m.add_polyline(&[[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]], WALL_HEIGHT)
}

fn constricted_passage() -> Result<Scenario> {
    let mut m = StaticMap::new();
    rect_walls(&mut m, 0.0, -1.5, 10.1, 1.5)?;
    // dividing wall with a 1.6 m doorway, y in [-0.8, 0.8]
    m.add_polygon(Polygon::rect(5.0, -1.5, 5.1, -0.8, WALL_HEIGHT))?;
    m.add_polygon(Polygon::rect(5.0, 0.8, 5.1, 1.5, WALL_HEIGHT))?;
    // the misplaced cabinet against the dividing wall: leaves y in [-0.8, 0.3], 1.1 m
    m.add_polygon(Polygon::rect(4.2, 0.3, 5.0, 1.5, 1.2))?;
    let mut s = Scenario::new("constricted_passage", m, Pose2::new(1.0, 0.0, 0.0));
    s.goal = Some(Pose2::new(8.0, 0.0, 0.0));
    Ok(s)
}

fn odometry_jump() -> Result<Scenario> {
    let (len, half_w, door, pitch, room_w, room_d) = (150.0, 1.2, 1.0, 12.0, 4.0, 3.0);
    let mut m = StaticMap::new();
    m.add_segment(super::Segment::new([0.0, -half_w], [0.0, half_w], WALL_HEIGHT))?;
    m.add_segment(super::Segment::new([len, -half_w], [len, half_w], WALL_HEIGHT))?;
    for side in [1.0, -1.0] {
        let y = side * half_w;
        let y_back = side * (half_w + room_d);
        let mut x = 0.0;
        let mut k = 0;
        loop {
            // doors alternate sides: top at 6, 30, 54, ...; bottom at 18, 42, ...
            let xc = 6.0 + pitch * k as Real;
            k += 1;
            if xc + room_w > len {
                break;
            }
            if (k % 2 == 1) != (side > 0.0) {
                continue;
            }
            m.add_polyline(&[[x, y], [xc - 0.5 * door, y]], WALL_HEIGHT)?;
            m.add_polyline(&[[xc - 0.5 * door, y], [xc - 0.5 * room_w, y], [xc - 0.5 * room_w, y_back], [xc + 0.5 * room_w, y_back], [xc + 0.5 * room_w, y], [xc + 0.5 * door, y]], WALL_HEIGHT)?;
            x = xc + 0.5 * door;
        }
        m.add_polyline(&[[x, y], [len, y]], WALL_HEIGHT)?;
    }
    let mut s = Scenario::new("odometry_jump", m, Pose2::new(2.0, 0.0, 0.0));
    s.goal = Some(Pose2::new(140.0, 0.0, 0.0));
    // perceptual aliasing: the estimate leaps 100 m down the tunnel and 1.5 m sideways, so a
    // robot tracking its mission line is sent into the wall
    s.odometry = OdometryConfig { faults: vec![OdometryFault::Jump { time: 20.0, dx: 100.0, dy: -1.5 }], ..Default::default() };
    Ok(s)
}

fn dynamic_obstacles() -> Result<Scenario> {
    let (len, half_w) = (30.0, 0.9);
    let (door_x, door_w) = (23.0, 0.8);
    let mut m = StaticMap::new();
    m.add_segment(super::Segment::new([0.0, -half_w], [0.0, half_w], WALL_HEIGHT))?;
    m.add_segment(super::Segment::new([len, -half_w], [len, half_w], WALL_HEIGHT))?;
    m.add_polyline(&[[0.0, half_w], [len, half_w]], WALL_HEIGHT)?;
    // bottom wall with a 0.8 m doorway at x in [23, 23.8] into a 3 x 3 m room
    m.add_polyline(&[[0.0, -half_w], [door_x, -half_w]], WALL_HEIGHT)?;
    m.add_polyline(&[[door_x, -half_w], [door_x - 1.0, -half_w], [door_x - 1.0, -3.9], [door_x + 2.0, -3.9], [door_x + 2.0, -half_w], [door_x + door_w, -half_w]], WALL_HEIGHT)?;
    m.add_polyline(&[[door_x + door_w, -half_w], [len, -half_w]], WALL_HEIGHT)?;
    // static clutter on both sides (boxes, a cart, shelves)
    for (x0, y0, x1, y1, h) in [
        (3.0, -0.9, 3.8, -0.55, 0.8),
        (7.0, -0.9, 7.5, -0.6, 1.0),
        (11.5, -0.9, 12.3, -0.5, 0.9),
        (19.5, -0.9, 20.1, -0.6, 1.2),
        (5.0, 0.55, 5.6, 0.9, 1.0),
        (9.5, 0.6, 10.3, 0.9, 1.5),
        (17.5, 0.5, 18.0, 0.9, 0.7),
        (26.0, 0.55, 27.0, 0.9, 1.1),
    ] {
        m.add_polygon(Polygon::rect(x0, y0, x1, y1, h))?;
    }
    // pushed 2 m toward the robot and into its lane: 1.1 m are left below it
    let chair = MovingObstacle {
        name: "chair".into(),
        shape: Polygon::rect(-0.25, -0.25, 0.25, 0.25, 0.9),
        trajectory: Trajectory::linear(Pose2::new(16.6, 0.6, 0.0), Pose2::new(14.6, 0.45, 0.0), 9.0, 11.0),
    };
    // a 0.75 m leaf swinging from the wall line to square across the lane: 1.05 m are left
    let door = MovingObstacle {
        name: "door".into(),
        shape: Polygon::rect(0.0, -0.05, 0.75, 0.0, 2.0),
        trajectory: Trajectory::linear(Pose2::new(door_x, -half_w, 0.0), Pose2::new(door_x, -half_w, FRAC_PI_2), 20.0, 22.0),
    };
    let mut s = Scenario::new("dynamic_obstacles", m, Pose2::new(1.0, 0.0, 0.0));
    s.goal = Some(Pose2::new(28.5, 0.0, 0.0));
    s.obstacles = vec![chair, door];
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_named_preset_builds() {
        for n in PRESET_NAMES {
            let s = preset(n).unwrap();
            assert_eq!(s.name, n);
            assert!(!s.map.segments.is_empty());
        }
    }

    #[test]
    fn unknown_preset_error_names_it_and_lists_the_known() {
        let e = preset("constricted").unwrap_err().to_string();
        assert!(e.contains("`constricted`") && e.contains("odometry_jump"), "{e}");
    }
}
