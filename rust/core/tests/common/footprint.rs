//! A brute-force reference for `footprint_reachability`: a breadth-first search over single
//! (cell, heading) configurations, 16 headings, written from the rules in the `traverse`
//! module docs, with the clearance from the grid's exact distance transform. Slow (it is the
//! search the generator used to run) and independent of the fast row-wise search.
#![allow(dead_code)]

use std::collections::VecDeque;

use shieldnav_core::world::{Cell, Footprint, OccupancyGrid, Pose2};

/// Headings of the reference search.
pub const HEADINGS: usize = 16;

/// The reference search's result: per configuration, the configuration it was reached from.
pub struct Reference {
    /// Grid size.
    pub width: usize,
    /// Grid size.
    pub height: usize,
    /// `from[(j * width + i) * HEADINGS + k]`: the predecessor, `u32::MAX` if unreached (the
    /// start is its own predecessor).
    pub from: Vec<u32>,
}

impl Reference {
    /// Whether the cell is reached at some heading.
    pub fn reached(&self, i: usize, j: usize) -> bool {
        (0..HEADINGS).any(|k| self.from[(j * self.width + i) * HEADINGS + k] != u32::MAX)
    }

    /// The configurations `(i, j, k)` from the start to the first reached heading of cell
    /// `(i, j)`, or `None`.
    pub fn path_to(&self, i: usize, j: usize) -> Option<Vec<(usize, usize, usize)>> {
        let k = (0..HEADINGS).find(|k| self.from[(j * self.width + i) * HEADINGS + k] != u32::MAX)?;
        let mut id = ((j * self.width + i) * HEADINGS + k) as u32;
        let mut path = Vec::new();
        loop {
            let (c, k) = (id as usize / HEADINGS, id as usize % HEADINGS);
            path.push((c % self.width, c / self.width, k));
            if self.from[id as usize] == id {
                break;
            }
            id = self.from[id as usize];
        }
        path.reverse();
        Some(path)
    }
}

/// Disc-centre offsets (cells) of heading `k` of 16, per the module docs (heading `k + 8` is
/// heading `k` turned by half a turn: the same discs).
pub fn disc_offsets(fp: Footprint, margin: f64, res: f64, k: usize) -> Vec<(i64, i64)> {
    let hw = 0.5 * fp.width + margin;
    let hl = 0.5 * fp.length + margin;
    let n = (2.0 * hl / (0.5 * hw)).ceil().max(1.0) as usize;
    let s = 2.0 * hl / n as f64;
    let a = (k % 8) as f64 * std::f64::consts::TAU / HEADINGS as f64;
    (0..n)
        .map(|m| {
            let x = (m as f64 + 0.5 - 0.5 * n as f64) * s;
            ((a.cos() * x / res).round() as i64, (a.sin() * x / res).round() as i64)
        })
        .collect()
}

/// The clearance a disc's cell needs (m), per the module docs.
pub fn need(fp: Footprint, margin: f64, res: f64) -> f64 {
    let hw = 0.5 * fp.width + margin;
    let hl = 0.5 * fp.length + margin;
    let n = (2.0 * hl / (0.5 * hw)).ceil().max(1.0) as usize;
    let s = 2.0 * hl / n as f64;
    (hw * hw + 0.25 * s * s).sqrt() + std::f64::consts::SQRT_2 * res
}

/// Breadth-first search from `start` over configurations whose every disc cell is at least
/// `need` from every blocked cell (not free, or off the grid).
pub fn reference_search(grid: &OccupancyGrid, fp: Footprint, margin: f64, start: Pose2) -> Option<Reference> {
    let (w, h, res) = (grid.width, grid.height, grid.resolution);
    // off-grid cells are blocked: pad the grid with a blocked border wider than `need`
    let pad = (need(fp, margin, res) / res).ceil() as usize + 2;
    let (pw, ph) = (w + 2 * pad, h + 2 * pad);
    let mut padded = OccupancyGrid::new(pw, ph, res, Pose2::default(), Cell::Occupied).unwrap();
    for j in 0..h {
        for i in 0..w {
            padded.set(i + pad, j + pad, grid.get(i, j));
        }
    }
    let clearance = padded.distance_field(|c| c != Cell::Free);
    let need = need(fp, margin, res);
    let offsets: Vec<Vec<(i64, i64)>> = (0..HEADINGS).map(|k| disc_offsets(fp, margin, res, k)).collect();
    let free = |i: usize, j: usize, k: usize| {
        offsets[k].iter().all(|&(dx, dy)| {
            let (pi, pj) = (i as i64 + pad as i64 + dx, j as i64 + pad as i64 + dy);
            pi >= 0 && pj >= 0 && (pi as usize) < pw && (pj as usize) < ph && clearance[pj as usize * pw + pi as usize] >= need
        })
    };
    let (si, sj) = grid.world_to_cell([start.x, start.y])?;
    let yaw = start.yaw - grid.origin.yaw;
    let k0 = ((yaw / std::f64::consts::TAU * HEADINGS as f64).round() as i64).rem_euclid(HEADINGS as i64) as usize;
    let ks = std::iter::once(k0).chain((0..HEADINGS).filter(|&k| k != k0)).find(|&k| free(si, sj, k))?;
    let mut from = vec![u32::MAX; w * h * HEADINGS];
    let id = |i: usize, j: usize, k: usize| ((j * w + i) * HEADINGS + k) as u32;
    from[id(si, sj, ks) as usize] = id(si, sj, ks);
    let mut queue = VecDeque::from([(si, sj, ks)]);
    while let Some((i, j, k)) = queue.pop_front() {
        let here = id(i, j, k);
        let mut next = vec![(i, j, (k + 1) % HEADINGS), (i, j, (k + HEADINGS - 1) % HEADINGS)];
        for (di, dj) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
            let (ni, nj) = (i as i64 + di, j as i64 + dj);
            if ni >= 0 && nj >= 0 && (ni as usize) < w && (nj as usize) < h {
                next.push((ni as usize, nj as usize, k));
            }
        }
        for (ni, nj, nk) in next {
            let n = id(ni, nj, nk) as usize;
            if from[n] == u32::MAX && free(ni, nj, nk) {
                from[n] = here;
                queue.push_back((ni, nj, nk));
            }
        }
    }
    Some(Reference { width: w, height: h, from })
}
