//! The planar LIDAR on big maps by walking a triangulation of the walls: every beam is
//! followed from the cell the sensor stands in, across cell edges, until the first wall edge
//! it crosses. Beams travel in windows (runs of consecutive columns through one edge), so a
//! cell is entered once per window and the window split at the cell's corners; a window
//! through a gap narrower than a beam step holds no beam and ends there. Only what the sensor
//! can see is read: no wall behind another is ever looked at.
//!
//! The walls are the constraints of a constrained Delaunay triangulation (`spade`), in a box
//! around them (walls that cross are split where they cross); triangles are merged into strictly convex cells of up to ten corners across
//! the edges that are no wall (longest first), so that a beam crosses fewer edges. A wall
//! edge stops the beams of its window when the wall blocks them (faces the sensor, and stands
//! higher than a planar ring); their ranges are the wall's exact f64 hits (the hit of the
//! whole wall, as [`Lidar::scan_into`] computes it), so the ranges equal the other scans' bit
//! for bit (once the range limits are applied: a wall partly in range may give a hit beyond
//! it, which the index never computes). A beam that passes within a nanometre of a cell's
//! corner, or that the wall's own hit test misses, is cast again against every wall.
//!
//! `tables.rs` holds the cell tables' encoding and the scan's buffers, `build.rs` the
//! triangulation, `walk.rs` the walk, and `kernels.rs` its AVX-512 kernels.

mod build;
mod kernels;
mod tables;
#[cfg(test)]
mod tests;
mod walk;

pub use build::ScanMesh;
pub(crate) use tables::MeshScratch;
pub use tables::{MeshScanStats, NoMesh};
