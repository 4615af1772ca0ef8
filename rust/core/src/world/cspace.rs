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
//! Consecutive identical rows are computed once: a row of `E` is recomputed only if a free
//! row it depends on differs from its predecessor, a row of `F_k` only in the words where an
//! `E` row it reads differs from its predecessor, and identical consecutive rows of `F_k`
//! share their runs. On a site of long straight walls this leaves a few hundred rows to work
//! on out of thousands.

use super::bitrow::{erode, extract_runs, pack_free, shifted_word, words_for};
use super::grid::{rows_equal, OccupancyGrid};
use super::region::{find, join_overlapping, run_holding};
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
    #[allow(dead_code)] // read by the move-sweep test of `traverse`
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
        run_holding(self.row_runs(k, j), i).map(|p| a as usize + p)
    }

    /// The component (root run) of run `r`.
    pub fn find(&mut self, r: usize) -> usize {
        find(&mut self.parent, r)
    }

    /// Joins the runs of groups `g` and `h` that overlap, columns widened by `tol`.
    fn join(&mut self, g: u32, h: u32, tol: i32) {
        let ((a, ae), (b, be)) = (self.groups[g as usize], self.groups[h as usize]);
        join_overlapping(&self.runs, &mut self.parent, (a as usize, ae as usize), (b as usize, be as usize), tol);
    }
}

/// First and one-past-last nonzero word of `row` (an empty range if none).
fn nonzero_range(row: &[u64]) -> (usize, usize) {
    match row.iter().position(|w| *w != 0) {
        None => (0, 0),
        Some(lo) => (lo, row.len() - row.iter().rev().position(|w| *w != 0).unwrap()),
    }
}

/// Rows of bits stored once each, with the nonzero word range of each. Each row is stored
/// between two zero words, so a shift by less than 64 cells reads no bounds.
struct Pool {
    words: usize,
    data: Vec<u64>,
    range: Vec<(usize, usize)>,
}

