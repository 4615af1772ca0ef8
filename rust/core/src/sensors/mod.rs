//! What the robot perceives: an exact planar / 3D LIDAR and a faulty odometry.
//!
//! The LIDAR always looks from the *true* pose; the odometry is the pose the planner and
//! nominal controllers see, with drift and scheduled faults (the paper's Scenario 2).

pub mod lidar;
pub mod noise;
pub mod odometry;
mod ray_segment;

pub use lidar::{IndexedScanStats, Lidar, LidarConfig, LidarMount, MeshScanStats, NoMesh, Scan, ScanMesh};
pub use odometry::{Odometry, OdometryConfig, OdometryFault};
pub use ray_segment::ray_segment_distance;
