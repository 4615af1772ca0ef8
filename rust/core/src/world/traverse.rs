//! Can the robot's rectangular footprint get from a start pose to a place? A search over
//! (cell, heading) configurations of an occupancy grid.
//!
//! A configuration is free when the footprint, inflated by `margin` (half-extents
//! `hl = length / 2 + margin`, `hw = width / 2 + margin`), misses every blocked cell: every
//! cell that is not [`Cell::Free`], and everything outside the grid. The inflated rectangle is
//! covered by `n = ⌈2·hl / (hw/2)⌉` discs of radius `r = √(hw² + s²/4)` centred on its long
//! axis at `(m + ½ − n/2)·s`, `s = 2·hl / n`, `m = 0 … n−1`. Each disc centre, offset from the
//! footprint's centre cell in cells, is rounded to the nearest cell (half away from zero, so
//! the offsets of heading `θ + π` are those of `θ` negated, the same discs); that cell's
//! centre must be at least `need = r + √2·res` from the centre of every blocked cell. Rounding
//! moves a disc centre by at most `res/√2` and a blocked cell reaches `res/√2` beyond its
//! centre, so the disc, and with it the inflated footprint, misses every blocked cell: the test
//! is conservative, a configuration called free is free.
//!
//! There are 16 headings, 22.5° apart; a rectangle turned by half a turn covers the same
//! cells, so the search runs on the 8 orientations modulo 180°. Moves are to the 8
//! neighbouring cells at the same heading and to the neighbouring heading in place. For the
//! default 1.1 × 0.5 m footprint, 5 cm margin and 5 cm cells, every move sweeps the bare
//! robot grown by the margin only through the discs its two end configurations certify free
//! (checked by the unit test `every_move_stays_inside_the_certified_discs`), so a path of
//! free configurations is a collision-free motion with the margin kept throughout.
//!
//! The search itself is exact for these rules (it reaches what a breadth-first search over
//! single configurations reaches) but runs on whole rows (see `cspace.rs`): 0.2–0.3 ms on a
//! 1280 × 880 site grid where the search over single configurations took 60–200 ms.

#[cfg(doc)]
use super::cell::Cell;
use super::cspace::{self, Cover, Space, ORIENTATIONS};
use super::geometry::{Point2, Pose2};
use super::grid::OccupancyGrid;
use crate::error::{Error, Result};
use crate::math::Real;

/// Number of heading bins of the search.
pub const HEADINGS: usize = 16;

/// A rectangular robot footprint (m), length along the body's x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// Along the heading (m).
    pub length: Real,
    /// Across (m).
    pub width: Real,
}

impl Default for Footprint {
    /// The Spot-like 1.1 × 0.5 m body.
    fn default() -> Self {
        Self { length: 1.1, width: 0.5 }
    }
}

impl Cover {
    /// The disc cover of `footprint` inflated by `margin` on cells of `res` (see the module
    /// docs): disc-centre offsets per orientation, and the clearance test as erosion widths.
    pub(crate) fn new(footprint: Footprint, margin: Real, res: Real) -> Self {
        let hw = 0.5 * footprint.width + margin;
        let hl = 0.5 * footprint.length + margin;
        let spacing = 0.5 * hw;
        let n = (2.0 * hl / spacing).ceil().max(1.0) as usize;
        let spacing = 2.0 * hl / n as Real;
        let radius = (hw * hw + 0.25 * spacing * spacing).sqrt();
        let need = radius + std::f64::consts::SQRT_2 * res;
        let offsets = (0..ORIENTATIONS)
            .map(|k| {
                let (s, c) = (k as Real * std::f64::consts::PI / ORIENTATIONS as Real).sin_cos();
                // the ends first: they fail most often, and the footprint test stops at a failure
                (0..n)
                    .map(|m| if m % 2 == 0 { m / 2 } else { n - 1 - m / 2 })
                    .map(|m| {
                        let x = (m as Real + 0.5 - 0.5 * n as Real) * spacing;
                        ((c * x / res).round() as i32, (s * x / res).round() as i32)
                    })
                    .collect()
            })
            .collect();
        // E(i, j): every blocked cell (i', j') has (i - i')² + (j - j')² >= t (cells²)
        let t = ((need / res).powi(2) * (1.0 + 1e-12)).ceil() as i64;
        let reach = (0..).take_while(|d: &i64| d * d < t).last().unwrap_or(0);
        let widths = (0..=reach).map(|dy| (0..).find(|d: &i64| d * d + dy * dy >= t).unwrap() as usize - 1).collect();
        Self { offsets, widths, need }
    }
}

