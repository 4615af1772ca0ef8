//! Inspection coverage: the static walls cut into short pieces, each inspected once the camera
//! has seen it.
//!
//! A piece counts as inspected when, at a LIDAR scan, its midpoint lies inside the camera's
//! horizontal field of view `α` about the sensor's heading, no farther than `d_view + margin`,
//! and in line of sight: the scan's range along that bearing reaches the piece (to within
//! [`LINE_OF_SIGHT_TOLERANCE`]). Walls are vertical and the camera looks horizontally, so the
//! piece at camera height is always inside the vertical field of view `β`; `β` shapes the
//! planner's path (its `d_vov`), not this test.
//!
//! Only pieces that can be seen from where the robot can be count: a flood fill of a
//! [`COVERAGE_GRID`] raster of the walls from the start marks the free space connected to it,
//! and a piece is inspectable when a probe [`PROBE_OFFSET`] off either face lands there. Faces
//! buried in furniture, the outside of the building and rooms walled off are left out.

use crate::error::{Error, Result};
use crate::math::Real;
use crate::sensors::Scan;
use crate::world::region::FreeRegion;
use crate::world::{Cell, OccupancyGrid, Point2, Pose2, Segment};

/// Cell of the reachability raster (m).
pub const COVERAGE_GRID: Real = 0.05;
/// How far off a face its reachability probe sits (m): past the wall's own raster cells.
pub const PROBE_OFFSET: Real = 0.1;
/// Slack (m) of the line-of-sight test against the scan's range (range noise, the piece's
/// own extent).
pub const LINE_OF_SIGHT_TOLERANCE: Real = 0.1;
/// Edge of the buckets that hold the pieces (m).
const BUCKET: Real = 1.0;

/// Coverage parameters. `Default`: 0.25 m pieces, 0.5 m of margin beyond `d_view`, an episode
/// ends at 95 % coverage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoverageConfig {
    /// Longest piece (m); each wall is cut into equal pieces no longer than this.
    pub piece_length: Real,
    /// Range slack beyond the planner's `d_view` (m).
    pub margin: Real,
    /// Fraction of the inspectable length at which the episode is complete, in `(0, 1]`.
    pub goal: Real,
}

impl Default for CoverageConfig {
    fn default() -> Self {
        Self { piece_length: 0.25, margin: 0.5, goal: 0.95 }
    }
}

impl CoverageConfig {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<()> {
        if !(self.piece_length.is_finite() && self.piece_length >= 0.05) {
            return Err(Error::invalid("piece_length", format!("must be finite and >= 0.05 m, got {}", self.piece_length)));
        }
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return Err(Error::invalid("coverage_margin", format!("must be finite and >= 0, got {}", self.margin)));
        }
        if !(self.goal > 0.0 && self.goal <= 1.0) {
            return Err(Error::invalid("coverage_goal", format!("must be in (0, 1], got {}", self.goal)));
        }
        Ok(())
    }
}

/// One inspectable piece of wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// First end (m, world).
    pub a: Point2,
    /// Second end (m, world).
    pub b: Point2,
    /// Midpoint (m, world).
    pub mid: Point2,
    /// Length (m).
    pub length: Real,
}

/// The pieces of an episode and which of them have been inspected.
#[derive(Debug, Clone)]
pub struct Coverage {
    pieces: Vec<Piece>,
    inspected: Vec<bool>,
    total: Real,
    covered: Real,
    count: usize,
    origin: Point2,
    nx: usize,
    ny: usize,
    starts: Vec<u32>,
    ids: Vec<u32>,
}

