//! # shieldnav-ros2
//!
//! The composite-CBF safety shield of `shieldnav-core` as a ROS 2 node, over the pure-Rust
//! `ros2-client` / RustDDS stack (no ROS installation needed to build or run it).
//!
//! The node subscribes to a `sensor_msgs/LaserScan` and/or `sensor_msgs/PointCloud2`, the
//! planner's nominal `geometry_msgs/Twist` and the robot's `nav_msgs/Odometry` (or
//! `sensor_msgs/Imu`), and publishes the filtered `Twist` and a state topic
//! (`std_msgs/String` holding one JSON object) for every nominal command. A stale or
//! malformed input, or a missing command, sends zero and says why.
//!
//! The decisions live in [`logic::ShieldNode`] and the message translation in
//! [`translate`], both without the network; `ros` (feature `dds`, on by default) wires them to
//! DDS.

pub mod logic;
pub mod msg;
pub mod params;
#[cfg(feature = "dds")]
pub mod record;
#[cfg(feature = "dds")]
pub mod ros;
pub mod translate;

pub use logic::{Output, ShieldNode, State};
pub use params::{NodeParams, ParamError, RawParams, Value};
