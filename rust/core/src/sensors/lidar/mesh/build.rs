//! The triangulation of a world's walls, merged into convex cells, as flat tables.

use std::collections::HashMap;

use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, PositionInTriangulation, Triangulation};

use super::tables::*;
use crate::math::Real;
use crate::world::{cross2, sub2, Segment};

/// A triangulation of a world's walls for the planar scan (see the module's doc), its
/// triangles merged into convex cells where no wall parts them.
#[derive(Debug, Clone)]
pub struct ScanMesh {
    pub(super) segments: Vec<Segment>,
    /// Cell `c`'s corners (counter-clockwise) are `corner[start[c]..start[c + 1]]`; cell 0 is
    /// the outside of the box (no corners); the others in the order of their middles along a
    /// Z curve, so that neighbours are mostly near in memory.
    pub(super) start: Vec<u32>,
    pub(super) corner: Vec<[Real; 2]>,
    /// Per corner `i` of a cell, for its edge to corner `i + 1`: the cell across it (0: the
    /// outside) in the low 25 bits, the walls' kind as this cell sees them in the next two
    /// (see [`WHOLE`]), that edge's place among the neighbour's in the next four, and whether
    /// walls lie on it in the top bit (then `edge_wall` says which).
    pub(super) link: Vec<u32>,
    /// Per corner edge, the walls on it (an index into `edge_walls`), or [`NONE`].
    pub(super) edge_wall: Vec<u32>,
    /// Per corner edge, the cell across it as its first corner (an index into `corner`)
    /// times 16 plus its number of corners (0 for the outside): the walk goes on into it
    /// without reading `start`.
    pub(super) across: Vec<u32>,
    /// Per wall edge, the range of its walls in `wall_ids`.
    pub(super) edge_walls: Vec<[u32; 2]>,
    pub(super) wall_ids: Vec<u32>,
    /// A cell at the centre of each cell of a grid over the walls' box.
    pub(super) grid: Vec<u32>,
    pub(super) grid_origin: [Real; 2],
    pub(super) grid_cell: Real,
    pub(super) grid_dims: (usize, usize),
    /// The lowest wall's top: a sensor no higher sees every wall that faces it.
    pub(super) lowest: Real,
}

impl ScanMesh {
    /// Triangulates `segments` (finite, of non-zero length; walls that cross are split where
    /// they cross).
    pub fn new(segments: &[Segment]) -> Result<Self, NoMesh> {
        // (a failure inside the triangulation library is reported, not passed on as a panic)
        std::panic::catch_unwind(|| Self::build(segments)).unwrap_or_else(|_| Err(NoMesh("the triangulation failed".into())))
    }

    pub(super) fn build(segments: &[Segment]) -> Result<Self, NoMesh> {
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
    pub(super) fn check_tables(&self) -> Result<(), NoMesh> {
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
    pub(super) fn corners(&self, c: usize) -> (&[[Real; 2]], usize) {
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
    pub(super) fn corners_across(&self, t: u32) -> (&[[Real; 2]], usize) {
        let (at, k) = ((t >> 4) as usize, (t & 15) as usize);
        debug_assert!(at + k <= self.corner.len());
        // SAFETY: `t` is an entry of `across`, checked to be a cell's corners (`check_tables`).
        (unsafe { self.corner.get_unchecked(at..at + k) }, at)
    }

    /// The cell across corner edge `g` (see [`ScanMesh::across`]).
    #[inline(always)]
    pub(super) fn across(&self, g: usize) -> u32 {
        debug_assert!(g < self.across.len());
        // SAFETY: `g` is a corner of a cell, below `corner.len() == across.len()` (checked).
        unsafe { *self.across.get_unchecked(g) }
    }

    /// The link of corner edge `g` (an index into `corner`).
    #[inline(always)]
    pub(super) fn link(&self, g: usize) -> u32 {
        debug_assert!(g < self.link.len());
        // SAFETY: `g` is a corner of a cell, below `corner.len() == link.len()` (checked).
        unsafe { *self.link.get_unchecked(g) }
    }

    /// The walls on the wall edge `g` (its link has the wall bit).
    #[inline(always)]
    pub(super) fn walls_on(&self, g: usize) -> impl Iterator<Item = &Segment> {
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
    pub(super) fn locate(&self, s: [Real; 2]) -> Option<usize> {
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

/// The kind (see [`WHOLE`]) of the corner edge `u → v` of a cell (which lies on its left)
/// as that cell sees the `walls` on it: if every one of them is the whole edge, and those that
/// face the cell (two-sided, or one-sided running `v → u`: a one-sided wall faces its right)
/// are one wall (or copies of one), [`WHOLE`] or [`WHOLE_BACK`] by its direction; if none
/// faces the cell, [`BEHIND`]; else 0. (A thin obstacle of a map is outlined both ways: two
/// one-sided walls on one edge, one facing each side.)
pub(super) fn whole_kind<'a>(walls: impl Iterator<Item = &'a Segment>, u: [Real; 2], v: [Real; 2]) -> u32 {
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
pub(super) fn across_of(start: &[u32], c: usize) -> u32 {
    if c == 0 {
        0
    } else {
        start[c] << 4 | (start[c + 1] - start[c])
    }
}
