//! The state of one cell of an occupancy grid.

/// The state of one grid cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Cell {
    /// Known free space.
    Free = 0,
    /// Known obstacle.
    Occupied = 1,
    /// Never observed.
    Unknown = 2,
}
