//! What the robot perceives: an exact planar / 3D LIDAR and a faulty odometry.
//!
//! The LIDAR always looks from the *true* pose; the odometry is the pose the planner and
//! nominal controllers see, with drift and scheduled faults (the paper's Scenario 2).

pub mod lidar;
mod lidar_indexed;
mod lidar_mesh;
pub mod noise;
pub mod odometry;
mod ray_segment;
mod simd;

pub use lidar::{Lidar, LidarConfig, LidarMount, Scan};
pub use lidar_indexed::IndexedScanStats;
pub use lidar_mesh::{MeshScanStats, NoMesh, ScanMesh};
pub use odometry::{Odometry, OdometryConfig, OdometryFault};
pub use ray_segment::ray_segment_distance;