/// Which grid cells the footprint's centre can reach (at some heading) from the start.
#[derive(Debug, Clone)]
pub struct Reachability {
    grid_origin: Pose2,
    resolution: Real,
    width: usize,
    height: usize,
    space: Space,
    /// The component (root run) of each run of free configurations.
    component: Vec<u32>,
    /// The start's component.
    start: u32,
}

impl Reachability {
    /// Whether the footprint's centre can reach the cell containing world point `p`.
    pub fn reaches(&self, p: Point2) -> bool {
        let q = self.grid_origin.inverse_transform_point(p);
        let (fi, fj) = ((q[0] / self.resolution).floor(), (q[1] / self.resolution).floor());
        if fi < 0.0 || fj < 0.0 || fi >= self.width as Real || fj >= self.height as Real {
            return false;
        }
        (0..ORIENTATIONS).any(|k| self.space.run_at(k, fj as usize, fi as i32).is_some_and(|r| self.component[r] == self.start))
    }

    /// The components of the free configurations whose centre is in the cell of `p` (reached
    /// or not), appended to `out`.
    pub(crate) fn components_at(&self, p: Point2, out: &mut Vec<u32>) {
        let q = self.grid_origin.inverse_transform_point(p);
        let (fi, fj) = ((q[0] / self.resolution).floor(), (q[1] / self.resolution).floor());
        if fi < 0.0 || fj < 0.0 || fi >= self.width as Real || fj >= self.height as Real {
            return;
        }
        out.extend((0..ORIENTATIONS).filter_map(|k| self.space.run_at(k, fj as usize, fi as i32)).map(|r| self.component[r]));
    }

    /// Whether a free configuration of one of the `components` has its centre in the grid box
    /// `[i0, i1] × [j0, j1]` (cells).
    pub(crate) fn components_in_box(&self, components: &[u32], (i0, j0, i1, j1): (i32, i32, i32, i32)) -> bool {
        (j0.max(0)..=j1.min(self.height as i32 - 1)).any(|j| {
            (0..ORIENTATIONS).any(|k| {
                let (a, _) = self.space.groups[self.space.row_group[k * self.height + j as usize] as usize];
                let runs = self.space.row_runs(k, j as usize).iter().enumerate();
                runs.filter(|(_, run)| run.0 <= i1 && run.1 >= i0).any(|(r, _)| components.contains(&self.component[a as usize + r]))
            })
        })
    }

    /// Number of reached cells.
    pub fn count(&self) -> usize {
        let mut row = Vec::new();
        (0..self.height)
            .map(|j| {
                self.reached_row(j, &mut row);
                row.iter().map(|(a, b)| (b - a + 1) as usize).sum::<usize>()
            })
            .sum()
    }

    /// The reached cells of row `j` as disjoint runs `(first, last)` in increasing order.
    pub(crate) fn reached_row(&self, j: usize, out: &mut Vec<(i32, i32)>) {
        out.clear();
        if j >= self.height {
            return;
        }
        for k in 0..ORIENTATIONS {
            let (a, _) = self.space.groups[self.space.row_group[k * self.height + j] as usize];
            let runs = self.space.row_runs(k, j).iter().enumerate();
            out.extend(runs.filter(|(r, _)| self.component[a as usize + r] == self.start).map(|(_, run)| *run));
        }
        out.sort_unstable();
        let mut merged = 0;
        for r in 0..out.len() {
            let (a, b) = out[r];
            if merged > 0 && a <= out[merged - 1].1 + 1 {
                out[merged - 1].1 = out[merged - 1].1.max(b);
            } else {
                out[merged] = (a, b);
                merged += 1;
            }
        }
        out.truncate(merged);
    }
}

