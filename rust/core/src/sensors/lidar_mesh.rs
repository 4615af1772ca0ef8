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

use std::collections::HashMap;

use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, PositionInTriangulation, Triangulation};

use super::lidar::{atan2_by, fast_atan2, iceil, parallel_beam, seg_origin_distance, Lidar, Scan};
use crate::math::Real;
use crate::simd::SimdLevel;
use crate::world::{cross2, sub2, Pose2, Segment};

/// "None" in the cell tables.
const NONE: u32 = u32::MAX;

/// Most corners of a cell: triangles merge into convex cells up to this size.
const MAX_CORNERS: usize = 10;
/// The cell of a link (see [`ScanMesh::link`]).
const LINK_CELL: u32 = (1 << 25) - 1;
/// Where a wall link's kind starts (two bits, see [`WHOLE`]).
const LINK_KIND: u32 = 25;
/// A wall edge's kind, as its cell sees it, where every wall on it is the whole edge: one
/// wall (or copies of one) faces the cell, `a → b` along the edge (`WHOLE`) or against it
/// (`WHOLE_BACK`), and any other turns its back to it (a one-sided wall, which blocks no beam
/// from that side: a thin obstacle outlined both ways is one wall facing each side); none
/// faces the cell (`BEHIND`); or anything else (0: the walls are tested one by one).
const WHOLE: u32 = 1;
const WHOLE_BACK: u32 = 2;
const BEHIND: u32 = 3;
/// Where a link's back index starts.
const LINK_BACK: u32 = 27;
/// A link's wall bit.
const LINK_WALL: u32 = 1 << 31;

/// Beams `j0..j1` (columns, unwrapped) entering cell `t` (as in [`ScanMesh::across`]) through
/// its edge `e`, whose ends (sensor frame) are `pv` (corner `e`, counter-clockwise as the
/// sensor sees it) and `pu` (corner `e + 1`).
#[derive(Debug, Clone, Copy)]
struct Window {
    pv: [Real; 2],
    pu: [Real; 2],
    j0: i32,
    j1: i32,
    t: u32,
    e: u32,
}

/// Beams `j0..j1` (columns, unwrapped) stopped by the walls on corner edge `edge`, or, if
/// `edge` is [`NONE`], by the one wall from `a` to `b` (sensor frame).
#[derive(Debug, Clone, Copy)]
#[repr(C)]
struct Sweep {
    a: [Real; 2],
    b: [Real; 2],
    j0: i32,
    j1: i32,
    edge: u32,
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

/// A triangulation of a world's walls for the planar scan (see the module's doc), its
/// triangles merged into convex cells where no wall parts them.
#[derive(Debug, Clone)]
pub struct ScanMesh {
    segments: Vec<Segment>,
    /// Cell `c`'s corners (counter-clockwise) are `corner[start[c]..start[c + 1]]`; cell 0 is
    /// the outside of the box (no corners); the others in the order of their middles along a
    /// Z curve, so that neighbours are mostly near in memory.
    start: Vec<u32>,
    corner: Vec<[Real; 2]>,
    /// Per corner `i` of a cell, for its edge to corner `i + 1`: the cell across it (0: the
    /// outside) in the low 25 bits, the walls' kind as this cell sees them in the next two
    /// (see [`WHOLE`]), that edge's place among the neighbour's in the next four, and whether
    /// walls lie on it in the top bit (then `edge_wall` says which).
    link: Vec<u32>,
    /// Per corner edge, the walls on it (an index into `edge_walls`), or [`NONE`].
    edge_wall: Vec<u32>,
    /// Per corner edge, the cell across it as its first corner (an index into `corner`)
    /// times 16 plus its number of corners (0 for the outside): the walk goes on into it
    /// without reading `start`.
    across: Vec<u32>,
    /// Per wall edge, the range of its walls in `wall_ids`.
    edge_walls: Vec<[u32; 2]>,
    wall_ids: Vec<u32>,
    /// A cell at the centre of each cell of a grid over the walls' box.
    grid: Vec<u32>,
    grid_origin: [Real; 2],
    grid_cell: Real,
    grid_dims: (usize, usize),
    /// The lowest wall's top: a sensor no higher sees every wall that faces it.
    lowest: Real,
}

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
pub(super) struct MeshScratch {
    stack: Vec<Window>,
    sweeps: Vec<Sweep>,
    recast: Vec<u32>,
    /// The beams of the sweeps of at most [`SMALL`] beams (their sweep's index times six, the
    /// beam), with AVX-512.
    jobs: Vec<[u32; 2]>,
    /// The sweeps swept one by one (their indices).
    big: Vec<u32>,
    pub(super) stats: MeshScanStats,
}

impl ScanMesh {
    /// Triangulates `segments` (finite, of non-zero length; walls that cross are split where
    /// they cross).
    pub fn new(segments: &[Segment]) -> Result<Self, NoMesh> {
        // (a failure inside the triangulation library is reported, not passed on as a panic)
        std::panic::catch_unwind(|| Self::build(segments)).unwrap_or_else(|_| Err(NoMesh("the triangulation failed".into())))
    }

