//! The configuration space of [`super::traverse`], built a row of 64 cells per word and
//! searched as runs of cells.
//!
//! 1. *Clearance*: `E` holds the cells whose centre is at least `need` from the centre of
//!    every blocked cell (not free, or outside the grid). Row by row it is the AND over
//!    `|dy| <= D` of row `j + dy` eroded horizontally by `w(dy)` cells.
//! 2. *Footprint*: for each of the 8 orientations `k`, `F_k` is the AND of `E` shifted by
//!    the footprint's disc-centre offsets.
//! 3. *Search*: each row of `F_k` is cut into runs of set cells; runs touching in the next
//!    row (8-neighbourhood) or overlapping in the next orientation (rotation in place) are
//!    joined in a union-find. A run's cells are connected along the run, so joining runs is
//!    the same as a breadth-first search over single configurations, only per run.
//!
//! Consecutive identical rows are computed once: a row of `E` (`F_k`) is recomputed only if a
//! row it depends on differs from its predecessor, and identical consecutive rows of `F_k`
//! share their runs. On a site of long straight walls this leaves a few hundred rows to work
//! on out of thousands.

use super::bitrow::{and_shifted, erode, pack_free, words_for};
use super::grid::{rows_equal, OccupancyGrid};
use crate::math::Real;

/// Orientations of the search: the 16 headings modulo the footprint's half-turn symmetry.
pub(crate) const ORIENTATIONS: usize = 8;

/// How the footprint is tested, in cells: the disc-centre offsets per orientation and the
/// clearance test as per-row erosion widths.
#[derive(Debug, Clone)]
pub(crate) struct Cover {
    /// Disc-centre offsets `(dx, dy)` of each orientation.
    pub offsets: Vec<Vec<(i32, i32)>>,
    /// `widths[|dy|]`: erosion half-width of row `j + dy` for `E(j)`, `|dy| <= D`.
    pub widths: Vec<usize>,
    /// The clearance a disc's cell needs (m), centre to centre.
    pub need: Real,
}

/// The searched configuration space: runs of free configurations, grouped by identical rows.
#[derive(Debug, Clone)]
pub(crate) struct Space {
    /// Grid rows.
    pub height: usize,
    /// `row_group[k * height + j]`: the group of row `j` in orientation `k`.
    pub row_group: Vec<u32>,
    /// A group's runs, as a range of `runs` (group 0 is empty).
    pub groups: Vec<(u32, u32)>,
    /// Runs of free configurations: first and last column (inclusive).
    pub runs: Vec<(i32, i32)>,
    /// Union-find parent of each run.
    parent: Vec<u32>,
}

impl Space {
    /// The runs of orientation `k` in row `j`.
    pub fn row_runs(&self, k: usize, j: usize) -> &[(i32, i32)] {
        let (a, b) = self.groups[self.row_group[k * self.height + j] as usize];
        &self.runs[a as usize..b as usize]
    }

    /// Index of the run of orientation `k` in row `j` that holds column `i`.
    pub fn run_at(&self, k: usize, j: usize, i: i32) -> Option<usize> {
        let (a, _) = self.groups[self.row_group[k * self.height + j] as usize];
        let runs = self.row_runs(k, j);
        let p = runs.partition_point(|r| r.1 < i);
        (p < runs.len() && runs[p].0 <= i).then_some(a as usize + p)
    }

    /// The component (root run) of run `r`.
    pub fn find(&mut self, mut r: usize) -> usize {
        while self.parent[r] as usize != r {
            let g = self.parent[self.parent[r] as usize];
            self.parent[r] = g;
            r = g as usize;
        }
        r
    }

    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.parent[hi] = lo as u32;
        }
    }

    /// Joins the runs of groups `g` and `h` that overlap, columns widened by `tol`.
    fn join(&mut self, g: u32, h: u32, tol: i32) {
        let ((mut a, ae), (mut b, be)) = (self.groups[g as usize], self.groups[h as usize]);
        while a < ae && b < be {
            let (p, q) = (self.runs[a as usize], self.runs[b as usize]);
            if p.1 + tol >= q.0 && q.1 + tol >= p.0 {
                self.union(a as usize, b as usize);
            }
            if p.1 < q.1 {
                a += 1;
            } else {
                b += 1;
            }
        }
    }
}