/// The pieces of `walls`, `piece_length` at most.
fn cut(walls: &[Segment], piece_length: Real) -> Vec<Piece> {
    let mut out = Vec::new();
    for w in walls {
        let len = w.length();
        let n = (len / piece_length).ceil().max(1.0) as usize;
        for k in 0..n {
            let (t0, t1) = (k as Real / n as Real, (k + 1) as Real / n as Real);
            let at = |t: Real| [w.a[0] + t * (w.b[0] - w.a[0]), w.a[1] + t * (w.b[1] - w.a[1])];
            let (a, b) = (at(t0), at(t1));
            out.push(Piece { a, b, mid: at(0.5 * (t0 + t1)), length: len / n as Real });
        }
    }
    out
}

/// The free space connected to `start` (4-connected) in a raster of `walls`, and the raster.
fn reachable(walls: &[Segment], start: Point2) -> Result<(OccupancyGrid, FreeRegion)> {
    let (mut lo, mut hi) = (start, start);
    for w in walls {
        for p in [w.a, w.b] {
            lo = [lo[0].min(p[0]), lo[1].min(p[1])];
            hi = [hi[0].max(p[0]), hi[1].max(p[1])];
        }
    }
    let pad = 4.0 * COVERAGE_GRID;
    let origin = Pose2::new(lo[0] - pad, lo[1] - pad, 0.0);
    let w = ((hi[0] - lo[0] + 2.0 * pad) / COVERAGE_GRID).ceil() as usize + 1;
    let h = ((hi[1] - lo[1] + 2.0 * pad) / COVERAGE_GRID).ceil() as usize + 1;
    if w.saturating_mul(h) > 200_000_000 {
        return Err(Error::invalid("walls", format!("the site spans {w} x {h} coverage cells of {COVERAGE_GRID} m; too large")));
    }
    let mut grid = OccupancyGrid::new(w, h, COVERAGE_GRID, origin, Cell::Free)?;
    grid.rasterize_segments(walls);
    let Some((i0, j0)) = grid.world_to_cell(start) else {
        return Err(Error::invalid("start", "outside the site"));
    };
    if grid.get(i0, j0) != Cell::Free {
        return Err(Error::invalid("start", format!("lies on a wall at ({:.3}, {:.3})", start[0], start[1])));
    }
    let region = FreeRegion::new(&grid, (i0, j0));
    Ok((grid, region))
}

impl Coverage {
    /// Cuts `walls` into pieces and keeps those facing the free space reachable from `start`.
    pub fn new(walls: &[Segment], start: Point2, config: &CoverageConfig) -> Result<Self> {
        config.validate()?;
        let (grid, region) = reachable(walls, start)?;
        let open = |p: Point2| grid.world_to_cell(p).is_some_and(|(i, j)| region.contains(i, j));
        let pieces: Vec<Piece> = cut(walls, config.piece_length)
            .into_iter()
            .filter(|p| {
                let d = [p.b[0] - p.a[0], p.b[1] - p.a[1]];
                let n = [-d[1] / p.length.max(1e-12), d[0] / p.length.max(1e-12)];
                let probe = |s: Real| [p.mid[0] + s * PROBE_OFFSET * n[0], p.mid[1] + s * PROBE_OFFSET * n[1]];
                open(probe(1.0)) || open(probe(-1.0))
            })
            .collect();
        let (mut lo, mut hi) = (start, start);
        for p in &pieces {
            lo = [lo[0].min(p.mid[0]), lo[1].min(p.mid[1])];
            hi = [hi[0].max(p.mid[0]), hi[1].max(p.mid[1])];
        }
        let nx = ((hi[0] - lo[0]) / BUCKET) as usize + 1;
        let ny = ((hi[1] - lo[1]) / BUCKET) as usize + 1;
        let bucket = |m: Point2| (((m[1] - lo[1]) / BUCKET) as usize) * nx + ((m[0] - lo[0]) / BUCKET) as usize;
        let mut starts = vec![0u32; nx * ny + 1];
        for p in &pieces {
            starts[bucket(p.mid) + 1] += 1;
        }
        for k in 0..nx * ny {
            starts[k + 1] += starts[k];
        }
        let mut fill = starts.clone();
        let mut ids = vec![0u32; pieces.len()];
        for (k, p) in pieces.iter().enumerate() {
            let b = bucket(p.mid);
            ids[fill[b] as usize] = k as u32;
            fill[b] += 1;
        }
        let total = pieces.iter().map(|p| p.length).sum();
        Ok(Self { inspected: vec![false; pieces.len()], pieces, total, covered: 0.0, count: 0, origin: lo, nx, ny, starts, ids })
    }

