//! The free cells of an occupancy grid 4-connected to a start cell, found run by run: each
//! row is packed into bits and cut into runs of free cells, runs overlapping in the next row
//! are joined in a union-find, and the start's component is what a 4-connected flood fill
//! from the start would mark, at a cost of words and runs instead of cells.

use super::bitrow::{extract_runs, pack_cells, words_for};
use super::grid::{Cell, OccupancyGrid};

/// The region 4-connected to a start cell through open cells ([`Cell::Free`] ones unless
/// [`FreeRegion::through`] says otherwise).
#[derive(Debug, Clone)]
pub(crate) struct FreeRegion {
    width: usize,
    /// Row `j`'s runs are `runs[row_start[j]..row_start[j + 1]]`.
    row_start: Vec<u32>,
    /// Free runs, first and last column (inclusive).
    runs: Vec<(i32, i32)>,
    /// Whether each run belongs to the start's region.
    inside: Vec<bool>,
}

/// The component (root run) of run `r` in the union-find `parent` (path halving).
pub(crate) fn find(parent: &mut [u32], mut r: usize) -> usize {
    while parent[r] as usize != r {
        let g = parent[parent[r] as usize];
        parent[r] = g;
        r = g as usize;
    }
    r
}

/// Joins the components of runs `a` and `b` (the lower root becomes the root).
pub(crate) fn union(parent: &mut [u32], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb)] = ra.min(rb) as u32;
    }
}

/// Joins every run of `runs[a.0..a.1]` with every run of `runs[b.0..b.1]` it overlaps, columns
/// widened by `tol` (both ranges sorted by column, runs disjoint within each).
pub(crate) fn join_overlapping(runs: &[(i32, i32)], parent: &mut [u32], (mut a, ae): (usize, usize), (mut b, be): (usize, usize), tol: i32) {
    while a < ae && b < be {
        let (p, q) = (runs[a], runs[b]);
        if p.1 + tol >= q.0 && q.1 + tol >= p.0 {
            union(parent, a, b);
        }
        if p.1 < q.1 {
            a += 1;
        } else {
            b += 1;
        }
    }
}

/// The place in `runs` (sorted, disjoint) of the run holding column `i`.
pub(crate) fn run_holding(runs: &[(i32, i32)], i: i32) -> Option<usize> {
    let p = runs.partition_point(|r| r.1 < i);
    (p < runs.len() && runs[p].0 <= i).then_some(p)
}

impl FreeRegion {
    /// The free cells connected to `(i, j)` (none if that cell is not free).
    pub(crate) fn new(grid: &OccupancyGrid, start: (usize, usize)) -> Self {
        Self::through(grid, start, [true, false, false])
    }

    /// The cells connected to `(i, j)` through open cells, cell `c` being open iff
    /// `open[c as usize]` (none if `(i, j)` is not open).
    pub(crate) fn through(grid: &OccupancyGrid, (si, sj): (usize, usize), open: [bool; 3]) -> Self {
        let (w, h) = (grid.width, grid.height);
        let mut packed = vec![0u64; words_for(w)];
        let mut runs = Vec::new();
        let mut row_start = Vec::with_capacity(h + 1);
        for j in 0..h {
            row_start.push(runs.len() as u32);
            pack_cells(grid.row(j), open, &mut packed);
            extract_runs(&packed, &mut runs);
        }
        row_start.push(runs.len() as u32);
        let mut parent: Vec<u32> = (0..runs.len() as u32).collect();
        for j in 1..h {
            let (above, below) = (row_start[j - 1] as usize, row_start[j] as usize);
            join_overlapping(&runs, &mut parent, (above, below), (below, row_start[j + 1] as usize), 0);
        }
        let mut region = Self { width: w, row_start, runs, inside: Vec::new() };
        let start = (si < w && sj < h).then(|| region.run_at(si, sj)).flatten().map(|r| find(&mut parent, r));
        region.inside = (0..region.runs.len()).map(|r| Some(find(&mut parent, r)) == start).collect();
        region
    }

