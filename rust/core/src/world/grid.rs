//! Occupancy grids: the raster form of a site, turned into merged wall segments.
//!
//! Cell `(i, j)` is column `i` (along the grid's x) and row `j` counted from the *bottom*
//! (along its y); its lower-left corner is `origin ∘ (i·res, j·res)`.

use super::bitrow::{extract_runs, pack_cells, words_for};
pub use super::cell::Cell;
use super::geometry::{Point2, Pose2, Segment};
use crate::error::{Error, Result};
use crate::math::Real;

/// A rectangular occupancy grid placed in the world by `origin` (m, rad).
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyGrid {
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// Cell edge (m).
    pub resolution: Real,
    /// The world pose of the lower-left corner of cell `(0, 0)`.
    pub origin: Pose2,
    /// Row-major from the bottom row: `cells[j * width + i]`.
    pub cells: Vec<Cell>,
}

impl Drop for OccupancyGrid {
    /// Hands the cells to the thread's buffer pool for the next grid.
    fn drop(&mut self) {
        let mut cells = std::mem::ManuallyDrop::new(std::mem::take(&mut self.cells));
        // SAFETY: `Cell` is `repr(u8)`: the buffer is a valid `Vec<u8>` of the same layout.
        super::recycle::give(unsafe { Vec::from_raw_parts(cells.as_mut_ptr().cast::<u8>(), cells.len(), cells.capacity()) });
    }
}

/// Most cells of a grid (a 50 × 50 km site at 5 cm; one byte each).
pub const MAX_CELLS: usize = 1 << 40;

impl OccupancyGrid {
    /// A `width × height` grid filled with `fill` (at most [`MAX_CELLS`] cells).
    pub fn new(width: usize, height: usize, resolution: Real, origin: Pose2, fill: Cell) -> Result<Self> {
        if width == 0 || height == 0 || width.checked_mul(height).is_none_or(|n| n > MAX_CELLS) {
            return Err(Error::invalid("grid", format!("size must be positive and at most {MAX_CELLS} cells, got {width} x {height}")));
        }
        if !(resolution.is_finite() && resolution > 0.0) {
            return Err(Error::invalid("resolution", format!("must be finite and > 0, got {resolution}")));
        }
        origin.validate("origin")?;
        let mut bytes = std::mem::ManuallyDrop::new(super::recycle::take(width * height, fill as u8));
        // SAFETY: `Cell` is `repr(u8)` and every byte holds `fill`, a valid `Cell`.
        let cells = unsafe { Vec::from_raw_parts(bytes.as_mut_ptr().cast::<Cell>(), bytes.len(), bytes.capacity()) };
        Ok(Self { width, height, resolution, origin, cells })
    }

    /// The cell `(i, j)`.
    ///
    /// # Panics
    ///
    /// If `(i, j)` lies outside the grid, as slice indexing does (see [`OccupancyGrid::world_to_cell`]).
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> Cell {
        self.cells[j * self.width + i]
    }