    /// Marks the pieces the camera sees at `scan` (its sensor pose, its ranges) within
    /// `range` (m) and the horizontal field of view `fov_h` (rad); returns the newly inspected
    /// length (m). `cos_el` holds the cosine of each channel's elevation.
    pub fn update(&mut self, scan: &Scan, cos_el: &[Real], fov_h: Real, range: Real) -> Real {
        let sp = scan.sensor_pose;
        let cols = scan.columns;
        if cols == 0 || self.pieces.is_empty() {
            return 0.0;
        }
        // the channel nearest the horizon is the camera's line of sight
        let (k, cos_el) = cos_el.iter().copied().enumerate().fold((0, -1.0), |a, b| if b.1 > a.1 { b } else { a });
        let ranges = &scan.ranges[k * cols..(k + 1) * cols];
        let step = std::f64::consts::TAU / cols as Real;
        let half = 0.5 * fov_h;
        let f = |v: Real, o: Real, n: usize| (((v - o) / BUCKET).floor().max(0.0) as usize).min(n - 1);
        let (i0, i1) = (f(sp.x - range, self.origin[0], self.nx), f(sp.x + range, self.origin[0], self.nx));
        let (j0, j1) = (f(sp.y - range, self.origin[1], self.ny), f(sp.y + range, self.origin[1], self.ny));
        let (ys, yc) = sp.yaw.sin_cos();
        let far2 = range * range * (1.0 + 1e-9);
        let front_only = half < std::f64::consts::FRAC_PI_2;
        let mut new = 0.0;
        for j in j0..=j1 {
            for i in i0..=i1 {
                let b = j * self.nx + i;
                for &id in &self.ids[self.starts[b] as usize..self.starts[b + 1] as usize] {
                    let id = id as usize;
                    if self.inspected[id] {
                        continue;
                    }
                    // = sp.inverse_transform_point(mid), with the sine and cosine taken once
                    let m = self.pieces[id].mid;
                    let (dx, dy) = (m[0] - sp.x, m[1] - sp.y);
                    let q = [yc * dx + ys * dy, -ys * dx + yc * dy];
                    // cheap rejections first: well out of range, or behind a camera narrower
                    // than a half turn; then the exact tests
                    let d2 = q[0] * q[0] + q[1] * q[1];
                    if d2 > far2 || (front_only && q[0] < 0.0) {
                        continue;
                    }
                    let d = q[0].hypot(q[1]);
                    if d > range {
                        continue;
                    }
                    let bearing = q[1].atan2(q[0]);
                    if bearing.abs() > half {
                        continue;
                    }
                    let col = ((bearing / step).round() as isize).rem_euclid(cols as isize) as usize;
                    if ranges[col] * cos_el >= d - LINE_OF_SIGHT_TOLERANCE {
                        self.inspected[id] = true;
                        self.covered += self.pieces[id].length;
                        self.count += 1;
                        new += self.pieces[id].length;
                    }
                }
            }
        }
        new
    }

    /// Forgets every inspection (a new episode on the same site).
    pub fn clear(&mut self) {
        self.inspected.iter_mut().for_each(|v| *v = false);
        self.covered = 0.0;
        self.count = 0;
    }

    /// The inspectable pieces.
    pub fn pieces(&self) -> &[Piece] {
        &self.pieces
    }

    /// Which pieces have been inspected, in the order of [`Coverage::pieces`].
    pub fn inspected(&self) -> &[bool] {
        &self.inspected
    }