impl Pool {
    /// A pool whose row 0 is all zeros.
    fn new(words: usize) -> Self {
        Self { words, data: vec![0; words + 2], range: vec![(0, 0)] }
    }
    /// Row `r`.
    fn row(&self, r: u32) -> &[u64] {
        &self.padded(r)[1..=self.words]
    }
    /// Row `r` with its zero words before and after.
    fn padded(&self, r: u32) -> &[u64] {
        let n = self.words + 2;
        &self.data[r as usize * n..(r as usize + 1) * n]
    }
    fn push(&mut self, row: &[u64]) -> u32 {
        self.data.push(0);
        self.data.extend_from_slice(row);
        self.data.push(0);
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

/// For each row `t` of `E` from `-1` to `h` (at `t + 1`), a mask of the words in which it
/// differs from row `t - 1` (rows off the grid are zero), `mask_words` u64 per row.
fn row_changes(e: &Pool, e_idx: &[u32], mask_words: usize) -> Vec<u64> {
    let h = e_idx.len() as i64;
    let at = |t: i64| if t < 0 || t >= h { 0 } else { e_idx[t as usize] };
    let mut masks = vec![0u64; (h as usize + 2) * mask_words];
    for t in -1..=h {
        let (a, b) = (at(t - 1), at(t));
        if a != b {
            let mask = &mut masks[(t + 1) as usize * mask_words..(t + 2) as usize * mask_words];
            for (q, (x, y)) in e.row(a).iter().zip(e.row(b)).enumerate() {
                mask[q / 64] |= ((x != y) as u64) << (q % 64);
            }
        }
    }
    masks
}

/// The rows of every `F_k`, cut into runs and joined into components.
///
/// Row `j` of `F_k` differs from row `j - 1` only in the words next to where one of the `E`
/// rows it reads differs from the row before; those words alone are recomputed.
fn footprint_rows(e: &Pool, e_idx: &[u32], cover: &Cover, w: usize, h: usize) -> Space {
    let nw = words_for(w);
    let mw = words_for(nw);
    let eat = |t: i64| if t < 0 || t >= h as i64 { 0 } else { e_idx[t as usize] };
    let changes = row_changes(e, e_idx, mw);
    let last_mask = if w.is_multiple_of(64) { !0 } else { (1u64 << (w % 64)) - 1 };
    let mut space = Space { height: h, row_group: vec![0; ORIENTATIONS * h], groups: vec![(0, 0)], runs: Vec::new(), parent: Vec::new() };
    let mut cur = vec![0u64; nw];
    // per row of F_k, the words to recompute (mw u64 of word bits per row)
    let mut todo = vec![0u64; h * mw];
    let mut todo_rows: Vec<usize> = Vec::new();
    let changed_rows: Vec<i64> = (-1..=h as i64).filter(|t| changes[(t + 1) as usize * mw..(t + 2) as usize * mw].iter().any(|m| *m != 0)).collect();
    // the E rows of the discs, zero-padded, with their shifts
    let mut rows: Vec<(&[u64], i32)> = Vec::new();
    for (k, offsets) in cover.offsets.iter().enumerate() {
        // a word of F reads the words of E up to `reach` away
        let reach = offsets.iter().map(|&(dx, _)| (dx.unsigned_abs() as usize).div_ceil(64)).max().unwrap_or(0);
        // scatter each change of E to the rows of F_k that read it
        todo_rows.clear();
        for &t in &changed_rows {
            for &(_, dy) in offsets {
                let j = t - dy as i64;
                if (0..h as i64).contains(&j) {
                    let j = j as usize;
                    let mask = &changes[(t + 1) as usize * mw..(t + 2) as usize * mw];
                    let dst = &mut todo[j * mw..(j + 1) * mw];
                    if dst.iter().all(|m| *m == 0) {
                        todo_rows.push(j);
                    }
                    for (a, b) in dst.iter_mut().zip(mask) {
                        *a |= b;
                    }
                }
            }
        }
        todo_rows.sort_unstable();
        todo_rows.dedup();
        // row -1 of F_k is zero: some disc sits at or below the centre row, where E is zero
        cur.fill(0);
        let mut group = 0u32;
        let mut next_row = 0;
        for &j in &todo_rows {
            space.row_group[k * h + next_row..k * h + j].fill(group);
            next_row = j + 1;
            let words = &mut todo[j * mw..(j + 1) * mw];
            for _ in 0..reach {
                grow(words);
            }
            rows.clear();
            rows.extend(offsets.iter().map(|&(dx, dy)| (e.padded(eat(j as i64 + dy as i64)), dx)));
            let mut differs = false;
            let words = &mut todo[j * mw..(j + 1) * mw];
            for (m, mask) in words.iter_mut().enumerate() {
                let mut bits = std::mem::take(mask);
                while bits != 0 {
                    let q = m * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    if q >= nw {
                        break;
                    }
                    let mut word = if q + 1 == nw { last_mask } else { !0 };
                    if reach == 1 {
                        for &(row, dx) in &rows {
                            word &= near_shift(row, q, dx);
                            if word == 0 {
                                break;
                            }
                        }
                    } else {
                        for &(row, dx) in &rows {
                            word &= shifted_word(&row[1..=nw], q, dx);
                        }
                    }
                    differs |= word != cur[q];
                    cur[q] = word;
                }
            }
            if !differs {
                space.row_group[k * h + j] = group;
                continue;
            }
            let first = space.runs.len() as u32;
            extract_runs(&cur, &mut space.runs);
            let last = space.runs.len() as u32;
            space.parent.extend(first..last);
            let previous = group;
            group = if first == last {
                0
            } else {
                space.groups.push((first, last));
                (space.groups.len() - 1) as u32
            };
            space.row_group[k * h + j] = group;
            if previous != 0 && group != 0 {
                space.join(previous, group, 1);
            }
        }
        space.row_group[k * h + next_row..(k + 1) * h].fill(group);
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

/// Sets the neighbours of every set bit of the multi-word mask `m`.
fn grow(m: &mut [u64]) {
    let mut below = 0;
    for q in 0..m.len() {
        let x = m[q];
        let above = if q + 1 < m.len() { m[q + 1] & 1 } else { 0 };
        m[q] = x | (x << 1) | (x >> 1) | (below >> 63) | (above << 63);
        below = x;
    }
}

/// Word `q` of a zero-padded row (see [`Pool::padded`]) shifted by `d` cells, `|d| < 64`: as
/// [`shifted_word`], without bounds to test.
#[inline(always)]
fn near_shift(padded: &[u64], q: usize, d: i32) -> u64 {
    let (b, r) = ((q as i64 + 1 + d.div_euclid(64) as i64) as usize, d.rem_euclid(64) as u32);
    (padded[b] >> r) | ((padded[b + 1] << 1) << (63 - r))
}