/// Searches the configurations reachable from `start` (world pose) in `grid` (unknown cells
/// and everything outside the grid count as obstacles). Errors if the footprint does not fit
/// at the start cell at any heading.
pub fn footprint_reachability(grid: &OccupancyGrid, footprint: Footprint, margin: Real, start: Pose2) -> Result<Reachability> {
    if !(footprint.length.is_finite() && footprint.width.is_finite() && footprint.width > 0.0 && footprint.length >= footprint.width) {
        return Err(Error::invalid("footprint", format!("needs finite length >= width > 0, got {footprint:?}")));
    }
    if !(margin.is_finite() && margin >= 0.0) {
        return Err(Error::invalid("margin", format!("must be finite and >= 0, got {margin}")));
    }
    let cover = Cover::new(footprint, margin, grid.resolution);
    let mut space = cspace::build(grid, &cover);
    let (si, sj) = grid.world_to_cell([start.x, start.y]).ok_or_else(|| Error::invalid("start", format!("{start:?} is outside the grid")))?;
    let yaw = start.yaw - grid.origin.yaw;
    let k0 = ((yaw / std::f64::consts::TAU * HEADINGS as Real).round() as i64).rem_euclid(HEADINGS as i64) as usize % ORIENTATIONS;
    let first = std::iter::once(k0).chain((0..ORIENTATIONS).filter(|&k| k != k0)).find_map(|k| space.run_at(k, sj, si as i32));
    let Some(first) = first else {
        return Err(Error::invalid("start", format!("the footprint with margin {margin} m does not fit at {start:?}")));
    };
    let start = space.find(first) as u32;
    let component = (0..space.runs.len()).map(|r| space.find(r) as u32).collect();
    Ok(Reachability { grid_origin: grid.origin, resolution: grid.resolution, width: grid.width, height: grid.height, space, component, start })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::grid::Cell;

    /// A 10 m corridor of `width` along x with a wall across it leaving a gap of `gap`.
    fn corridor(width: Real, gap: Real) -> OccupancyGrid {
        let mut g = OccupancyGrid::new(240, 100, 0.05, Pose2::default(), Cell::Occupied).unwrap();
        g.fill_rect(1.0, 2.5 - 0.5 * width, 11.0, 2.5 + 0.5 * width, Cell::Free);
        g.fill_rect(5.9, 0.0, 6.1, 5.0, Cell::Occupied);
        g.fill_rect(5.9, 2.5 - 0.5 * gap, 6.1, 2.5 + 0.5 * gap, Cell::Free);
        g
    }

    #[test]
    fn robot_passes_a_gap_a_bit_wider_than_it_is() {
        let g = corridor(2.0, 0.8);
        let r = footprint_reachability(&g, Footprint::default(), 0.05, Pose2::new(2.0, 2.5, 0.0)).unwrap();
        assert!(r.reaches([10.0, 2.5]));
    }

    #[test]
    fn robot_does_not_pass_a_gap_narrower_than_it_is() {
        let g = corridor(2.0, 0.45);
        let r = footprint_reachability(&g, Footprint::default(), 0.0, Pose2::new(2.0, 2.5, 0.0)).unwrap();
        assert!(!r.reaches([10.0, 2.5]));
        assert!(r.reaches([5.0, 2.5]));
    }

    #[test]
    fn robot_cannot_turn_in_a_dead_end_narrower_than_its_length() {
        // a 0.8 m wide, 3 m long dead end from a big room: the robot can enter forwards only
        let mut g = OccupancyGrid::new(200, 100, 0.05, Pose2::default(), Cell::Occupied).unwrap();
        g.fill_rect(0.5, 0.5, 5.0, 4.5, Cell::Free);
        g.fill_rect(5.0, 2.1, 8.0, 2.9, Cell::Free);
        let r = footprint_reachability(&g, Footprint::default(), 0.05, Pose2::new(2.0, 2.5, 0.0)).unwrap();
        assert!(r.reaches([6.9, 2.5])); // the disc cover is conservative at the ends by ~0.3 m
                                        // but it cannot turn around in it: heading +x at the entrance is reached, heading
                                        // -y (sideways) deep inside is not, so a cell needing sideways fit is not reached
        let mut g2 = OccupancyGrid::new(200, 100, 0.05, Pose2::default(), Cell::Occupied).unwrap();
        g2.fill_rect(0.5, 0.5, 5.0, 4.5, Cell::Free);
        g2.fill_rect(5.0, 2.1, 8.0, 2.9, Cell::Free);
        g2.fill_rect(7.2, 2.9, 8.0, 3.25, Cell::Free); // a 0.35 m notch: too shallow to stand in
        let r2 = footprint_reachability(&g2, Footprint::default(), 0.05, Pose2::new(2.0, 2.5, 0.0)).unwrap();
        assert!(!r2.reaches([7.6, 3.1]));
    }

    #[test]
    fn every_move_stays_inside_the_certified_discs() {
        // a snapped disc cell at least `need` from every blocked cell centre leaves the disc of
        // radius need - res/√2 around its centre free of blocked cells
        let (fp, margin, res) = (Footprint::default(), 0.05, 0.05);
        let cover = Cover::new(fp, margin, res);
        let free_radius = cover.need - res * std::f64::consts::FRAC_1_SQRT_2;
        let discs = |k: usize, at: [Real; 2]| -> Vec<[Real; 2]> { cover.offsets[k % ORIENTATIONS].iter().map(|&(dx, dy)| [at[0] + dx as Real * res, at[1] + dy as Real * res]).collect() };
        let covered = |p: [Real; 2], d: &[[Real; 2]]| d.iter().any(|c| (p[0] - c[0]).hypot(p[1] - c[1]) <= free_radius);
        // the bare robot grown by the margin, sampled on its boundary and inside
        let (hl, hw) = (0.5 * fp.length + margin, 0.5 * fp.width + margin);
        let body: Vec<[Real; 2]> = (0..=24).flat_map(|a| (0..=10).map(move |b| [-hl + 2.0 * hl * a as Real / 24.0, -hw + 2.0 * hw * b as Real / 10.0])).collect();
        let step = std::f64::consts::PI / ORIENTATIONS as Real;
        for k in 0..ORIENTATIONS {
            let here = discs(k, [0.0, 0.0]);
            let mut moves: Vec<([Real; 2], usize)> = vec![([0.0, 0.0], k + 1)];
            for (di, dj) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                moves.push(([di as Real * res, dj as Real * res], k));
            }
            for (to, k2) in moves {
                let both = [here.clone(), discs(k2, to)].concat();
                for t in 0..=32 {
                    let f = t as Real / 32.0;
                    let (s, c) = ((k as Real + f * (k2 - k) as Real) * step).sin_cos();
                    for p in &body {
                        let q = [f * to[0] + c * p[0] - s * p[1], f * to[1] + s * p[0] + c * p[1]];
                        assert!(covered(q, &both), "orientation {k} to {k2} by {to:?}, t = {f}: {q:?} uncovered");
                    }
                }
            }
        }
    }

    #[test]
    fn start_inside_a_wall_is_an_error() {
        let g = corridor(2.0, 0.8);
        assert!(footprint_reachability(&g, Footprint::default(), 0.05, Pose2::new(0.2, 0.2, 0.0)).is_err());
    }
}