    /// Inspected length over inspectable length, in `[0, 1]` (1 for a site with nothing to see).
    pub fn fraction(&self) -> Real {
        if self.total > 0.0 {
            self.covered / self.total
        } else {
            1.0
        }
    }

    /// Inspected length (m).
    pub fn covered_length(&self) -> Real {
        self.covered
    }

    /// Inspectable length (m).
    pub fn total_length(&self) -> Real {
        self.total
    }

    /// Number of inspected pieces (changes exactly when coverage grows).
    pub fn inspected_count(&self) -> usize {
        self.count
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Polygon;

    fn room() -> Vec<Segment> {
        let c = [[0.0, 0.0], [6.0, 0.0], [6.0, 4.0], [0.0, 4.0]];
        (0..4).map(|k| Segment::new(c[k], c[(k + 1) % 4], 2.0)).collect()
    }

    #[test]
    fn buried_faces_and_the_outside_are_not_inspectable() {
        let mut walls = room();
        // a box flush against the right wall: its right face is buried, three faces are open
        walls.extend(Polygon::rect(5.0, 1.0, 6.0, 2.0, 1.0).edges());
        let cov = Coverage::new(&walls, [1.0, 1.0], &CoverageConfig::default()).unwrap();
        // room perimeter 20 m, less the 1 m of right wall behind the box, plus 3 m of box faces
        assert!((cov.total_length() - 22.0).abs() < 1e-9, "{}", cov.total_length());
        assert!(cov.pieces().iter().all(|p| !(p.mid[0] == 6.0 && p.mid[1] > 1.0 && p.mid[1] < 2.0)));
    }

    #[test]
    fn pieces_in_view_and_line_of_sight_are_inspected() {
        let walls = room();
        let mut cov = Coverage::new(&walls, [1.0, 2.0], &CoverageConfig::default()).unwrap();
        // a sensor at (3, 2) facing +x, seeing the right wall 3 m away; fake exact ranges
        let cols = 1024;
        let sp = Pose2::new(3.0, 2.0, 0.0);
        let step = std::f64::consts::TAU / cols as Real;
        let ranges: Vec<Real> = (0..cols)
            .map(|i| {
                let a = i as Real * step;
                let (s, c) = a.sin_cos();
                let tx = if c > 1e-12 {
                    3.0 / c
                } else if c < -1e-12 {
                    -3.0 / c
                } else {
                    Real::INFINITY
                };
                let ty = if s > 1e-12 {
                    2.0 / s
                } else if s < -1e-12 {
                    -2.0 / s
                } else {
                    Real::INFINITY
                };
                tx.min(ty)
            })
            .collect();
        let scan = Scan { channels: 1, columns: cols, ranges, points: Vec::new(), stamp: 0.0, sensor_pose: sp };
        let fov = 69.4_f64.to_radians();
        assert_eq!(cov.update(&scan, &[1.0], fov, 2.0), 0.0, "the wall is 3 m away, beyond range 2 m");
        let new = cov.update(&scan, &[1.0], fov, 4.0);
        // at 3 m, ±34.7° spans ±2.08 m of the right wall, which is only ±2 m tall: the whole wall
        assert!((new - 4.0).abs() < 1e-9, "{new}");
        assert!((cov.fraction() - 0.2).abs() < 1e-9);
        assert_eq!(cov.update(&scan, &[1.0], fov, 4.0), 0.0, "inspected once");
        // a blocked line of sight: ranges cut short at 1 m inspect nothing new on the top wall
        let mut blocked = scan.clone();
        blocked.sensor_pose = Pose2::new(3.0, 2.0, std::f64::consts::FRAC_PI_2);
        blocked.ranges.iter_mut().for_each(|r| *r = 1.0);
        assert_eq!(cov.update(&blocked, &[1.0], fov, 4.0), 0.0);
    }
}