    fn build(segments: &[Segment]) -> Result<Self, NoMesh> {
        let mut ids: HashMap<(u64, u64), u32> = HashMap::with_capacity(segments.len() * 2);
        let mut pts: Vec<spade::Point2<Real>> = Vec::with_capacity(segments.len() * 2 + 4);
        let (mut lo, mut hi) = ([Real::INFINITY; 2], [Real::NEG_INFINITY; 2]);
        let mut id = |p: [Real; 2], pts: &mut Vec<spade::Point2<Real>>| {
            *ids.entry((p[0].to_bits(), p[1].to_bits())).or_insert_with(|| {
                pts.push(spade::Point2::new(p[0], p[1]));
                (pts.len() - 1) as u32
            })
        };
        let mut ends = Vec::with_capacity(segments.len());
        for (k, s) in segments.iter().enumerate() {
            if !(s.a.iter().chain(&s.b).all(|v| v.is_finite() && v.abs() < 1e7)) || s.a == s.b {
                return Err(NoMesh(format!("wall {k} is not finite or has no length")));
            }
            for p in [s.a, s.b] {
                for i in 0..2 {
                    lo[i] = lo[i].min(p[i]);
                    hi[i] = hi[i].max(p[i]);
                }
            }
            ends.push((id(s.a, &mut pts), id(s.b, &mut pts)));
        }
        if segments.is_empty() {
            return Err(NoMesh("no walls".into()));
        }
        let margin = 1.0 + 0.05 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
        for (x, y) in [(lo[0] - margin, lo[1] - margin), (hi[0] + margin, lo[1] - margin), (hi[0] + margin, hi[1] + margin), (lo[0] - margin, hi[1] + margin)] {
            id([x, y], &mut pts);
        }
        let mut pairs: Vec<[usize; 2]> = ends.iter().map(|&(a, b)| if a < b { [a as usize, b as usize] } else { [b as usize, a as usize] }).collect();
        pairs.sort_unstable();
        pairs.dedup();
        let n_pts = pts.len();
        type Cdt = ConstrainedDelaunayTriangulation<spade::Point2<Real>>;
        let failed = |e: spade::InsertionError| NoMesh(format!("triangulation failed: {e:?}"));
        let mut conflicts = 0usize;
        let mut cdt = Cdt::try_bulk_load_cdt(pts.clone(), pairs.clone(), |_| conflicts += 1).map_err(failed)?;
        if conflicts > 0 {
            // walls that cross: inserted one by one, each split where it crosses another (at a
            // corner rounded off the walls' lines by about 1e-16 of their size: the beams
            // within a nanometre of it are cast again)
            cdt = Cdt::bulk_load_cdt(pts, Vec::new()).map_err(failed)?;
            for &[a, b] in &pairs {
                cdt.add_constraint_and_split(FixedVertexHandle::from_index(a), FixedVertexHandle::from_index(b), |p| p);
            }
        }
        if cdt.num_vertices() < n_pts || cdt.vertices().take(n_pts).zip(0..).any(|(v, i)| v.fix().index() != i) {
            return Err(NoMesh("vertices merged".into()));
        }
        let verts: Vec<[Real; 2]> = cdt.vertices().map(|v| [v.position().x, v.position().y]).collect();
        // the walls on each constraint edge: follow each wall from its start along constraint
        // edges through the vertices lying on it
        let mut on_edge: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        for (k, &(a, b)) in ends.iter().enumerate() {
            let (pa, pb) = (verts[a as usize], verts[b as usize]);
            let ab = sub2(pb, pa);
            let l2 = ab[0] * ab[0] + ab[1] * ab[1];
            let along = |p: [Real; 2]| {
                let d = sub2(p, pa);
                (cross2(ab, d).abs() <= 1e-9 * l2, d[0] * ab[0] + d[1] * ab[1])
            };
            let mut cur = a as usize;
            let mut steps = 0;
            while cur != b as usize {
                let (_, t_cur) = along(verts[cur]);
                let v = cdt.vertex(FixedVertexHandle::from_index(cur));
                let next = v.out_edges().find(|e| {
                    let to = e.to().index();
                    let (on, t) = along(verts[to]);
                    e.as_undirected().is_constraint_edge() && on && t > t_cur && t <= l2 * (1.0 + 1e-12)
                });
                let Some(e) = next else {
                    return Err(NoMesh(format!("wall {k} not found in the triangulation")));
                };
                let (x, y) = (cur as u32, e.to().index() as u32);
                on_edge.entry((x.min(y), x.max(y))).or_default().push(k as u32);
                cur = e.to().index();
                steps += 1;
                if steps > verts.len() {
                    return Err(NoMesh(format!("wall {k} not found in the triangulation")));
                }
            }
        }
        let mut edge_walls = Vec::with_capacity(on_edge.len());
        let mut wall_ids = Vec::with_capacity(segments.len());
        let mut edge_slot: HashMap<(u32, u32), u32> = HashMap::with_capacity(on_edge.len());
        let mut keys: Vec<(u32, u32)> = on_edge.keys().copied().collect();
        keys.sort_unstable();
        for e in keys {
            let ws = &on_edge[&e];
            edge_slot.insert(e, edge_walls.len() as u32);
            edge_walls.push([wall_ids.len() as u32, (wall_ids.len() + ws.len()) as u32]);
            wall_ids.extend_from_slice(ws);
        }
        let slot = |x: u32, y: u32| edge_slot.get(&(x.min(y), x.max(y))).copied().unwrap_or(NONE);
        // cells: spade's triangles (face indices, 0 the outside), then merged across edges
        // that are no wall while the union stays strictly convex, longest edges first
        let nf = cdt.num_all_faces();
        let mut polys: Vec<Vec<u32>> = vec![Vec::new(); nf];
        let mut faces: Vec<Vec<u32>> = vec![Vec::new(); nf];
        let mut owner: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * nf);
        for f in cdt.inner_faces() {
            let i = f.fix().index();
            polys[i] = f.adjacent_edges().iter().map(|e| e.from().index() as u32).collect();
            faces[i].push(i as u32);
            for k in 0..3 {
                owner.insert((polys[i][k], polys[i][(k + 1) % 3]), i as u32);
            }
        }
        let mut diagonals: Vec<(Real, u32, u32)> = owner
            .keys()
            .filter(|&&(x, y)| x < y && owner.contains_key(&(y, x)) && slot(x, y) == NONE)
            .map(|&(x, y)| {
                let d = sub2(verts[y as usize], verts[x as usize]);
                (d[0] * d[0] + d[1] * d[1], x, y)
            })
            .collect();
        diagonals.sort_unstable_by(|p, q| q.0.total_cmp(&p.0).then((p.1, p.2).cmp(&(q.1, q.2))));
        let orient = |p: u32, q: u32, r: u32| {
            let (p, q, r) = (verts[p as usize], verts[q as usize], verts[r as usize]);
            let (u, w) = (sub2(q, p), sub2(r, q));
            // strictly convex, with a margin far above rounding
            cross2(u, w) > 1e-9 * (u[0].abs() + u[1].abs()) * (w[0].abs() + w[1].abs())
        };
        for &(_, x, y) in &diagonals {
            let (Some(&p1), Some(&p2)) = (owner.get(&(x, y)), owner.get(&(y, x))) else { continue };
            if p1 == p2 || polys[p1 as usize].len() + polys[p2 as usize].len() - 2 > MAX_CORNERS {
                continue;
            }
            // p1 from y round to x (its edge x → y closing it), p2 from x round to y
            let rot = |poly: &[u32], from: u32| {
                let i = poly.iter().position(|&c| c == from).expect("a corner of its cell");
                let mut r = poly.to_vec();
                r.rotate_left(i);
                r
            };
            let (r1, r2) = (rot(&polys[p1 as usize], y), rot(&polys[p2 as usize], x));
            let (n1, n2) = (r1.len(), r2.len());
            if !(orient(r1[n1 - 2], x, r2[1]) && orient(r2[n2 - 2], y, r1[1])) {
                continue;
            }
            let mut merged = r1;
            merged.extend_from_slice(&r2[1..n2 - 1]);
            owner.remove(&(x, y));
            owner.remove(&(y, x));
            for k in 0..merged.len() {
                owner.insert((merged[k], merged[(k + 1) % merged.len()]), p1);
            }
            polys[p1 as usize] = merged;
            polys[p2 as usize].clear();
            let moved = std::mem::take(&mut faces[p2 as usize]);
            faces[p1 as usize].extend(moved);
        }
        let mut cell_of_face = vec![0u32; nf];
        // renumbered along a Z curve of their middles (0 stays the outside)
        let morton = |x: Real, y: Real| {
            let q = |t: Real| (t.clamp(0.0, 1.0) * 65535.0) as u64;
            let spread = |mut a: u64| {
                a = (a | (a << 8)) & 0x00FF_00FF;
                a = (a | (a << 4)) & 0x0F0F_0F0F;
                a = (a | (a << 2)) & 0x3333_3333;
                (a | (a << 1)) & 0x5555_5555
            };
            spread(q((x - lo[0]) / (hi[0] - lo[0]).max(1e-9))) | spread(q((y - lo[1]) / (hi[1] - lo[1]).max(1e-9))) << 1
        };
        let mut order: Vec<(u64, usize)> = (1..nf)
            .filter(|&i| !polys[i].is_empty())
            .map(|i| {
                let k = polys[i].len() as Real;
                let (sx, sy) = polys[i].iter().fold((0.0, 0.0), |(sx, sy), &c| (sx + verts[c as usize][0], sy + verts[c as usize][1]));
                (morton(sx / k, sy / k), i)
            })
            .collect();
        order.sort_unstable();
        if order.len() as u64 >= LINK_CELL as u64 {
            return Err(NoMesh(format!("{} cells, too many", order.len())));
        }
        let mut new_of = vec![0u32; nf];
        for (k, &(_, i)) in order.iter().enumerate() {
            new_of[i] = k as u32 + 1;
            for &f in &faces[i] {
                cell_of_face[f as usize] = k as u32 + 1;
            }
        }
        let (mut start, mut corner, mut link, mut edge_wall) = (vec![0u32, 0], Vec::new(), Vec::new(), Vec::new());
        for &(_, i) in &order {
            let poly = &polys[i];
            for k in 0..poly.len() {
                let (x, y) = (poly[k], poly[(k + 1) % poly.len()]);
                corner.push(verts[x as usize]);
                let (nb, back) = match owner.get(&(y, x)) {
                    Some(&n) => (new_of[n as usize], polys[n as usize].iter().position(|&c| c == y).expect("a corner of its cell") as u32),
                    None => (0, 0),
                };
                let w = slot(x, y);
                edge_wall.push(w);
                let mut kind = 0;
                if w != NONE {
                    let [w0, w1] = edge_walls[w as usize];
                    let walls = wall_ids[w0 as usize..w1 as usize].iter().map(|&k| &segments[k as usize]);
                    kind = whole_kind(walls, verts[x as usize], verts[y as usize]);
                }
                link.push(nb | back << LINK_BACK | if w != NONE { LINK_WALL | kind << LINK_KIND } else { 0 });
            }
            start.push(corner.len() as u32);
        }
        // the locator grid
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        let cell = (extent / 256.0).max(1.0);
        let dims = (((hi[0] - lo[0]) / cell).floor() as usize + 1, ((hi[1] - lo[1]) / cell).floor() as usize + 1);
        let mut grid = Vec::with_capacity(dims.0 * dims.1);
        for j in 0..dims.1 {
            for i in 0..dims.0 {
                let p = spade::Point2::new(lo[0] + (i as Real + 0.5) * cell, lo[1] + (j as Real + 0.5) * cell);
                let t = match cdt.locate(p) {
                    PositionInTriangulation::OnFace(f) => f.index(),
                    PositionInTriangulation::OnEdge(e) | PositionInTriangulation::OutsideOfConvexHull(e) => {
                        let e = cdt.directed_edge(e);
                        e.face().as_inner().or_else(|| e.rev().face().as_inner()).map_or(0, |f| f.fix().index())
                    }
                    PositionInTriangulation::OnVertex(v) => cdt.vertex(v).out_edges().find_map(|e| e.face().as_inner()).map_or(0, |f| f.fix().index()),
                    PositionInTriangulation::NoTriangulation => 0,
                };
                grid.push(cell_of_face[t].max(1));
            }
        }
        if corner.len() >= 1 << 28 {
            return Err(NoMesh(format!("{} cell corners, too many", corner.len())));
        }
        let across = link.iter().map(|&l| across_of(&start, (l & LINK_CELL) as usize)).collect();
        let lowest = segments.iter().map(|s| s.height).fold(Real::INFINITY, Real::min);
        let mesh = Self { segments: segments.to_vec(), start, corner, link, edge_wall, across, edge_walls, wall_ids, grid, grid_origin: lo, grid_cell: cell, grid_dims: dims, lowest };
        mesh.check_tables()?;
        Ok(mesh)
    }

