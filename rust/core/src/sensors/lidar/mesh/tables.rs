//! The encoding of the triangulation's cell tables, and the windows, sweeps and buffers of a
//! scan's walk.

use crate::math::Real;

/// "None" in the cell tables.
pub(super) const NONE: u32 = u32::MAX;

/// Most corners of a cell: triangles merge into convex cells up to this size.
pub(super) const MAX_CORNERS: usize = 10;
/// The cell of a link (see [`ScanMesh::link`]).
pub(super) const LINK_CELL: u32 = (1 << 25) - 1;
/// Where a wall link's kind starts (two bits, see [`WHOLE`]).
pub(super) const LINK_KIND: u32 = 25;
/// A wall edge's kind, as its cell sees it, where every wall on it is the whole edge: one
/// wall (or copies of one) faces the cell, `a → b` along the edge (`WHOLE`) or against it
/// (`WHOLE_BACK`), and any other turns its back to it (a one-sided wall, which blocks no beam
/// from that side: a thin obstacle outlined both ways is one wall facing each side); none
/// faces the cell (`BEHIND`); or anything else (0: the walls are tested one by one).
pub(super) const WHOLE: u32 = 1;
pub(super) const WHOLE_BACK: u32 = 2;
pub(super) const BEHIND: u32 = 3;
/// Where a link's back index starts.
pub(super) const LINK_BACK: u32 = 27;
/// A link's wall bit.
pub(super) const LINK_WALL: u32 = 1 << 31;

/// Beams `j0..j1` (columns, unwrapped) entering cell `t` (as in [`ScanMesh::across`]) through
/// its edge `e`, whose ends (sensor frame) are `pv` (corner `e`, counter-clockwise as the
/// sensor sees it) and `pu` (corner `e + 1`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Window {
    pub(super) pv: [Real; 2],
    pub(super) pu: [Real; 2],
    pub(super) j0: i32,
    pub(super) j1: i32,
    pub(super) t: u32,
    pub(super) e: u32,
}

/// Beams `j0..j1` (columns, unwrapped) stopped by the walls on corner edge `edge`, or, if
/// `edge` is [`NONE`], by the one wall from `a` to `b` (sensor frame).
#[derive(Debug, Clone, Copy)]
#[repr(C)]
pub(super) struct Sweep {
    pub(super) a: [Real; 2],
    pub(super) b: [Real; 2],
    pub(super) j0: i32,
    pub(super) j1: i32,
    pub(super) edge: u32,
}

/// Why a set of walls has no [`ScanMesh`]; the scans then use the bucket index.
#[derive(Debug, Clone, PartialEq)]
pub struct NoMesh(pub String);

impl std::fmt::Display for NoMesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "no triangulation of the walls: {}", self.0)
    }
}

impl std::error::Error for NoMesh {}

/// What the last [`Lidar::scan_mesh_into`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MeshScanStats {
    /// Cells entered (once per window).
    pub cells: usize,
    /// Wall edges whose beams were swept.
    pub walls_swept: usize,
    /// Beams cast again against every wall.
    pub beams_recast: usize,
    /// Whether the scan fell back to the bucket index (the sensor on an edge, or outside).
    pub fell_back: bool,
}

/// Reusable buffers of the mesh scan.
#[derive(Debug, Clone, Default)]
pub(crate) struct MeshScratch {
    pub(super) stack: Vec<Window>,
    pub(super) sweeps: Vec<Sweep>,
    pub(super) recast: Vec<u32>,
    /// The beams of the sweeps of at most [`SMALL`] beams (their sweep's index times six, the
    /// beam), with AVX-512.
    pub(super) jobs: Vec<[u32; 2]>,
    /// The sweeps swept one by one (their indices).
    pub(super) big: Vec<u32>,
    pub(crate) stats: MeshScanStats,
}
