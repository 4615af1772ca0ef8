//! The robot: its true footprint as a rapier rigid body, and the low-level velocity tracker.
//!
//! Collisions are judged on this footprint (a 1.1 × 0.5 m rectangle by default, optionally with
//! rounded corners), never on the shield's ellipse.

pub mod footprint;
pub mod physics;
pub mod tracker;

pub use footprint::{check_start, footprint_segment_distance, RobotShape};
pub use physics::{ContactReport, PhysicsScene, PhysicsStats};
pub use tracker::{Tracker, TrackerConfig, TrackerOutcome};