    /// That every index in the tables is in bounds, which the walk's reads without bounds
    /// checks rely on (see [`ScanMesh::corners`] and [`Walker::edge`]): cell 0 has no corners,
    /// every other cell 3 to [`MAX_CORNERS`]; every link leads to a cell and to one of its
    /// edges; every wall edge to a run of walls.
    fn check_tables(&self) -> Result<(), NoMesh> {
        let bad = |what: &str| Err(NoMesh(format!("bad table: {what}")));
        let cells = self.start.len().saturating_sub(2);
        let k = |c: usize| (self.start[c + 1] - self.start[c]) as usize;
        if self.start.len() < 2 || self.start[0] != 0 || self.start[1] != 0 || self.start[cells + 1] as usize != self.corner.len() {
            return bad("start");
        }
        if self.link.len() != self.corner.len() || self.edge_wall.len() != self.corner.len() || self.across.len() != self.corner.len() {
            return bad("lengths");
        }
        for c in 1..=cells {
            if self.start[c + 1] < self.start[c] || !(3..=MAX_CORNERS).contains(&k(c)) {
                return bad("corners");
            }
        }
        for (g, &link) in self.link.iter().enumerate() {
            let nb = (link & LINK_CELL) as usize;
            if nb > cells || (nb != 0 && ((link >> LINK_BACK) & 15) as usize >= k(nb)) {
                return bad("link");
            }
            if self.across[g] != across_of(&self.start, nb) {
                return bad("across");
            }
            if link & LINK_WALL != 0 {
                let Some(&[w0, w1]) = self.edge_walls.get(self.edge_wall[g] as usize) else {
                    return bad("edge_wall");
                };
                if w0 > w1 || w1 as usize > self.wall_ids.len() {
                    return bad("edge_walls");
                }
            }
        }
        if self.wall_ids.iter().any(|&w| w as usize >= self.segments.len()) {
            return bad("wall_ids");
        }
        if self.grid.iter().any(|&c| c == 0 || c as usize > cells) {
            return bad("grid");
        }
        Ok(())
    }

    /// The walls.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Convex cells (triangles and merged ones).
    pub fn cells(&self) -> usize {
        self.start.len() - 2
    }

    /// The corners of cell `c` (counter-clockwise), and the index of its first; `c` a cell
    /// of the tables (the outside, 0, or one a link or the grid leads to).
    #[inline(always)]
    fn corners(&self, c: usize) -> (&[[Real; 2]], usize) {
        debug_assert!(c + 2 <= self.start.len());
        // SAFETY: `c + 1 < start.len()` (every cell a link or the grid names, checked by
        // `check_tables`), and `start` rises to `corner.len()`.
        unsafe {
            let (a, b) = (*self.start.get_unchecked(c) as usize, *self.start.get_unchecked(c + 1) as usize);
            (self.corner.get_unchecked(a..b), a)
        }
    }

    /// The corners of the cell `t` (as in [`ScanMesh::across`]), and the index of its first.
    #[inline(always)]
    fn corners_across(&self, t: u32) -> (&[[Real; 2]], usize) {
        let (at, k) = ((t >> 4) as usize, (t & 15) as usize);
        debug_assert!(at + k <= self.corner.len());
        // SAFETY: `t` is an entry of `across`, checked to be a cell's corners (`check_tables`).
        (unsafe { self.corner.get_unchecked(at..at + k) }, at)
    }

    /// The cell across corner edge `g` (see [`ScanMesh::across`]).
    #[inline(always)]
    fn across(&self, g: usize) -> u32 {
        debug_assert!(g < self.across.len());
        // SAFETY: `g` is a corner of a cell, below `corner.len() == across.len()` (checked).
        unsafe { *self.across.get_unchecked(g) }
    }

    /// The link of corner edge `g` (an index into `corner`).
    #[inline(always)]
    fn link(&self, g: usize) -> u32 {
        debug_assert!(g < self.link.len());
        // SAFETY: `g` is a corner of a cell, below `corner.len() == link.len()` (checked).
        unsafe { *self.link.get_unchecked(g) }
    }

    /// The walls on the wall edge `g` (its link has the wall bit).
    #[inline(always)]
    fn walls_on(&self, g: usize) -> impl Iterator<Item = &Segment> {
        debug_assert!(self.link[g] & LINK_WALL != 0);
        // SAFETY: a wall edge's `edge_wall` is an index into `edge_walls`, whose runs lie in
        // `wall_ids`, whose walls lie in `segments` (all checked by `check_tables`).
        unsafe {
            let [w0, w1] = *self.edge_walls.get_unchecked(*self.edge_wall.get_unchecked(g) as usize);
            self.wall_ids.get_unchecked(w0 as usize..w1 as usize).iter().map(|&w| self.segments.get_unchecked(w as usize))
        }
    }

    /// The cell holding `s` strictly inside, found by walking from the grid's; `None` on an
    /// edge's line or outside the box.
    fn locate(&self, s: [Real; 2]) -> Option<usize> {
        let (nx, ny) = self.grid_dims;
        let gi = (((s[0] - self.grid_origin[0]) / self.grid_cell).floor().max(0.0) as usize).min(nx - 1);
        let gj = (((s[1] - self.grid_origin[1]) / self.grid_cell).floor().max(0.0) as usize).min(ny - 1);
        let mut t = self.grid[gj * nx + gi] as usize;
        for _ in 0..1 << 16 {
            let (cs, at) = self.corners(t);
            let mut next = None;
            for k in 0..cs.len() {
                let (a, b) = (cs[k], cs[(k + 1) % cs.len()]);
                let o = cross2(sub2(b, a), sub2(s, a));
                if o == 0.0 {
                    return None;
                }
                if o < 0.0 && next.is_none() {
                    next = Some((self.link[at + k] & LINK_CELL) as usize);
                }
            }
            match next {
                None => return Some(t),
                Some(0) => return None,
                Some(n) => t = n,
            }
        }
        None
    }
}

impl Lidar {
    /// What the last [`Lidar::scan_mesh_into`] did.
    pub fn last_mesh_stats(&self) -> MeshScanStats {
        self.mesh.stats
    }

    /// The ranges of a planar scan of `mesh`'s walls from the sensor pose `sp` into `out`
    /// (every range `inf` before); `false` (ranges untouched) if the sensor stands on a line
    /// of the triangulation or outside it, or the scan is not planar.
    pub(super) fn sweep_mesh(&mut self, mesh: &ScanMesh, sp: Pose2, out: &mut Scan) -> bool {
        let mut scratch = std::mem::take(&mut self.mesh);
        scratch.stats = MeshScanStats::default();
        let ok = self.config.channels == 1
            && match self.simd {
                // SAFETY: `simd` is found from the CPU: it runs these instructions.
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx512 => unsafe { self.walk_avx512(mesh, sp, &mut out.ranges, &mut scratch) },
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx2 => unsafe { self.walk_avx2(mesh, sp, &mut out.ranges, &mut scratch) },
                _ => self.walk::<false>(mesh, sp, &mut out.ranges, &mut scratch),
            };
        scratch.stats.fell_back = !ok;
        self.mesh = scratch;
        ok
    }

