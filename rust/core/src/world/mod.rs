//! The world an episode runs in: static geometry, scenarios, presets, moving obstacles.
//!
//! Geometry is planar `f64` wall segments extruded from the floor to a height (for the 3D
//! LIDAR). Polygons (furniture, pillars) are stored as their edges.

pub(crate) mod bitrow;
mod contour;
mod cspace;
pub mod generate;
mod geometry;
pub mod grid;
pub(crate) mod index;
mod map;
mod moving;
pub mod preset;
pub(crate) mod recycle;
pub(crate) mod region;
pub mod rosmap;
mod scenario;
mod sim;
pub mod traverse;

pub use contour::{simplify_walls, thin_corner};
pub use geometry::{cross2, norm2, sub2, wrap_angle, Point2, Polygon, Pose2, Segment};
pub use grid::{Cell, OccupancyGrid};
pub use index::SegmentIndex;
pub use map::StaticMap;
pub use moving::{MovingObstacle, Trajectory};
pub use preset::{preset, PRESET_NAMES};
pub use rosmap::{load_ros_map, RosMap, RosMapOptions};
pub use scenario::{Scenario, COORDINATE_LIMIT, TIME_LIMIT, YAW_LIMIT};
pub use sim::{StepOutcome, World, WorldConfig, CLEARANCE_BUDGET, CLEARANCE_SEARCH, FREE_STEP_MARGIN, SCAN_ALL_WALLS_MAX, SCAN_PROBE_EVERY, SCAN_PROBE_MAX, SCAN_PROBE_SLOWER};
pub use traverse::{footprint_reachability, Footprint, Reachability};