    /// The run holding cell `(i, j)`, if that cell is free.
    fn run_at(&self, i: usize, j: usize) -> Option<usize> {
        let a = self.row_start[j] as usize;
        run_holding(&self.runs[a..self.row_start[j + 1] as usize], i as i32).map(|p| a + p)
    }

    /// A grid like `grid` whose region cells are free and all others occupied.
    pub(crate) fn as_grid(&self, grid: &OccupancyGrid) -> crate::error::Result<OccupancyGrid> {
        let mut g = OccupancyGrid::new(grid.width, grid.height, grid.resolution, grid.origin, Cell::Occupied)?;
        for j in 0..self.row_start.len() - 1 {
            for r in self.row_start[j] as usize..self.row_start[j + 1] as usize {
                if self.inside[r] {
                    let (a, b) = self.runs[r];
                    g.cells[j * self.width + a as usize..=j * self.width + b as usize].fill(Cell::Free);
                }
            }
        }
        Ok(g)
    }

    /// Whether cell `(i, j)` is in the region (false off the grid).
    pub(crate) fn contains(&self, i: usize, j: usize) -> bool {
        i < self.width && j + 1 < self.row_start.len() && self.run_at(i, j).is_some_and(|r| self.inside[r])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Pose2;
    use rand::{Rng, SeedableRng};

    /// The cell-by-cell 4-connected flood fill.
    fn flood(grid: &OccupancyGrid, s: (usize, usize)) -> Vec<bool> {
        let (w, h) = (grid.width, grid.height);
        let mut seen = vec![false; w * h];
        let mut stack = vec![s];
        while let Some((i, j)) = stack.pop() {
            if grid.get(i, j) != Cell::Free || seen[j * w + i] {
                continue;
            }
            seen[j * w + i] = true;
            for (di, dj) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (ni, nj) = (i as i64 + di, j as i64 + dj);
                if ni >= 0 && nj >= 0 && (ni as usize) < w && (nj as usize) < h {
                    stack.push((ni as usize, nj as usize));
                }
            }
        }
        seen
    }

    #[test]
    fn equals_the_cell_by_cell_flood_fill() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for (w, h, density) in [(70, 40, 0.3), (130, 65, 0.4), (200, 3, 0.2), (64, 64, 0.45), (1, 30, 0.2)] {
            for _ in 0..5 {
                let mut g = OccupancyGrid::new(w, h, 0.05, Pose2::default(), Cell::Free).unwrap();
                for j in 0..h {
                    for i in 0..w {
                        if rng.random_bool(density) {
                            g.set(i, j, if rng.random_bool(0.5) { Cell::Occupied } else { Cell::Unknown });
                        }
                    }
                }
                let s = (rng.random_range(0..w), rng.random_range(0..h));
                let region = FreeRegion::new(&g, s);
                let want = flood(&g, s);
                for j in 0..h {
                    for i in 0..w {
                        assert_eq!(region.contains(i, j), want[j * w + i], "{w}x{h} cell ({i}, {j}) from {s:?}");
                    }
                }
                assert!(!region.contains(w, 0) && !region.contains(0, h));
                // through free and unknown cells: the flood fill of the grid with unknown as free
                let mut g2 = g.clone();
                g2.cells.iter_mut().filter(|c| **c == Cell::Unknown).for_each(|c| *c = Cell::Free);
                let region = FreeRegion::through(&g, s, [true, false, true]);
                let want = flood(&g2, s);
                let as_grid = region.as_grid(&g).unwrap();
                for j in 0..h {
                    for i in 0..w {
                        assert_eq!(region.contains(i, j), want[j * w + i], "{w}x{h} cell ({i}, {j}) from {s:?}, through unknown");
                        assert_eq!(as_grid.get(i, j) == Cell::Free, want[j * w + i]);
                    }
                }
            }
        }
    }
}