    /// [`Lidar::walk`] built for AVX2 and FMA (the same ranges: no fused multiply-add is
    /// asked for).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn walk_avx2(&self, mesh: &ScanMesh, sp: Pose2, ranges: &mut [Real], sc: &mut MeshScratch) -> bool {
        self.walk::<false>(mesh, sp, ranges, sc)
    }

    /// [`Lidar::walk`] built for AVX-512: the same code and ranges, with 32 vector registers
    /// instead of 16, so that the walk's loop keeps its values in registers (5–6 % faster on
    /// the atrium of `ut_gdc_floor2`), and the angles of corners from a 14-bit reciprocal
    /// instead of a division (see [`atan2_rcp14`]; 3–5 % faster there).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq")]
    fn walk_avx512(&self, mesh: &ScanMesh, sp: Pose2, ranges: &mut [Real], sc: &mut MeshScratch) -> bool {
        self.walk::<true>(mesh, sp, ranges, sc)
    }

    /// The walk (see the module's doc); `RCP14`: the CPU runs AVX-512 (see [`atan2_rcp14`]).
    #[inline(always)]
    fn walk<const RCP14: bool>(&self, mesh: &ScanMesh, sp: Pose2, ranges: &mut [Real], sc: &mut MeshScratch) -> bool {
        let s = [sp.x, sp.y];
        let Some(t0) = mesh.locate(s) else {
            return false;
        };
        let c = self.config;
        let (ys, yc) = sp.yaw.sin_cos();
        let w = Walker { lidar: self, mesh, s, ys, yc, mask: c.columns as i64 - 1, r2: c.max_range * c.max_range, zs: c.mount.z, low: c.mount.z <= mesh.lowest, rcp14: RCP14 };
        // (`Lidar::new` builds the beam tables of `columns` beams, a power of two)
        debug_assert!(c.columns.is_power_of_two() && self.az_sin.len() == c.columns && self.az_cos.len() == c.columns);
        let n = c.columns as i64;
        let recast = &mut sc.recast;
        recast.clear();
        let stack = &mut sc.stack;
        stack.clear();
        let sweeps = &mut sc.sweeps;
        sweeps.clear();
        let stats = &mut sc.stats;
        // the start cell: its corners' columns, in turn counter-clockwise round the sensor
        let (cs, at) = mesh.corners(t0);
        let k = cs.len();
        let mut p = [[0.0; 2]; MAX_CORNERS + 1];
        let mut cols = [0i64; MAX_CORNERS + 1];
        for i in 0..k {
            p[i] = w.frame(cs[i]);
            cols[i] = w.col(p[i], recast);
            if i > 0 {
                let behind = cols[i - 1] - cols[i];
                if behind > 0 {
                    cols[i] += n * ((behind + n - 1) / n);
                }
            }
        }
        (p[k], cols[k]) = (p[0], cols[0] + n);
        for i in 0..k {
            if let Some(next) = w.edge(at + i, p[i], p[i + 1], cols[i], cols[i + 1], sweeps) {
                stack.push(next);
            }
        }
        let mut cur = stack.pop();
        let mut cells = 0;
        while let Some(win) = cur {
            cells += 1;
            let (cs, at) = mesh.corners_across(win.t);
            let k = cs.len();
            let e = win.e as usize;
            // out through the edges from corner e + 1 round to corner e: each takes the beams
            // up to (clockwise of) its far corner
            let (mut lo, j1) = (win.j0 as i64, win.j1 as i64);
            if j1 - lo == 1 {
                cur = w.one_beam(cs, at, e, &win, recast, sweeps).or_else(|| stack.pop());
                continue;
            }
            let mut from = win.pu;
            let mut i = if e + 1 == k { 0 } else { e + 1 };
            let mut next: Option<Window> = None;
            loop {
                let i1 = if i + 1 == k { 0 } else { i + 1 };
                let (to, m) = if i1 == e {
                    (win.pv, j1)
                } else {
                    // SAFETY: `i1 < k`, a corner of the cell
                    let to = w.frame(unsafe { *cs.get_unchecked(i1) });
                    (to, w.split(to, lo, j1, recast))
                };
                if let Some(out) = w.edge(at + i, from, to, lo, m, sweeps) {
                    match next {
                        None => next = Some(out),
                        Some(_) => stack.push(out),
                    }
                }
                if m >= j1 {
                    break;
                }
                (lo, from, i) = (m, to, i1);
            }
            // on through one side at once, the others later
            cur = next.or_else(|| stack.pop());
        }
        stats.cells = cells;
        match self.simd {
            // SAFETY: `simd` is found from the CPU: it runs these instructions.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => unsafe { self.sweep_walked_avx512(&w, ranges, sc) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => unsafe { self.sweep_walked_avx2(&w, ranges, sc) },
            _ => self.sweep_walked_portable(&w, ranges, sc),
        }
        true
    }

    /// [`Lidar::sweep_walked`] built for AVX-512 (the same ranges).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq")]
    #[inline(never)]
    fn sweep_walked_avx512(&self, w: &Walker, ranges: &mut [Real], sc: &mut MeshScratch) {
        self.sweep_walked(w, ranges, sc);
    }

    /// [`Lidar::sweep_walked`] built for AVX2 and FMA (the same ranges: no fused multiply-add
    /// is asked for).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline(never)]
    fn sweep_walked_avx2(&self, w: &Walker, ranges: &mut [Real], sc: &mut MeshScratch) {
        self.sweep_walked(w, ranges, sc);
    }

    /// [`Lidar::sweep_walked`] for any CPU.
    #[inline(never)]
    fn sweep_walked_portable(&self, w: &Walker, ranges: &mut [Real], sc: &mut MeshScratch) {
        self.sweep_walked(w, ranges, sc);
    }

    /// After the walk: the beams of each wall edge reached, with its walls' exact hits, and
    /// the beams through a corner or missed cast again against every wall (out of the walk's
    /// function, so that the code after it does not change how its loop is built: with the
    /// small sweeps' code inside it, the loop ran 6–9 % slower on `ut_gdc_floor2`; built for
    /// the CPU as the walk is, so that the sweep of each wall is inlined).
    #[inline(always)]
    fn sweep_walked(&self, w: &Walker, ranges: &mut [Real], sc: &mut MeshScratch) {
        let mesh = w.mesh;
        let (sweeps, recast) = (&sc.sweeps, &mut sc.recast);
        // the beams of each wall edge reached, with its walls' exact hits (after the walk, so
        // that its loop stays small), and those the walls missed marked for recasting
        // (with AVX-512 the sweeps of a few beams first, eight beams at once; the others listed
        // in `big`)
        let mut missed = false;
        let big = &mut sc.big;
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
        let mut batched = false;
        #[cfg(target_arch = "x86_64")]
        if self.simd == SimdLevel::Avx512 && sweeps.len() < 1 << 24 {
            // SAFETY: the CPU runs AVX-512 (`simd`); under 2^24 sweeps (indices times six
            // within an `i32`)
            missed = unsafe { small_sweeps_avx512(sweeps, &mut sc.jobs, big, w.mask, &self.az_cos, &self.az_sin, ranges) };
            batched = true;
        }
        if !batched {
            big.clear();
            big.extend(0..sweeps.len() as u32);
        }
        for sw in big.iter().map(|&i| &sweeps[i as usize]) {
            let (j0, count) = (sw.j0 as i64, (sw.j1 - sw.j0) as usize);
            if sw.edge == NONE {
                // (its ends as the walk transformed them, the wall's own)
                missed |= self.sweep_flat(sw.a, sw.b, j0, count, ranges);
                continue;
            }
            for seg in mesh.walls_on(sw.edge as usize) {
                if w.blocks(seg) {
                    missed |= self.sweep_flat(w.frame(seg.a), w.frame(seg.b), j0, count, ranges);
                }
            }
        }
        if missed {
            // (rare: a beam may also have been missed by one wall of an edge and hit by another)
            for sw in sweeps.iter() {
                for j in sw.j0..sw.j1 {
                    let i = (j as i64 & w.mask) as usize;
                    if ranges[i] == Real::INFINITY {
                        recast.push(i as u32);
                    }
                }
            }
        }
        // beams through a corner, or missed by the wall they crossed: against every wall
        recast.sort_unstable();
        recast.dedup();
        (sc.stats.walls_swept, sc.stats.beams_recast) = (sweeps.len(), recast.len());
        // (a beam along a wall's line, within rounding, gets from its hit test a quotient of
        // two roundings: a "hit" nearer than the wall itself is no hit, as the other scans,
        // which skip a wall no nearer than the beam's range so far, never see it)
        for &i in recast.iter() {
            let i = i as usize;
            let mut best = Real::INFINITY;
            for seg in mesh.segments.iter().filter(|seg| w.blocks(seg)) {
                let (a, b) = (w.frame(seg.a), w.frame(seg.b));
                ranges[i] = Real::INFINITY;
                self.sweep(a, b, seg.height, i as i64, 1, w.zs, -1.0, ranges);
                let t = ranges[i];
                if t < best && t >= seg_origin_distance(a, b) * (1.0 - 1e-9) {
                    best = t;
                }
            }
            ranges[i] = best;
        }
    }
}

