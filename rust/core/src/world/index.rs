//! A uniform bucket grid over wall segments, to fetch the walls near a point on big maps.

use super::geometry::{Point2, Segment};
use crate::error::{Error, Result};
use crate::math::Real;

/// Walls bucketed by a square grid of `cell` metres (each wall in every bucket its bounding
/// box touches). [`SegmentIndex::query_into`] returns each wall near a disc once.
///
/// ```
/// use shieldnav_core::world::{Segment, SegmentIndex};
/// let walls = vec![Segment::new([0.0, 0.0], [10.0, 0.0], 2.0), Segment::new([50.0, 50.0], [51.0, 50.0], 2.0)];
/// let mut index = SegmentIndex::new(walls, 2.0).unwrap();
/// let mut near = Vec::new();
/// index.query_into([5.0, 1.0], 3.0, &mut near);
/// assert_eq!(near.len(), 1);
/// ```
#[derive(Debug, Clone)]
pub struct SegmentIndex {
    segments: Vec<Segment>,
    cell: Real,
    origin: Point2,
    nx: usize,
    ny: usize,
    starts: Vec<u32>,
    ids: Vec<u32>,
    /// The walls of `ids`, copied in bucket order so a bucket's walls are contiguous in memory.
    walls: Vec<Segment>,
    stamp: Vec<u32>,
    epoch: u32,
}

impl SegmentIndex {
    /// Buckets `segments` into square cells of `cell` metres.
    pub fn new(segments: Vec<Segment>, cell: Real) -> Result<Self> {
        if !(cell.is_finite() && cell > 0.0) {
            return Err(Error::invalid("cell", format!("must be finite and > 0, got {cell}")));
        }
        let (mut lo, mut hi) = ([Real::INFINITY; 2], [Real::NEG_INFINITY; 2]);
        for s in &segments {
            for p in [s.a, s.b] {
                if !(p[0].is_finite() && p[1].is_finite()) {
                    return Err(Error::invalid("segments", format!("non-finite end point {p:?}")));
                }
                lo = [lo[0].min(p[0]), lo[1].min(p[1])];
                hi = [hi[0].max(p[0]), hi[1].max(p[1])];
            }
        }
        if segments.is_empty() {
            lo = [0.0, 0.0];
            hi = [0.0, 0.0];
        }
        let nx = ((hi[0] - lo[0]) / cell).floor() as usize + 1;
        let ny = ((hi[1] - lo[1]) / cell).floor() as usize + 1;
        if nx.saturating_mul(ny) > 50_000_000 {
            return Err(Error::invalid("cell", format!("{cell} m gives {nx} x {ny} buckets; use a larger cell")));
        }
        let range = |s: &Segment| {
            let i0 = ((s.a[0].min(s.b[0]) - lo[0]) / cell).floor() as usize;
            let i1 = ((s.a[0].max(s.b[0]) - lo[0]) / cell).floor() as usize;
            let j0 = ((s.a[1].min(s.b[1]) - lo[1]) / cell).floor() as usize;
            let j1 = ((s.a[1].max(s.b[1]) - lo[1]) / cell).floor() as usize;
            (i0, i1.min(nx - 1), j0, j1.min(ny - 1))
        };
        let mut counts = vec![0u32; nx * ny + 1];
        for s in &segments {
            let (i0, i1, j0, j1) = range(s);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    counts[j * nx + i + 1] += 1;
                }
            }
        }
        for k in 1..counts.len() {
            counts[k] += counts[k - 1];
        }
        let mut fill = counts.clone();
        let mut ids = vec![0u32; counts[nx * ny] as usize];
        for (id, s) in segments.iter().enumerate() {
            let (i0, i1, j0, j1) = range(s);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let b = j * nx + i;
                    ids[fill[b] as usize] = id as u32;
                    fill[b] += 1;
                }
            }
        }
        let n = segments.len();
        let walls = ids.iter().map(|&id| segments[id as usize]).collect();
        Ok(Self { segments, cell, origin: lo, nx, ny, starts: counts, ids, walls, stamp: vec![0; n], epoch: 0 })
    }

    /// All walls.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Bucket edge (m).
    pub fn cell(&self) -> Real {
        self.cell
    }

    /// World position of bucket `(0, 0)`'s lower-left corner.
    pub fn origin(&self) -> Point2 {
        self.origin
    }

    /// Buckets along x and y.
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Indices (into [`SegmentIndex::segments`]) of the walls in bucket `(i, j)`.
    #[inline]
    pub fn bucket(&self, i: usize, j: usize) -> &[u32] {
        let b = j * self.nx + i;
        &self.ids[self.starts[b] as usize..self.starts[b + 1] as usize]
    }

    /// The walls of bucket `(i, j)`, contiguous, in the order of [`SegmentIndex::bucket`].
    #[inline]
    pub fn bucket_walls(&self, i: usize, j: usize) -> &[Segment] {
        let b = j * self.nx + i;
        &self.walls[self.starts[b] as usize..self.starts[b + 1] as usize]
    }

    /// Replaces `out` with every wall in a bucket touched by the square around the disc of
    /// `radius` about `center` (a superset of the walls within `radius`), each once.
    pub fn query_into(&mut self, center: Point2, radius: Real, out: &mut Vec<Segment>) {
        out.clear();
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            self.stamp.iter_mut().for_each(|s| *s = 0);
            self.epoch = 1;
        }
        let f = |v: Real, o: Real, n: usize| (((v - o) / self.cell).floor().max(0.0) as usize).min(n - 1);
        let (i0, i1) = (f(center[0] - radius, self.origin[0], self.nx), f(center[0] + radius, self.origin[0], self.nx));
        let (j0, j1) = (f(center[1] - radius, self.origin[1], self.ny), f(center[1] + radius, self.origin[1], self.ny));
        if center[0] + radius < self.origin[0] || center[1] + radius < self.origin[1] {
            return;
        }
        for j in j0..=j1 {
            for i in i0..=i1 {
                let b = j * self.nx + i;
                for &id in &self.ids[self.starts[b] as usize..self.starts[b + 1] as usize] {
                    let st = &mut self.stamp[id as usize];
                    if *st != self.epoch {
                        *st = self.epoch;
                        out.push(self.segments[id as usize]);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_returns_every_near_wall_once_and_no_far_bucket() {
        let mut walls = Vec::new();
        for k in 0..100 {
            let x = k as Real * 0.7;
            walls.push(Segment::new([x, -1.0], [x + 0.5, 1.0], 2.0));
        }
        walls.push(Segment::new([-5.0, 3.0], [80.0, 3.0], 2.0)); // long, many buckets
        let mut idx = SegmentIndex::new(walls.clone(), 1.5).unwrap();
        let mut near = Vec::new();
        for c in [[10.0, 0.0], [0.0, 0.0], [69.0, 2.0], [-20.0, -20.0]] {
            idx.query_into(c, 4.0, &mut near);
            let within: Vec<&Segment> = walls.iter().filter(|s| s.distance_to_point(c) <= 4.0).collect();
            for w in &within {
                assert_eq!(near.iter().filter(|s| s == w).count(), 1, "{c:?}");
            }
            assert!(near.iter().all(|s| s.distance_to_point(c) <= 4.0 + 1.5 * 2.0 * std::f64::consts::SQRT_2 + 2.0));
        }
    }
}