/// First and one-past-last nonzero word of `row` (an empty range if none).
fn nonzero_range(row: &[u64]) -> (usize, usize) {
    match row.iter().position(|w| *w != 0) {
        None => (0, 0),
        Some(lo) => (lo, row.len() - row.iter().rev().position(|w| *w != 0).unwrap()),
    }
}

/// Rows of bits stored once each, with the nonzero word range of each.
struct Pool {
    words: usize,
    data: Vec<u64>,
    range: Vec<(usize, usize)>,
}

impl Pool {
    /// A pool whose row 0 is all zeros.
    fn new(words: usize) -> Self {
        Self { words, data: vec![0; words], range: vec![(0, 0)] }
    }
    fn row(&self, r: u32) -> &[u64] {
        &self.data[r as usize * self.words..(r as usize + 1) * self.words]
    }
    fn push(&mut self, row: &[u64]) -> u32 {
        self.data.extend_from_slice(row);
        self.range.push(nonzero_range(row));
        (self.range.len() - 1) as u32
    }
}

/// Builds and searches the configuration space of `grid` under `cover`.
pub(crate) fn build(grid: &OccupancyGrid, cover: &Cover) -> Space {
    let (w, h) = (grid.width, grid.height);
    let nw = words_for(w);
    // distinct free rows
    let mut free = Pool::new(nw);
    let mut free_id = vec![0u32; h];
    let mut packed = vec![0u64; nw];
    for j in 0..h {
        let row = grid.row(j);
        if j > 0 && rows_equal(row, grid.row(j - 1)) {
            free_id[j] = free_id[j - 1];
        } else {
            pack_free(row, &mut packed);
            free_id[j] = free.push(&packed);
        }
    }
    let (e_idx, e) = clearance_rows(&free, &free_id, cover, nw);
    footprint_rows(&e, &e_idx, cover, w, h)
}

/// The rows of `E`: an index into the returned pool per grid row.
fn clearance_rows(free: &Pool, free_id: &[u32], cover: &Cover, nw: usize) -> (Vec<u32>, Pool) {
    let h = free_id.len();
    let d = cover.widths.len() - 1;
    // boundaries[t]: rows 0..t holding a change of free row (row t' differs from t' - 1)
    let mut boundaries = vec![0u32; h + 1];
    for t in 0..h {
        boundaries[t + 1] = boundaries[t] + (t > 0 && free_id[t] != free_id[t - 1]) as u32;
    }
    let mut e = Pool::new(nw);
    let mut e_idx = vec![0u32; h];
    // eroded free rows, by (free row, width), computed on demand
    let mut eroded = Pool::new(nw);
    let mut eroded_id = vec![u32::MAX; free.range.len() * (d + 1)];
    let (mut acc, mut tmp, mut out) = (vec![0u64; nw], vec![0u64; nw], vec![0u64; nw]);
    for j in d..h.saturating_sub(d) {
        if j > d && boundaries[j + d + 1] == boundaries[j - d] {
            e_idx[j] = e_idx[j - 1];
            continue;
        }
        acc.fill(!0);
        let mut dy = -(d as i64);
        while dy <= d as i64 {
            // a stretch of equal rows: erode once by the widest width it needs
            let id = free_id[(j as i64 + dy) as usize];
            let mut end = dy;
            while end < d as i64 && free_id[(j as i64 + end + 1) as usize] == id {
                end += 1;
            }
            let nearest = if dy <= 0 && end >= 0 { 0 } else { dy.abs().min(end.abs()) as usize };
            let key = id as usize * (d + 1) + nearest;
            if free.range[id as usize].0 == free.range[id as usize].1 {
                acc.fill(0);
                break;
            }
            if eroded_id[key] == u32::MAX {
                erode(free.row(id), cover.widths[nearest], &mut out, &mut tmp);
                eroded_id[key] = eroded.push(&out);
            }
            for (a, b) in acc.iter_mut().zip(eroded.row(eroded_id[key])) {
                *a &= b;
            }
            dy = end + 1;
        }
        e_idx[j] = if e.row(e_idx[j - 1]) == &acc[..] { e_idx[j - 1] } else { e.push(&acc) };
    }
    (e_idx, e)
}