/// The sweeps of at most [`SMALL`] beams of a whole wall (`edge` [`NONE`]) in `sweeps`, eight
/// beams at once (the same test and quotient as [`Lidar::sweep_flat`]; the walls loaded whole
/// and transposed, the beams' directions and ranges gathered by index, the ranges scattered
/// back: the sweeps' beams are distinct), the others listed in `big` (their indices); returns
/// whether one of the beams has no range after them. On the atrium of `ut_gdc_floor2` at 20 m, where 201 of a
/// scan's 303 sweeps are of one or two beams, a scan took 4 % less than with each swept alone.
///
/// `mask` is the columns less one (a power of two less one), `cos`, `sin` and `best` hold a
/// beam each, and `sweeps` has fewer than 2^24 records (its indices times six fit an `i32`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq")]
fn small_sweeps_avx512(sweeps: &[Sweep], jobs: &mut Vec<[u32; 2]>, big: &mut Vec<u32>, mask: i64, cos: &[Real], sin: &[Real], best: &mut [Real]) -> bool {
    use std::arch::x86_64::*;
    // the jobs (a beam and its sweep's record, six `f64`s a record), written without branches:
    // every sweep writes SMALL jobs, kept by its count if it is small, and its index in `big`,
    // kept if not (the eight jobs after the last are of sweep 0 and beam 0: read, masked off)
    let need = SMALL * sweeps.len() + 8;
    if jobs.len() < need {
        jobs.resize(need, [0, 0]);
    }
    big.clear();
    big.resize(sweeps.len(), 0);
    let (mut k, mut nb) = (0, 0);
    for (i, sw) in sweeps.iter().enumerate() {
        let count = sw.j1 - sw.j0;
        let small = (count <= SMALL as i32) & (sw.edge == NONE);
        let id = 6 * i as u32;
        // SAFETY: `k + SMALL <= SMALL * (i + 1) < need`, `nb <= i`
        unsafe {
            for o in 0..SMALL {
                *jobs.get_unchecked_mut(k + o) = [id, ((sw.j0 + o as i32) as i64 & mask) as u32];
            }
            *big.get_unchecked_mut(nb) = i as u32;
        }
        k += if small { count as usize } else { 0 };
        nb += !small as usize;
    }
    big.truncate(nb);
    // SAFETY: `k + 8 <= need`
    unsafe { std::ptr::write_bytes(jobs.as_mut_ptr().add(k), 0, 8) };
    let base = sweeps.as_ptr() as *const Real;
    let zero = _mm512_setzero_pd();
    let inf = _mm512_set1_pd(Real::INFINITY);
    let (mut parallel, mut missed) = (0u8, 0u8);
    for at in (0..k).step_by(8) {
        let on: __mmask8 = if k - at >= 8 { 0xff } else { (1u8 << (k - at)) - 1 };
        // SAFETY: `at + 8 <= k + 8 <= need` jobs, each of a sweep (index times six: 48-byte
        // records, `Sweep` is `repr(C)`) and a beam (masked to a column), the jobs after the
        // last of sweep 0 and beam 0; the lanes off are not written
        unsafe {
            let job = jobs.as_ptr().add(at);
            let beam = _mm512_cvtepi64_epi32(_mm512_srli_epi64::<32>(_mm512_loadu_si512(job as *const __m512i)));
            // the eight sweeps' walls (a0 a1 b0 b1 each) loaded whole and turned into four
            // vectors of eight (fewer instructions than four gathers)
            let wall = |o: usize| _mm256_loadu_pd(base.add((*job.add(o))[0] as usize));
            let two = |o: usize| _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(wall(o)), wall(o + 1));
            let (z0, z1, z2, z3) = (two(0), two(2), two(4), two(6));
            // (x0: a0 of walls 0 2, b0 of 0 2, a0 of 1 3, b0 of 1 3; x1 the same of walls 4 to
            // 7; y0, y1 the same of a1 and b1)
            let (x0, x1) = (_mm512_unpacklo_pd(z0, z1), _mm512_unpacklo_pd(z2, z3));
            let (y0, y1) = (_mm512_unpackhi_pd(z0, z1), _mm512_unpackhi_pd(z2, z3));
            let (first, second) = (_mm512_set_epi64(13, 9, 12, 8, 5, 1, 4, 0), _mm512_set_epi64(15, 11, 14, 10, 7, 3, 6, 2));
            let (a0, b0) = (_mm512_permutex2var_pd(x0, first, x1), _mm512_permutex2var_pd(x0, second, x1));
            let (a1, b1) = (_mm512_permutex2var_pd(y0, first, y1), _mm512_permutex2var_pd(y0, second, y1));
            let dc = _mm512_mask_i32gather_pd::<8>(zero, on, beam, cos.as_ptr());
            let ds = _mm512_mask_i32gather_pd::<8>(zero, on, beam, sin.as_ptr());
            let old = _mm512_mask_i32gather_pd::<8>(inf, on, beam, best.as_ptr());
            let (e0, e1) = (_mm512_sub_pd(b0, a0), _mm512_sub_pd(b1, a1));
            let ae = _mm512_sub_pd(_mm512_mul_pd(a0, e1), _mm512_mul_pd(a1, e0));
            let den = _mm512_sub_pd(_mm512_mul_pd(dc, e1), _mm512_mul_pd(ds, e0));
            let sn = _mm512_sub_pd(_mm512_mul_pd(a0, ds), _mm512_mul_pd(a1, dc));
            let ahead =
                _mm512_cmp_pd_mask::<_CMP_GT_OQ>(den, zero) & _mm512_cmp_pd_mask::<_CMP_GE_OQ>(ae, zero) & _mm512_cmp_pd_mask::<_CMP_GE_OQ>(sn, zero) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(sn, den);
            let behind =
                _mm512_cmp_pd_mask::<_CMP_LT_OQ>(den, zero) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(ae, zero) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(sn, zero) & _mm512_cmp_pd_mask::<_CMP_GE_OQ>(sn, den);
            let t = _mm512_div_pd(ae, den);
            let take = (ahead | behind) & on & _mm512_cmp_pd_mask::<_CMP_LT_OQ>(t, old);
            let new = _mm512_mask_mov_pd(old, take, t);
            _mm512_mask_i32scatter_pd::<8>(best.as_mut_ptr(), on, beam, new);
            parallel |= on & _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(den, zero);
            missed |= on & _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(new, inf);
        }
    }
    if parallel != 0 {
        // a beam parallel to its wall (rare): the general test
        missed = 0;
        for &[id, i] in &jobs[..k] {
            let (sw, i) = (&sweeps[id as usize / 6], i as usize);
            best[i] = parallel_beam(sw.a, sw.b, cos[i], sin[i], best[i]);
            missed |= (best[i] == Real::INFINITY) as u8;
        }
    }
    missed != 0
}

/// The most beams of a sweep that [`small_sweeps_avx512`] takes (2, 4, 6, 8, 12 tried on the
/// atrium of `ut_gdc_floor2`: 4 the fastest).
const SMALL: usize = 4;
// (`small_sweeps_avx512` reads a sweep's walls as the first four `f64`s of 48-byte records)
const _: () = assert!(std::mem::size_of::<Sweep>() == 48 && std::mem::offset_of!(Sweep, a) == 0 && std::mem::offset_of!(Sweep, b) == 16);