    /// Sets the cell `(i, j)`.
    ///
    /// # Panics
    ///
    /// If `(i, j)` lies outside the grid, as slice indexing does.
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, c: Cell) {
        self.cells[j * self.width + i] = c;
    }

    /// World position of the centre of cell `(i, j)`.
    pub fn cell_center(&self, i: usize, j: usize) -> Point2 {
        self.grid_to_world([(i as Real + 0.5) * self.resolution, (j as Real + 0.5) * self.resolution])
    }

    /// Grid-frame metres to world.
    #[inline]
    pub fn grid_to_world(&self, p: Point2) -> Point2 {
        self.origin.transform_point(p)
    }

    /// The cell containing world point `p`, if inside the grid.
    pub fn world_to_cell(&self, p: Point2) -> Option<(usize, usize)> {
        let q = self.origin.inverse_transform_point(p);
        let (x, y) = (q[0] / self.resolution, q[1] / self.resolution);
        // on [0, width) truncation is the floor (and no libm call); NaN fails every test
        (x >= 0.0 && y >= 0.0 && x < self.width as Real && y < self.height as Real).then_some((x as usize, y as usize))
    }

    /// Sets every cell whose centre lies in the grid-frame box `[x0, x1] × [y0, y1]` (m).
    pub fn fill_rect(&mut self, x0: Real, y0: Real, x1: Real, y1: Real, c: Cell) {
        let r = self.resolution;
        let i0 = ((x0 / r - 0.5).ceil().max(0.0)) as usize;
        let j0 = ((y0 / r - 0.5).ceil().max(0.0)) as usize;
        let i1 = ((x1 / r - 0.5).floor().min(self.width as Real - 1.0)) as i64;
        let j1 = ((y1 / r - 0.5).floor().min(self.height as Real - 1.0)) as i64;
        if i1 < i0 as i64 || j1 < j0 as i64 {
            return;
        }
        let w = self.width;
        for j in j0..=j1 as usize {
            self.cells[j * w + i0..=j * w + i1 as usize].fill(c);
        }
    }

    /// Whether every cell with its centre in the grid-frame box is `c` (false if the box leaves
    /// the grid).
    pub fn rect_is(&self, x0: Real, y0: Real, x1: Real, y1: Real, c: Cell) -> bool {
        let r = self.resolution;
        if x0 < 0.0 || y0 < 0.0 || x1 > self.width as Real * r || y1 > self.height as Real * r {
            return false;
        }
        let i0 = (x0 / r - 0.5).ceil() as i64;
        let j0 = (y0 / r - 0.5).ceil() as i64;
        let i1 = ((x1 / r - 0.5).floor() as i64).min(self.width as i64 - 1);
        let j1 = ((y1 / r - 0.5).floor() as i64).min(self.height as i64 - 1);
        if i1 < i0 || j1 < j0 {
            return true;
        }
        let w = self.width;
        (j0 as usize..=j1 as usize).all(|j| self.cells[j * w + i0 as usize..=j * w + i1 as usize].iter().fold(true, |acc, x| acc & (*x as u8 == c as u8)))
    }

    /// Row `j` of cells.
    #[inline]
    pub fn row(&self, j: usize) -> &[Cell] {
        &self.cells[j * self.width..(j + 1) * self.width]
    }

    /// The boundary of the solid cells (those for which `solid` holds) as one-sided wall
    /// segments of `height` (m), the solid on each wall's left: every cell edge with a solid
    /// cell on exactly one side (the grid's outside is not solid), collinear neighbouring edges
    /// with the solid on the same side merged into one straight run. Horizontal walls come
    /// first, by row then column; then vertical walls, by column then row.
    ///
    /// Rows are packed 64 cells to a word and only rows that differ from the row below are
    /// looked at, so a grid of long straight walls costs little more than comparing its rows.
    pub fn wall_segments(&self, height: Real, solid: impl Fn(Cell) -> bool) -> Vec<Segment> {
        let (w, h) = (self.width, self.height);
        let r = self.resolution;
        let select = [solid(Cell::Free), solid(Cell::Occupied), solid(Cell::Unknown)];
        let mut out = Vec::new();
        let emit = |out: &mut Vec<Segment>, p: Point2, q: Point2, solid_left_when_forward: bool| {
            let (p, q) = (self.grid_to_world(p), self.grid_to_world(q));
            out.push(if solid_left_when_forward { Segment::one_sided(p, q, height) } else { Segment::one_sided(q, p, height) });
        };
        // solid bits of the rows below and above grid line y = j (off the grid: not solid)
        let (nw, lw) = (words_for(w), words_for(w + 1));
        let (mut below, mut above) = (vec![0u64; nw], vec![0u64; nw]);
        // per vertical grid line x = i (bit i): an open run of edges, its side, its first row
        let (mut open, mut open_left) = (vec![0u64; lw], vec![0u64; lw]);
        let mut open_from = vec![0usize; w + 1];
        let (mut edge, mut left) = (vec![0u64; lw], vec![0u64; lw]);
        let mut vertical: Vec<(usize, usize, usize, bool)> = Vec::new();
        let (mut up, mut down, mut runs) = (vec![0u64; nw], vec![0u64; nw], Vec::new());
        for j in 0..=h {
            if j > 0 && j < h && rows_equal(self.row(j), self.row(j - 1)) {
                continue; // no horizontal edge on this line, the vertical runs go on
            }
            if j < h {
                pack_cells(self.row(j), select, &mut above);
            } else {
                above.fill(0);
            }
            // horizontal edges on grid line y = j, in runs of one side, from left to right;
            // +x has +y on its left: forward when the solid is above
            for q in 0..nw {
                up[q] = above[q] & !below[q];
                down[q] = below[q] & !above[q];
            }
            runs.clear();
            extract_runs(&up, &mut runs);
            let n_up = runs.len();
            extract_runs(&down, &mut runs);
            let (ups, downs) = runs.split_at(n_up);
            let (mut a, mut b) = (0, 0);
            while a < ups.len() || b < downs.len() {
                let take_up = b == downs.len() || (a < ups.len() && ups[a].0 < downs[b].0);
                let (run, is_up) = if take_up { (ups[a], true) } else { (downs[b], false) };
                if take_up {
                    a += 1
                } else {
                    b += 1
                }
                emit(&mut out, [run.0 as Real * r, j as Real * r], [(run.1 + 1) as Real * r, j as Real * r], is_up);
            }
            // vertical edges of row j on grid lines x = i: solid on exactly one side, side =
            // solid at -x; +y has -x on its left: forward when the solid is at -x
            for q in 0..lw {
                let cur = if q < nw { above[q] } else { 0 };
                left[q] = (cur << 1) | if q > 0 { above[q - 1] >> 63 } else { 0 };
                edge[q] = cur ^ left[q];
            }
            for q in 0..lw {
                let going = open[q] & edge[q] & !(open_left[q] ^ left[q]);
                let (mut close, mut start) = (open[q] & !going, edge[q] & !going);
                while close != 0 {
                    let i = q * 64 + close.trailing_zeros() as usize;
                    vertical.push((i, open_from[i], j, open_left[q] >> (i % 64) & 1 == 1));
                    close &= close - 1;
                }
                while start != 0 {
                    open_from[q * 64 + start.trailing_zeros() as usize] = j;
                    start &= start - 1;
                }
                open[q] = edge[q];
                open_left[q] = left[q] & edge[q];
            }
            std::mem::swap(&mut below, &mut above);
        }
        vertical.sort_unstable_by_key(|v| (v.0, v.1));
        for (i, j0, j1, left) in vertical {
            emit(&mut out, [i as Real * r, j0 as Real * r], [i as Real * r, j1 as Real * r], left);
        }
        out
    }

    /// Distance (m) from each cell centre to the nearest cell centre for which `blocked` holds
    /// (exact Euclidean distance transform, Felzenszwalb–Huttenlocher); `inf` if none is.
    pub fn distance_field(&self, blocked: impl Fn(Cell) -> bool) -> Vec<Real> {
        const BIG: Real = 1e18;
        let (w, h) = (self.width, self.height);
        let mut f: Vec<Real> = self.cells.iter().map(|&c| if blocked(c) { 0.0 } else { BIG }).collect();
        let n = w.max(h);
        let (mut line, mut d, mut v, mut z) = (vec![0.0; n], vec![0.0; n], vec![0usize; n], vec![0.0; n + 1]);
        for i in 0..w {
            for j in 0..h {
                line[j] = f[j * w + i];
            }
            edt_1d(&line[..h], &mut d[..h], &mut v, &mut z);
            for j in 0..h {
                f[j * w + i] = d[j];
            }
        }
        for j in 0..h {
            line[..w].copy_from_slice(&f[j * w..(j + 1) * w]);
            edt_1d(&line[..w], &mut d[..w], &mut v, &mut z);
            f[j * w..(j + 1) * w].copy_from_slice(&d[..w]);
        }
        let r = self.resolution;
        f.into_iter().map(|s| if s >= BIG * 0.5 { Real::INFINITY } else { s.sqrt() * r }).collect()
    }

    /// Marks as occupied every cell a wall of `segments` passes through (sampled at a quarter
    /// cell, so no cell a segment crosses is skipped by more than a corner).
    pub fn rasterize_segments(&mut self, segments: &[Segment]) {
        for s in segments {
            // an axis-aligned wall in an unrotated grid covers one row (column) of cells from
            // its first sample's cell to its last's: the samples below step < one cell, so
            // they hit exactly those (the last sample is `a + 1 (b − a)`, as below)
            if self.origin.yaw == 0.0 && (s.a[0] == s.b[0] || s.a[1] == s.b[1]) {
                let end = [s.a[0] + (s.b[0] - s.a[0]), s.a[1] + (s.b[1] - s.a[1])];
                if let (Some((i0, j0)), Some((i1, j1))) = (self.world_to_cell(s.a), self.world_to_cell(end)) {
                    for j in j0.min(j1)..=j0.max(j1) {
                        let row = j * self.width;
                        self.cells[row + i0.min(i1)..=row + i0.max(i1)].fill(Cell::Occupied);
                    }
                    continue;
                }
            }
            self.rasterize_sampled(s);
        }
    }

    /// Marks the cells of samples a quarter cell apart along `s`, both ends included.
    fn rasterize_sampled(&mut self, s: &Segment) {
        let len = s.length();
        let n = (len / (0.25 * self.resolution)).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as Real / n as Real;
            let p = [s.a[0] + t * (s.b[0] - s.a[0]), s.a[1] + t * (s.b[1] - s.a[1])];
            if let Some((i, j)) = self.world_to_cell(p) {
                self.set(i, j, Cell::Occupied);
            }
        }
    }
}

