//! What the robot perceives: an exact planar / 3D LIDAR, a faulty odometry, and the moving
//! objects tracked from both.
//!
//! The LIDAR always looks from the *true* pose; the odometry is the pose the planner and
//! nominal controllers see, with drift and scheduled faults (the paper's Scenario 2).

pub mod lidar;
pub mod movers;
pub mod noise;
pub mod odometry;
mod ray_segment;

pub use lidar::{IndexedScanStats, Lidar, LidarConfig, LidarMount, MeshScanStats, NoMesh, Scan, ScanMesh};
pub use movers::{Mover, MoverTracker, MoverTrackerConfig, MAX_MOVER_SPEED};
pub use odometry::{Odometry, OdometryConfig, OdometryFault};
pub use ray_segment::ray_segment_distance;