/// [`fast_atan2`] with its one division replaced by AVX-512's reciprocal to 2^-14 (a fifth of
/// the division's latency on the walk's path from a corner to its column): within 7.3e-5 rad
/// (its bound, tested, and `fast_atan2`'s), a fortieth of a beam step at 2 048 columns, so
/// that [`Walker::column`]'s tests of the beams beside it still find the column.
///
/// Only where the CPU runs AVX-512 (the walk's AVX-512 build, [`Walker::rcp14`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn atan2_rcp14(y: Real, x: Real) -> Real {
    use std::arch::x86_64::{_mm_cvtsd_f64, _mm_rcp14_sd, _mm_set_sd, _mm_setzero_pd};
    // SAFETY: called only where the CPU runs AVX-512 (see above)
    atan2_by(y, x, |n, d| n * unsafe { _mm_cvtsd_f64(_mm_rcp14_sd(_mm_setzero_pd(), _mm_set_sd(d))) })
}

/// How near (m) a beam passes a corner of the triangulation to be cast again against every
/// wall: far above the rounding of any hit test (about 1e-16 of the distances involved), far
/// below the gap between beams.
const NEAR: Real = 1e-9;

/// The kind (see [`WHOLE`]) of the corner edge `u → v` of a cell (which lies on its left)
/// as that cell sees the `walls` on it: if every one of them is the whole edge, and those that
/// face the cell (two-sided, or one-sided running `v → u`: a one-sided wall faces its right)
/// are one wall (or copies of one), [`WHOLE`] or [`WHOLE_BACK`] by its direction; if none
/// faces the cell, [`BEHIND`]; else 0. (A thin obstacle of a map is outlined both ways: two
/// one-sided walls on one edge, one facing each side.)
fn whole_kind<'a>(walls: impl Iterator<Item = &'a Segment>, u: [Real; 2], v: [Real; 2]) -> u32 {
    let mut facing: Option<([Real; 2], [Real; 2])> = None;
    for seg in walls {
        let ends = (seg.a, seg.b);
        if ends != (u, v) && ends != (v, u) {
            return 0;
        }
        if seg.one_sided && ends == (u, v) {
            continue;
        }
        if facing.is_some_and(|f| f != ends) {
            return 0;
        }
        facing = Some(ends);
    }
    match facing {
        None => BEHIND,
        Some(ends) if ends == (u, v) => WHOLE,
        Some(_) => WHOLE_BACK,
    }
}

/// Cell `c` (an index into `start`) as [`ScanMesh::across`] gives it.
fn across_of(start: &[u32], c: usize) -> u32 {
    if c == 0 {
        0
    } else {
        start[c] << 4 | (start[c + 1] - start[c])
    }
}

/// Marks beams `i` and `k` (unless [`NONE`]) for recasting: rare, kept out of the walk's loop.
#[cold]
#[inline(never)]
fn mark(recast: &mut Vec<u32>, i: u32, k: u32) {
    recast.push(i);
    if k != NONE {
        recast.push(k);
    }
}

/// One scan's walk (see [`Lidar::walk`]).
struct Walker<'a> {
    lidar: &'a Lidar,
    mesh: &'a ScanMesh,
    /// The sensor's place, and its yaw's sine and cosine.
    s: [Real; 2],
    ys: Real,
    yc: Real,
    /// Columns less one (a power of two less one).
    mask: i64,
    /// The squared range.
    r2: Real,
    /// The sensor's height.
    zs: Real,
    /// Whether the sensor is no higher than the lowest wall (see [`WHOLE`]).
    low: bool,
    /// Whether the CPU runs AVX-512: corners' angles by [`atan2_rcp14`] (a constant in each
    /// build of the walk).
    rcp14: bool,
}