/// Whether two rows of cells are equal (one `memcmp` of their bytes).
pub(crate) fn rows_equal(a: &[Cell], b: &[Cell]) -> bool {
    // SAFETY: `Cell` is `repr(u8)`: a slice of cells is a slice of as many bytes.
    let bytes = |x: &[Cell]| unsafe { std::slice::from_raw_parts(x.as_ptr().cast::<u8>(), x.len()) };
    bytes(a) == bytes(b)
}

/// 1D squared distance transform of sampled function `f` into `d`.
fn edt_1d(f: &[Real], d: &mut [Real], v: &mut [usize], z: &mut [Real]) {
    let n = f.len();
    let mut k = 0usize;
    v[0] = 0;
    z[0] = Real::NEG_INFINITY;
    z[1] = Real::INFINITY;
    let sq = |q: usize| (q * q) as Real;
    for q in 1..n {
        let mut s = ((f[q] + sq(q)) - (f[v[k]] + sq(v[k]))) / (2.0 * (q as Real - v[k] as Real));
        while s <= z[k] {
            k -= 1;
            s = ((f[q] + sq(q)) - (f[v[k]] + sq(v[k]))) / (2.0 * (q as Real - v[k] as Real));
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = Real::INFINITY;
    }
    k = 0;
    for (q, dq) in d.iter_mut().enumerate() {
        while z[k + 1] < q as Real {
            k += 1;
        }
        let dd = q as Real - v[k] as Real;
        *dq = dd * dd + f[v[k]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_aligned_walls_rasterize_exactly_as_sampled() {
        // ends on cell edges, inside cells, reversed, zero-length and leaving the grid
        let walls: Vec<Segment> = (0..400)
            .map(|k| {
                let f = |m: usize| ((k * m) % 97) as Real * 0.0371 - 0.3;
                let (x, y, l) = (f(7), f(13), f(29) - 1.0);
                if k % 2 == 0 {
                    Segment::new([x, y], [x + l, y], 1.0)
                } else {
                    Segment::new([x, y], [x, y + l * 0.05 / 0.05], 1.0)
                }
            })
            .chain([Segment::new([0.5, 0.5], [2.0, 0.5], 1.0), Segment::new([1.0, 0.25], [1.0, 3.0], 1.0), Segment::new([-1.0, 1.0], [1.0, 1.0], 1.0)])
            .collect();
        let origin = Pose2::new(-0.1, -0.2, 0.0);
        let mut fast = OccupancyGrid::new(80, 90, 0.05, origin, Cell::Free).unwrap();
        fast.rasterize_segments(&walls);
        let mut sampled = OccupancyGrid::new(80, 90, 0.05, origin, Cell::Free).unwrap();
        for w in &walls {
            sampled.rasterize_sampled(w);
        }
        assert!(fast.cells.iter().filter(|c| **c == Cell::Occupied).count() > 500);
        assert_eq!(fast.cells, sampled.cells);
    }

    #[test]
    fn single_occupied_block_gives_its_outline() {
        let mut g = OccupancyGrid::new(6, 5, 0.5, Pose2::new(1.0, 2.0, 0.0), Cell::Free).unwrap();
        for j in 1..3 {
            for i in 2..5 {
                g.set(i, j, Cell::Occupied);
            }
        }
        let segs = g.wall_segments(2.0, |c| c == Cell::Occupied);
        assert_eq!(segs.len(), 4, "{segs:?}");
        let total: Real = segs.iter().map(|s| s.length()).sum();
        assert!((total - 2.0 * (1.5 + 1.0)).abs() < 1e-12);
        // the solid is above the bottom edge, so it runs +x; every wall faces out of the block
        assert!(segs.iter().any(|s| s.a == [2.0, 2.5] && s.b == [3.5, 2.5]));
        let inside = |p: Point2| p[0] > 2.0 && p[0] < 3.5 && p[1] > 2.5 && p[1] < 3.5;
        for s in &segs {
            let (m, e) = ([0.5 * (s.a[0] + s.b[0]), 0.5 * (s.a[1] + s.b[1])], [s.b[0] - s.a[0], s.b[1] - s.a[1]]);
            let right = [m[0] + 0.01 * e[1].signum(), m[1] - 0.01 * e[0].signum()];
            let left = [m[0] - 0.01 * e[1].signum(), m[1] + 0.01 * e[0].signum()];
            assert!(s.one_sided && s.faces(right) && !s.faces(left) && !inside(right) && inside(left), "{s:?}");
        }
    }

    /// The cell-by-cell scan `wall_segments` replaced: every line, every cell.
    fn wall_segments_reference(g: &OccupancyGrid, height: Real, solid: impl Fn(Cell) -> bool) -> Vec<Segment> {
        let (w, h) = (g.width, g.height);
        let occ = |i: i64, j: i64| i >= 0 && j >= 0 && (i as usize) < w && (j as usize) < h && solid(g.get(i as usize, j as usize));
        let r = g.resolution;
        let mut out = Vec::new();
        let mut emit = |p: Point2, q: Point2, fwd: bool| {
            let (p, q) = (g.grid_to_world(p), g.grid_to_world(q));
            out.push(if fwd { Segment::one_sided(p, q, height) } else { Segment::one_sided(q, p, height) });
        };
        for j in 0..=h as i64 {
            let mut run: Option<(i64, bool)> = None;
            for i in 0..=w as i64 {
                let edge = (i < w as i64 && occ(i, j - 1) != occ(i, j)).then(|| occ(i, j));
                if let Some((i0, above)) = run {
                    if edge != Some(above) {
                        emit([i0 as Real * r, j as Real * r], [i as Real * r, j as Real * r], above);
                        run = None;
                    }
                }
                if run.is_none() {
                    run = edge.map(|s| (i, s));
                }
            }
        }
        for i in 0..=w as i64 {
            let mut run: Option<(i64, bool)> = None;
            for j in 0..=h as i64 {
                let edge = (j < h as i64 && occ(i - 1, j) != occ(i, j)).then(|| occ(i - 1, j));
                if let Some((j0, left)) = run {
                    if edge != Some(left) {
                        emit([i as Real * r, j0 as Real * r], [i as Real * r, j as Real * r], left);
                        run = None;
                    }
                }
                if run.is_none() {
                    run = edge.map(|s| (j, s));
                }
            }
        }
        out
    }

    #[test]
    fn wall_segments_match_the_cell_by_cell_scan() {
        let mut s = 7u64;
        let mut next = |n: usize| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 33) as usize % n
        };
        for case in 0..40 {
            let (w, h) = (1 + next(200), 1 + next(50));
            let mut g = OccupancyGrid::new(w, h, 0.05, Pose2::new(1.0, -2.0, 0.3 * case as Real), Cell::Free).unwrap();
            for _ in 0..next(12) {
                let (x0, y0) = (next(w), next(h));
                let (x1, y1) = ((x0 + next(30)).min(w - 1), (y0 + next(30)).min(h - 1));
                let c = [Cell::Occupied, Cell::Unknown, Cell::Free][next(3)];
                for j in y0..=y1 {
                    for i in x0..=x1 {
                        g.set(i, j, c);
                    }
                }
            }
            for _ in 0..next(20) {
                g.set(next(w), next(h), Cell::Occupied);
            }
            for solid in [|c: Cell| c == Cell::Occupied, |c: Cell| c != Cell::Free] {
                assert_eq!(g.wall_segments(2.0, solid), wall_segments_reference(&g, 2.0, solid), "case {case}");
            }
        }
    }

    #[test]
    fn fill_rect_and_rect_is_follow_cell_centres() {
        let boxes = [(0.12, 0.31, 0.77, 0.52), (-1.0, -1.0, 0.1, 0.1), (0.4, 0.2, 9.0, 0.23), (0.3, 0.3, 0.31, 0.31), (0.6, 0.1, 0.2, 0.5)];
        for (k, &(x0, y0, x1, y1)) in boxes.iter().enumerate() {
            let mut g = OccupancyGrid::new(17, 12, 0.05, Pose2::default(), Cell::Free).unwrap();
            g.fill_rect(x0, y0, x1, y1, Cell::Occupied);
            let mut any = false;
            for j in 0..12 {
                for i in 0..17 {
                    let (cx, cy) = ((i as Real + 0.5) * 0.05, (j as Real + 0.5) * 0.05);
                    let want = cx >= x0 && cx <= x1 && cy >= y0 && cy <= y1;
                    assert_eq!(g.get(i, j) == Cell::Occupied, want, "box {k} cell ({i}, {j})");
                    any |= want;
                }
            }
            let inside_grid = x0 >= 0.0 && y0 >= 0.0 && x1 <= 17.0 * 0.05 && y1 <= 12.0 * 0.05;
            assert_eq!(g.rect_is(x0, y0, x1, y1, Cell::Occupied), inside_grid, "box {k}");
            assert_eq!(g.rect_is(x0, y0, x1, y1, Cell::Free), inside_grid && !any, "box {k}");
        }
    }

    #[test]
    fn distance_field_matches_brute_force() {
        let mut g = OccupancyGrid::new(17, 11, 0.1, Pose2::default(), Cell::Free).unwrap();
        for (i, j) in [(0, 0), (5, 7), (16, 3), (9, 9)] {
            g.set(i, j, Cell::Occupied);
        }
        let d = g.distance_field(|c| c != Cell::Free);
        for j in 0..11 {
            for i in 0..17 {
                let bf = [(0, 0), (5, 7), (16, 3), (9, 9)].iter().map(|&(a, b): &(i32, i32)| (((a - i as i32).pow(2) + (b - j as i32).pow(2)) as Real).sqrt() * 0.1).fold(Real::INFINITY, Real::min);
                assert!((d[j * 17 + i] - bf).abs() < 1e-12, "({i},{j}) {} vs {bf}", d[j * 17 + i]);
            }
        }
    }

    #[test]
    fn world_to_cell_inverts_cell_center_with_yaw() {
        let g = OccupancyGrid::new(10, 8, 0.05, Pose2::new(3.0, -1.0, 0.7), Cell::Free).unwrap();
        for (i, j) in [(0, 0), (9, 7), (4, 2)] {
            assert_eq!(g.world_to_cell(g.cell_center(i, j)), Some((i, j)));
        }
        assert_eq!(g.world_to_cell([-100.0, 0.0]), None);
    }
}
