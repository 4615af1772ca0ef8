//! The geometry an episode runs in: static walls, scenarios, presets, maps, moving obstacles
//! (the simulated world that steps a robot through them is [`crate::sim`]).
//!
//! Geometry is planar `f64` wall segments extruded from the floor to a height (for the 3D
//! LIDAR). Polygons (furniture, pillars) are stored as their edges.

pub(crate) mod bitrow;
mod cell;
mod contour;
mod cspace;
pub mod generate;
mod geometry;
pub mod grid;
pub(crate) mod index;
mod map;
mod moving;
mod odometry;
pub mod preset;
pub(crate) mod recycle;
pub(crate) mod region;
pub mod rosmap;
mod scenario;
pub mod traverse;

pub use contour::{simplify_walls, thin_corner};
pub use geometry::{cross2, norm2, sub2, wrap_angle, Point2, Polygon, Pose2, Segment};
pub use grid::{Cell, OccupancyGrid};
pub use index::SegmentIndex;
pub use map::StaticMap;
pub use moving::{MovingObstacle, Trajectory, TIME_LIMIT};
pub use odometry::{OdometryConfig, OdometryFault};
pub use preset::{preset, PRESET_NAMES};
pub use rosmap::{load_ros_map, RosMap, RosMapOptions};
pub use scenario::{Chaser, Scenario, COORDINATE_LIMIT, MAX_CHASE_SPEED, YAW_LIMIT};
pub use traverse::{footprint_reachability, Footprint, Reachability};