/// The rows of every `F_k`, cut into runs and joined into components.
fn footprint_rows(e: &Pool, e_idx: &[u32], cover: &Cover, w: usize, h: usize) -> Space {
    let nw = words_for(w);
    let eat = |t: i64| if t < 0 || t >= h as i64 { 0 } else { e_idx[t as usize] };
    // e_changes[t + 1]: row t of E differs from row t - 1 (rows off the grid are zero)
    let e_changes: Vec<bool> = (-1..=h as i64).map(|t| eat(t) != eat(t - 1)).collect();
    let changed = |t: i64| t >= -1 && t <= h as i64 && e_changes[(t + 1) as usize];
    let last_mask = if w % 64 == 0 { !0 } else { (1u64 << (w % 64)) - 1 };
    let mut space = Space { height: h, row_group: vec![0; ORIENTATIONS * h], groups: vec![(0, 0)], runs: Vec::new(), parent: Vec::new() };
    let (mut cur, mut new) = (vec![0u64; nw], vec![0u64; nw]);
    for (k, offsets) in cover.offsets.iter().enumerate() {
        cur.fill(0);
        let (mut cur_range, mut new_range) = ((0, 0), (0, 0));
        let mut group = 0u32;
        for j in 0..h {
            let jj = j as i64;
            if j > 0 && !offsets.iter().any(|&(_, dy)| changed(jj + dy as i64)) {
                space.row_group[k * h + j] = group;
                continue;
            }
            // the words that can be nonzero: where every shifted E row can be
            let (mut lo, mut hi) = (0usize, nw);
            for &(_, dy) in offsets {
                let (a, b) = e.range[eat(jj + dy as i64) as usize];
                lo = lo.max(a.saturating_sub(1));
                hi = hi.min((b + 1).min(nw));
            }
            new[new_range.0..new_range.1].fill(0);
            new_range = if lo < hi { (lo, hi) } else { (0, 0) };
            if lo < hi {
                new[lo..hi].fill(!0);
                for &(dx, dy) in offsets {
                    and_shifted(&mut new, e.row(eat(jj + dy as i64)), dx, lo..hi);
                }
                new[nw - 1] &= last_mask;
            }
            let span = cur_range.0.min(new_range.0)..cur_range.1.max(new_range.1);
            if j > 0 && cur[span.clone()] == new[span] {
                space.row_group[k * h + j] = group;
                continue;
            }
            std::mem::swap(&mut cur, &mut new);
            std::mem::swap(&mut cur_range, &mut new_range);
            let first = space.runs.len() as u32;
            extract_runs(&cur, cur_range, &mut space.runs);
            let last = space.runs.len() as u32;
            space.parent.extend(first..last);
            let previous = group;
            group = if first == last { 0 } else { space.groups.push((first, last)); (space.groups.len() - 1) as u32 };
            space.row_group[k * h + j] = group;
            if previous != 0 && group != 0 {
                space.join(previous, group, 1);
            }
        }
    }
    // rotation in place: orientation k to k + 1 wherever either changes group
    for j in 0..h {
        for k in 0..ORIENTATIONS {
            let k2 = (k + 1) % ORIENTATIONS;
            let (g1, g2) = (space.row_group[k * h + j], space.row_group[k2 * h + j]);
            if g1 != 0 && g2 != 0 && (j == 0 || g1 != space.row_group[k * h + j - 1] || g2 != space.row_group[k2 * h + j - 1]) {
                space.join(g1, g2, 0);
            }
        }
    }
    space
}

/// Appends the runs of set bits of `row` within words `range` (zero outside it).
fn extract_runs(row: &[u64], range: (usize, usize), out: &mut Vec<(i32, i32)>) {
    let mut fill = out.len();
    for k in range.0..range.1 {
        let x = row[k];
        if x == 0 {
            continue;
        }
        let below = if k > range.0 { row[k - 1] >> 63 } else { 0 };
        let above = if k + 1 < range.1 { row[k + 1] & 1 } else { 0 };
        let mut starts = x & !((x << 1) | below);
        let mut ends = x & !((x >> 1) | (above << 63));
        while starts != 0 {
            out.push(((k * 64) as i32 + starts.trailing_zeros() as i32, -1));
            starts &= starts - 1;
        }
        while ends != 0 {
            out[fill].1 = (k * 64) as i32 + ends.trailing_zeros() as i32;
            fill += 1;
            ends &= ends - 1;
        }
    }
}