impl Walker<'_> {
    /// Whether wall `seg` stops the planar ring's beams: it stands higher than the sensor and
    /// faces it.
    #[inline(always)]
    fn blocks(&self, seg: &Segment) -> bool {
        self.zs <= seg.height && seg.faces(self.s)
    }

    /// The world point `p` in the sensor's frame (as the other scans compute it).
    #[inline(always)]
    fn frame(&self, p: [Real; 2]) -> [Real; 2] {
        let (dx, dy) = (p[0] - self.s[0], p[1] - self.s[1]);
        [self.yc * dx + self.ys * dy, -self.ys * dx + self.yc * dy]
    }

    /// `p × d_j`: ≥ 0 if beam `j` is at or counter-clockwise of `p` (within half a turn).
    #[inline(always)]
    fn side(&self, p: [Real; 2], j: i64) -> Real {
        let i = (j & self.mask) as usize;
        // SAFETY: the beam tables hold `mask + 1` beams (`Lidar::new`).
        unsafe { p[0] * *self.lidar.az_sin.get_unchecked(i) - p[1] * *self.lidar.az_cos.get_unchecked(i) }
    }

    /// Marks for recasting beams `j - 1` and `j` if they pass within [`NEAR`] of `p`: there
    /// the other scans' hit tests may round a wall's end point either way.
    #[inline(always)]
    fn near(&self, p: [Real; 2], j: i64, recast: &mut Vec<u32>) {
        for j in [j - 1, j] {
            if self.side(p, j).abs() <= NEAR {
                mark(recast, (j & self.mask) as u32, NONE);
            }
        }
    }

    /// The first column at or counter-clockwise of `p` (sensor frame), near its angle: from
    /// the angle (within 1.1e-5 rad, or 7.3e-5 with AVX-512's reciprocal, far below a beam
    /// step), set right by the beams beside it.
    #[inline(always)]
    fn column(&self, p: [Real; 2]) -> i64 {
        #[cfg(target_arch = "x86_64")]
        let angle = if self.rcp14 { atan2_rcp14(p[1], p[0]) } else { fast_atan2(p[1], p[0]) };
        #[cfg(not(target_arch = "x86_64"))]
        let angle = fast_atan2(p[1], p[0]);
        let j = iceil(angle * self.lidar.inv_step);
        if self.side(p, j) < 0.0 {
            j + 1
        } else if self.side(p, j - 1) >= 0.0 {
            j - 1
        } else {
            j
        }
    }

    /// [`Walker::column`], the beams beside `p` marked for recasting if near it.
    #[inline(always)]
    fn col(&self, p: [Real; 2], recast: &mut Vec<u32>) -> i64 {
        let j = self.column(p);
        self.near(p, j, recast);
        j
    }

    /// The first column of `j0..j1` at or counter-clockwise of `p` (`j1` if none); `p` and
    /// the beams lie within half a turn of each other.
    #[inline(always)]
    fn split(&self, p: [Real; 2], j0: i64, j1: i64, recast: &mut Vec<u32>) -> i64 {
        // the end beams first, both at once: most windows leave whole by one side (one branch
        // to foresee instead of two)
        let (first, last) = (self.side(p, j0), self.side(p, j1 - 1));
        if (first >= 0.0) | (last < 0.0) {
            if (first.abs() <= NEAR) | (last.abs() <= NEAR) {
                mark(recast, (j0 & self.mask) as u32, ((j1 - 1) & self.mask) as u32);
            }
            return if first >= 0.0 { j0 } else { j1 };
        }
        // beam j0 is clockwise of p, beam j1 - 1 at or counter-clockwise of it
        let m = if j1 - j0 <= 8 {
            let mut m = j0 + 1;
            for j in j0 + 1..j1 - 1 {
                m += (self.side(p, j) < 0.0) as i64;
            }
            m
        } else {
            // (the column taken to the window's turn; within the window by the tests above)
            let n = self.mask + 1;
            let m = self.column(p);
            (m + n * (((j0 + j1) >> 1) - m + n / 2).div_euclid(n)).clamp(j0 + 1, j1 - 1)
        };
        self.near(p, m, recast);
        m
    }

    /// The walk of a window of one beam (`win`, into the cell of corners `cs`, the first at
    /// `at`, through its edge `e`): out through the edge whose far corner the beam passes
    /// clockwise of, the beam marked for recasting if it passes near a corner tested, as the
    /// edges one by one find it (see [`Lidar::walk`]), with one test per corner instead of
    /// [`Walker::split`]'s two, and without its third outcome (a split window). A third of
    /// the windows entering cells on the atrium of `ut_gdc_floor2` at 20 m are of one beam; the
    /// scan there took 5 % less (14.50 against 15.25–15.30 µs; the same test inside `split`
    /// saved 1–2 %).
    #[inline(always)]
    fn one_beam(&self, cs: &[[Real; 2]], at: usize, e: usize, win: &Window, recast: &mut Vec<u32>, sweeps: &mut Vec<Sweep>) -> Option<Window> {
        let k = cs.len();
        let j = win.j0 as i64;
        let b = (j & self.mask) as usize;
        // SAFETY: the beam tables hold `mask + 1` beams (`Lidar::new`)
        let (sin, cos) = unsafe { (*self.lidar.az_sin.get_unchecked(b), *self.lidar.az_cos.get_unchecked(b)) };
        let mut from = win.pu;
        let mut i = if e + 1 == k { 0 } else { e + 1 };
        loop {
            let i1 = if i + 1 == k { 0 } else { i + 1 };
            if i1 == e {
                return self.edge(at + i, from, win.pv, j, j + 1, sweeps);
            }
            // SAFETY: `i1 < k`, a corner of the cell
            let to = self.frame(unsafe { *cs.get_unchecked(i1) });
            // (as `Walker::side`)
            let side = to[0] * sin - to[1] * cos;
            if side.abs() <= NEAR {
                mark(recast, b as u32, NONE);
            }
            if side < 0.0 {
                return self.edge(at + i, from, to, j, j + 1, sweeps);
            }
            (from, i) = (to, i1);
        }
    }

    /// The beams `j0..j1` crossing the corner edge `g` (see [`ScanMesh::link`]; its ends `p`,
    /// `q` in the sensor frame, clockwise end first as the sensor sees it): listed in `sweeps`
    /// (swept after the walk) if a wall there blocks them, else the window into the next cell.
    #[inline(always)]
    fn edge(&self, g: usize, p: [Real; 2], q: [Real; 2], j0: i64, j1: i64, sweeps: &mut Vec<Sweep>) -> Option<Window> {
        if j0 >= j1 {
            return None;
        }
        let (dp, dq) = (p[0] * p[0] + p[1] * p[1], q[0] * q[0] + q[1] * q[1]);
        if dp > self.r2 && dq > self.r2 {
            let e = sub2(q, p);
            let cr = cross2(p, e);
            if cr * cr > self.r2 * (e[0] * e[0] + e[1] * e[1]) {
                return None; // the edge's line is out of range
            }
        }
        let link = self.mesh.link(g);
        if link & LINK_WALL != 0 {
            let kind = (link >> LINK_KIND) & 3;
            if self.low && kind != 0 {
                // one wall, the whole edge: it blocks the beams if it faces the cell, as the
                // sensor, on the cell's side of the edge's line, sees it then
                if kind != BEHIND {
                    let (a, b) = if kind == WHOLE { (p, q) } else { (q, p) };
                    sweeps.push(Sweep { a, b, j0: j0 as i32, j1: j1 as i32, edge: NONE });
                    return None;
                }
            } else if self.mesh.walls_on(g).any(|seg| self.blocks(seg)) {
                sweeps.push(Sweep { a: p, b: q, j0: j0 as i32, j1: j1 as i32, edge: g as u32 });
                return None;
            }
        }
        let nb = link & LINK_CELL;
        (nb != 0).then_some(Window { pv: q, pu: p, j0: j0 as i32, j1: j1 as i32, t: self.mesh.across(g), e: (link >> LINK_BACK) & 15 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::generate::{generate, GeneratorConfig};

    /// The table check the walk's unchecked reads rely on passes on built meshes and names
    /// each kind of index out of bounds.
    #[test]
    fn table_check_finds_indices_out_of_bounds() {
        let walls = generate(5, &GeneratorConfig::default()).unwrap().scenario.map.segments;
        let mesh = ScanMesh::new(&walls).unwrap();
        assert_eq!(mesh.check_tables(), Ok(()));
        let cells = mesh.cells() as u32;
        let g = mesh.link.iter().position(|&l| l & LINK_CELL != 0).unwrap();
        let wall = mesh.link.iter().position(|&l| l & LINK_WALL != 0).unwrap();
        let mut broken: Vec<(&str, ScanMesh)> = Vec::new();
        let mut m = mesh.clone();
        m.link[g] = (m.link[g] & !LINK_CELL) | (cells + 1);
        broken.push(("link", m));
        let mut m = mesh.clone();
        m.link[g] |= 15 << LINK_BACK;
        broken.push(("link", m));
        let mut m = mesh.clone();
        *m.start.last_mut().unwrap() += 1;
        broken.push(("start", m));
        let mut m = mesh.clone();
        m.edge_wall[wall] = m.edge_walls.len() as u32;
        broken.push(("edge_wall", m));
        let mut m = mesh.clone();
        m.wall_ids[0] = walls.len() as u32;
        broken.push(("wall_ids", m));
        let mut m = mesh.clone();
        m.grid[0] = cells + 1;
        broken.push(("grid", m));
        let mut m = mesh.clone();
        m.across[g] += 1;
        broken.push(("across", m));
        for (what, m) in broken {
            let err = m.check_tables().unwrap_err();
            assert!(err.0.contains(what), "{what}: {err}");
        }
    }

    /// Every cell is strictly convex and counter-clockwise, and every link leads to the
    /// neighbour's copy of the same edge, walked the other way; wall edges lie on their walls.
    #[test]
    fn cells_are_convex_and_linked_both_ways() {
        let walls = generate(3, &GeneratorConfig::default()).unwrap().scenario.map.segments;
        let mesh = ScanMesh::new(&walls).unwrap();
        assert!(mesh.cells() > 10);
        let (mut merged, mut kinds) = (0, [0; 4]);
        for c in 1..=mesh.cells() {
            let (cs, at) = mesh.corners(c);
            let k = cs.len();
            assert!((3..=MAX_CORNERS).contains(&k));
            merged += (k > 3) as usize;
            for i in 0..k {
                let (p, q, r) = (cs[i], cs[(i + 1) % k], cs[(i + 2) % k]);
                assert!(cross2(sub2(q, p), sub2(r, q)) > 0.0, "cell {c} corner {i}");
                let link = mesh.link[at + i];
                let nb = (link & LINK_CELL) as usize;
                if nb != 0 {
                    let (ns, _) = mesh.corners(nb);
                    let b = ((link >> LINK_BACK) & 15) as usize;
                    assert_eq!((ns[b], ns[(b + 1) % ns.len()]), (q, p), "cell {c} edge {i}");
                }
                if link & LINK_WALL != 0 {
                    let [w0, w1] = mesh.edge_walls[mesh.edge_wall[at + i] as usize];
                    for &w in &mesh.wall_ids[w0 as usize..w1 as usize] {
                        let s = &walls[w as usize];
                        assert!(s.distance_to_point(p) < 1e-9 && s.distance_to_point(q) < 1e-9);
                    }
                    // a kind: walls that are the whole edge, of which those facing the cell
                    // (on its left) all run p → q, or all q → p, or there are none
                    let kind = (link >> LINK_KIND) & 3;
                    kinds[kind as usize] += 1;
                    if kind != 0 {
                        let on: Vec<&Segment> = mesh.wall_ids[w0 as usize..w1 as usize].iter().map(|&w| &walls[w as usize]).collect();
                        assert!(on.iter().all(|s| (s.a, s.b) == (p, q) || (s.a, s.b) == (q, p)), "cell {c} edge {i}");
                        let facing: Vec<_> = on.iter().filter(|s| !s.one_sided || (s.a, s.b) == (q, p)).map(|s| (s.a, s.b)).collect();
                        match kind {
                            WHOLE => assert!(!facing.is_empty() && facing.iter().all(|&e| e == (p, q))),
                            WHOLE_BACK => assert!(!facing.is_empty() && facing.iter().all(|&e| e == (q, p))),
                            _ => assert!(facing.is_empty()),
                        }
                    }
                }
            }
        }
        assert!(merged > 0, "no triangles merged");
        // walls seen from their front and from their back (one-sided)
        assert!(kinds[WHOLE_BACK as usize] > 0 && kinds[BEHIND as usize] > 0, "{kinds:?}");
    }

    /// An edge's kind as each of its two cells sees it: a thin wall outlined both ways (two
    /// one-sided walls) blocks from either side as the wall facing it; a two-sided wall given
    /// twice is one wall; a one-sided wall seen from behind blocks nothing; a two-sided wall
    /// and a one-sided one facing the same cell are tested one by one.
    #[test]
    fn edge_kinds_as_each_side_sees_them() {
        let (a, b) = ([1.0, 1.0], [3.0, 1.5]);
        let kinds_of = |walls: &[Segment]| {
            let mut all = walls.to_vec();
            all.extend([Segment::new([0.0, 0.0], [4.0, 0.0], 1.0), Segment::new([4.0, 0.0], [4.0, 3.0], 1.0), Segment::new([4.0, 3.0], [0.0, 3.0], 1.0), Segment::new([0.0, 3.0], [0.0, 0.0], 1.0)]);
            let mesh = ScanMesh::new(&all).unwrap();
            // (the kind from the cell on the left of a → b, then from the one on its right)
            let mut seen = [None, None];
            for c in 1..=mesh.cells() {
                let (cs, at) = mesh.corners(c);
                for i in 0..cs.len() {
                    let (p, q) = (cs[i], cs[(i + 1) % cs.len()]);
                    let kind = (mesh.link[at + i] >> LINK_KIND) & 3;
                    if (p, q) == (a, b) {
                        seen[0] = Some(kind);
                    } else if (p, q) == (b, a) {
                        seen[1] = Some(kind);
                    }
                }
            }
            [seen[0].unwrap(), seen[1].unwrap()]
        };
        assert_eq!(kinds_of(&[Segment::new(a, b, 1.0)]), [WHOLE, WHOLE_BACK]);
        assert_eq!(kinds_of(&[Segment::one_sided(a, b, 1.0)]), [BEHIND, WHOLE_BACK]);
        assert_eq!(kinds_of(&[Segment::one_sided(a, b, 1.0), Segment::one_sided(b, a, 1.0)]), [WHOLE_BACK, WHOLE_BACK]);
        assert_eq!(kinds_of(&[Segment::new(b, a, 1.0), Segment::new(b, a, 1.0)]), [WHOLE_BACK, WHOLE]);
        assert_eq!(kinds_of(&[Segment::one_sided(a, b, 1.0), Segment::one_sided(a, b, 2.0)]), [BEHIND, WHOLE_BACK]);
        assert_eq!(kinds_of(&[Segment::new(a, b, 1.0), Segment::one_sided(b, a, 1.0)]), [0, WHOLE_BACK]);
    }

    /// Whether this CPU runs AVX-512 (else the test says it is skipped).
    #[cfg(target_arch = "x86_64")]
    fn runs_avx512() -> bool {
        let yes = SimdLevel::detect() == SimdLevel::Avx512;
        if !yes {
            eprintln!("SKIPPED: no AVX-512 on this CPU");
        }
        yes
    }

    /// The sweeps of a few beams taken eight beams at once give each sweep's own ranges (and
    /// whether a beam is left without one), bit for bit: walls across their beams, walls some
    /// beams miss, walls along beam 0 (parallel to it, the beam on or beside the wall's line),
    /// runs across column 0, ranges already partly filled; the longer sweeps and those of
    /// several walls are left listed, in order.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn small_sweeps_equal_each_sweep_alone() {
        use rand::{Rng, SeedableRng};
        if !runs_avx512() {
            return;
        }
        let lidar = Lidar::new(crate::sensors::LidarConfig { columns: 1024, range_noise_std: 0.0, ..Default::default() }).unwrap();
        let n = 1024i32;
        let step = std::f64::consts::TAU / n as Real;
        let at = |j: Real, d: Real| [d * (j * step).cos(), d * (j * step).sin()];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (mut parallel, mut missing, mut hit) = (0, 0, 0);
        for round in 0..200 {
            let mut sweeps = Vec::new();
            let mut j = rng.random_range(-3..1);
            while j < n - 12 {
                let count = if sweeps.is_empty() { rng.random_range(1 - j..=4) } else { rng.random_range(1..=6) };
                let (j0, j1) = (j as Real, (j + count - 1) as Real);
                let (a, b) = match if sweeps.is_empty() && round % 2 == 0 { 2 } else { rng.random_range(0..4) } {
                    // across the run's beams, or short of its ends
                    0 => (at(j0 - 0.4, rng.random_range(0.5..15.0)), at(j1 + 0.4, rng.random_range(0.5..15.0))),
                    1 => (at(j0 + 0.3, rng.random_range(0.5..15.0)), at(j1 - 0.3, rng.random_range(0.5..15.0))),
                    // along beam 0 (on its line, or beside it), for runs over it
                    2 if j <= 0 && j + count > 0 => {
                        let y = if rng.random_bool(0.5) { 0.0 } else { 0.5 };
                        if rng.random_bool(0.5) {
                            ([1.0, y], [4.0, y])
                        } else {
                            ([4.0, y], [1.0, y])
                        }
                    }
                    _ => (at(rng.random_range(0.0..n as Real), rng.random_range(0.5..15.0)), at(rng.random_range(0.0..n as Real), rng.random_range(0.5..15.0))),
                };
                let edge = if rng.random_bool(0.1) { 7 } else { NONE };
                sweeps.push(Sweep { a, b, j0: j, j1: j + count, edge });
                j += count + rng.random_range(0..3);
            }
            let start: Vec<Real> = (0..n).map(|_| if rng.random_bool(0.2) { rng.random_range(0.5..15.0) } else { Real::INFINITY }).collect();
            let (mut want, mut want_missed, mut want_big) = (start.clone(), false, Vec::new());
            for (i, sw) in sweeps.iter().enumerate() {
                let count = (sw.j1 - sw.j0) as usize;
                if sw.edge == NONE && count <= SMALL {
                    want_missed |= lidar.sweep_flat(sw.a, sw.b, sw.j0 as i64, count, &mut want);
                    let e = sub2(sw.b, sw.a);
                    parallel += (sw.j0..sw.j1).any(|j| j == 0 && e[1] == 0.0) as usize;
                } else {
                    want_big.push(i as u32);
                }
            }
            let (mut got, mut jobs, mut big) = (start.clone(), Vec::new(), Vec::new());
            // SAFETY: this CPU runs AVX-512
            let got_missed = unsafe { small_sweeps_avx512(&sweeps, &mut jobs, &mut big, (n - 1) as i64, &lidar.az_cos, &lidar.az_sin, &mut got) };
            let diff: Vec<_> = (0..n as usize).filter(|&i| want[i].to_bits() != got[i].to_bits()).map(|i| (i, want[i], got[i])).collect();
            assert!(diff.is_empty(), "round {round}: {diff:?}");
            assert_eq!((got_missed, big), (want_missed, want_big), "round {round}");
            missing += want_missed as usize;
            hit += (0..n as usize).filter(|&i| want[i] < start[i]).count();
        }
        assert!(parallel >= 100 && missing > 100 && hit > 20_000, "parallel {parallel}, missing {missing}, hit {hit}");
    }

    /// The angle from AVX-512's reciprocal is within its bound (7.3e-5 rad) of `atan2`, all
    /// round and at any distance, and the division's within its own (2e-5).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn reciprocal_angle_is_within_its_bound() {
        if !runs_avx512() {
            return;
        }
        let (mut worst, mut worst_div): (Real, Real) = (0.0, 0.0);
        for k in 0..200_000 {
            let a = k as Real * std::f64::consts::TAU / 200_000.0 - std::f64::consts::PI;
            let d = [1e-3, 0.37, 1.0, 7.9, 150.0][k % 5];
            let (y, x) = (a.sin() * d, a.cos() * d);
            worst = worst.max((atan2_rcp14(y, x) - y.atan2(x)).abs());
            worst_div = worst_div.max((fast_atan2(y, x) - y.atan2(x)).abs());
        }
        // (7.3e-5 rad: 2^-14 from the reciprocal plus the polynomial's 1.1e-5; a beam step at
        // 2 048 columns is 3.07e-3 rad)
        assert!(worst < 7.3e-5 && worst > worst_div && worst_div < 2e-5, "worst {worst}, with the division {worst_div}");
    }
}
