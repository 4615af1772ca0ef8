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
    /// Bucket `b`'s pieces are `pieces[piece_starts[b]..piece_starts[b + 1]]`.
    piece_starts: Vec<u32>,
    pieces: Vec<Piece>,
    /// Per bucket: the box `[x0, y0, x1, y1]` of its pieces.
    content: Vec<[Real; 4]>,
    /// Per bucket: where each [`Facing`] class of its pieces ends (they are sorted by class).
    class_ends: Vec<[u32; 4]>,
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
        // each wall's part inside each bucket its box touches (none if it only passes by)
        let mut piece_starts = Vec::with_capacity(nx * ny + 1);
        let mut pieces = Vec::with_capacity(ids.len());
        let mut content = Vec::with_capacity(nx * ny);
        let mut class_ends = Vec::with_capacity(nx * ny);
        // a wall on a bucket's edge may lie a rounding error outside the computed edge
        let eps = 1e-9 * (1.0 + lo[0].abs().max(lo[1].abs()) + nx.max(ny) as Real * cell);
        for b in 0..nx * ny {
            piece_starts.push(pieces.len() as u32);
            let (x0, y0) = (lo[0] + (b % nx) as Real * cell - eps, lo[1] + (b / nx) as Real * cell - eps);
            let cell = cell + 2.0 * eps;
            let mut bx = [Real::INFINITY, Real::INFINITY, Real::NEG_INFINITY, Real::NEG_INFINITY];
            for &id in &ids[counts[b] as usize..counts[b + 1] as usize] {
                let s = segments[id as usize];
                if let Some((p, q)) = clip(s.a, s.b, [x0, y0], [x0 + cell, y0 + cell]) {
                    pieces.push(Piece { a: s.a, b: s.b, p, q, height: s.height, one_sided: s.one_sided });
                    bx = [bx[0].min(p[0]).min(q[0]), bx[1].min(p[1]).min(q[1]), bx[2].max(p[0]).max(q[0]), bx[3].max(p[1]).max(q[1])];
                }
            }
            content.push(bx);
            let start = *piece_starts.last().unwrap() as usize;
            let mine = &mut pieces[start..];
            mine.sort_by_key(|pc| Facing::of(pc) as u8);
            let mut ends = [0u32; 4];
            for (c, end) in ends.iter_mut().enumerate() {
                *end = mine.partition_point(|pc| (Facing::of(pc) as usize) <= c) as u32;
            }
            class_ends.push(ends);
        }
        piece_starts.push(pieces.len() as u32);
        let n = segments.len();
        Ok(Self { segments, cell, origin: lo, nx, ny, starts: counts, ids, piece_starts, pieces, content, class_ends, stamp: vec![0; n], epoch: 0 })
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

    /// The pieces of the walls in bucket `(i, j)`, the box `[x0, y0, x1, y1]` holding them
    /// (empty, `x0 > x1`, if there are none), and where each [`Facing`] class among them ends
    /// (sorted by class; the last, [`Facing::Any`], ends with the slice).
    #[inline]
    pub(crate) fn bucket_pieces(&self, i: usize, j: usize) -> (&[Piece], [Real; 4], [u32; 4]) {
        let b = j * self.nx + i;
        (&self.pieces[self.piece_starts[b] as usize..self.piece_starts[b + 1] as usize], self.content[b], self.class_ends[b])
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

/// A wall's part inside one bucket, for the LIDAR: the whole wall `a b` (hits are computed on
/// it, so they are the wall's to the last bit) and the part's end points `p q`, in the
/// direction `a → b`, which bound the beams that can hit it there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Piece {
    pub a: Point2,
    pub b: Point2,
    pub p: Point2,
    pub q: Point2,
    pub height: Real,
    pub one_sided: bool,
}

/// Which side a piece can be seen from, for skipping a bucket's back faces wholesale: the
/// free side of a one-sided axis-aligned wall (solid on the left of `a → b`, seen from points
/// strictly on its right), or any side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum Facing {
    /// Seen only from `x` greater than the wall's.
    PlusX = 0,
    /// Only from smaller `x`.
    MinusX = 1,
    /// Only from greater `y`.
    PlusY = 2,
    /// Only from smaller `y`.
    MinusY = 3,
    /// Two-sided, slanted or a point: decided per piece.
    Any = 4,
}

impl Facing {
    /// The class of `pc`.
    pub(crate) fn of(pc: &Piece) -> Self {
        let (dx, dy) = (pc.b[0] - pc.a[0], pc.b[1] - pc.a[1]);
        match (pc.one_sided, dx == 0.0, dy == 0.0) {
            (true, true, false) if dy > 0.0 => Facing::PlusX,
            (true, true, false) => Facing::MinusX,
            (true, false, true) if dx < 0.0 => Facing::PlusY,
            (true, false, true) => Facing::MinusY,
            _ => Facing::Any,
        }
    }
}

/// The part of segment `a b` inside the box `lo`–`hi` (Liang–Barsky), if any; an end inside
/// is returned as it is.
fn clip(a: Point2, b: Point2, lo: Point2, hi: Point2) -> Option<(Point2, Point2)> {
    let (mut t0, mut t1): (Real, Real) = (0.0, 1.0);
    for k in 0..2 {
        let e = b[k] - a[k];
        if e == 0.0 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return None;
            }
        } else {
            let (u, v) = ((lo[k] - a[k]) / e, (hi[k] - a[k]) / e);
            t0 = t0.max(u.min(v));
            t1 = t1.min(u.max(v));
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: Real| if t <= 0.0 { a } else if t >= 1.0 { b } else { [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])] };
    Some((at(t0), at(t1)))
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

    #[test]
    fn pieces_cover_each_wall_inside_their_buckets() {
        let mut walls = vec![Segment::new([-5.0, 3.0], [80.0, 3.0], 2.0), Segment::new([0.1, 0.2], [7.3, 9.9], 2.0), Segment::new([4.0, 4.0], [4.0, 1.0], 2.0)];
        walls.push(Segment::new([2.9, 2.9], [3.1, 3.1], 1.0)); // a bucket corner
        // on a bucket edge that rounds to above it: -3.9 + 3 * 1.0 = -0.8999999999999999
        let edge = vec![Segment::new([0.0, -3.9], [30.0, -3.9], 2.0), Segment::new([23.8, -0.9], [30.0, -0.9], 2.0)];
        for (walls, cell) in [(walls, 1.5), (edge, 1.0)] {
            check_pieces(&walls, cell);
        }
    }

    #[test]
    fn facing_classes_agree_with_faces() {
        let walls = vec![
            Segment::one_sided([0.0, 0.0], [0.0, 2.0], 1.0),
            Segment::one_sided([1.0, 2.0], [1.0, 0.0], 1.0),
            Segment::one_sided([0.0, 3.0], [2.0, 3.0], 1.0),
            Segment::one_sided([2.0, 4.0], [0.0, 4.0], 1.0),
            Segment::one_sided([0.0, 5.0], [1.0, 6.0], 1.0),
            Segment::new([0.0, 7.0], [1.0, 7.0], 1.0),
        ];
        let want = [Facing::PlusX, Facing::MinusX, Facing::MinusY, Facing::PlusY, Facing::Any, Facing::Any];
        for (w, f) in walls.iter().zip(want) {
            let pc = Piece { a: w.a, b: w.b, p: w.a, q: w.b, height: 1.0, one_sided: w.one_sided };
            assert_eq!(Facing::of(&pc), f, "{w:?}");
            let mid = [(w.a[0] + w.b[0]) / 2.0, (w.a[1] + w.b[1]) / 2.0];
            let seen = |d: [Real; 2]| w.faces([mid[0] + d[0], mid[1] + d[1]]);
            match f {
                Facing::PlusX => assert!(seen([0.1, 0.0]) && !seen([-0.1, 0.0]) && !seen([0.0, 0.5])),
                Facing::MinusX => assert!(seen([-0.1, 0.0]) && !seen([0.1, 0.0])),
                Facing::PlusY => assert!(seen([0.0, 0.1]) && !seen([0.0, -0.1])),
                Facing::MinusY => assert!(seen([0.0, -0.1]) && !seen([0.0, 0.1])),
                Facing::Any => {}
            }
        }
        // sorted by class within each bucket, with the class ends
        let idx = SegmentIndex::new(walls, 10.0).unwrap();
        let (pieces, _, ends) = idx.bucket_pieces(0, 0);
        assert_eq!(ends, [1, 2, 3, 4]);
        assert!(pieces.windows(2).all(|w| Facing::of(&w[0]) as u8 <= Facing::of(&w[1]) as u8));
    }

    fn check_pieces(walls: &[Segment], cell: Real) {
        let idx = SegmentIndex::new(walls.to_vec(), cell).unwrap();
        let (nx, ny) = idx.dims();
        for (k, w) in walls.iter().enumerate() {
            let mut covered = 0.0;
            for j in 0..ny {
                for i in 0..nx {
                    let (pieces, bx, _) = idx.bucket_pieces(i, j);
                    let (x0, y0) = (idx.origin()[0] + i as Real * cell, idx.origin()[1] + j as Real * cell);
                    for pc in pieces.iter().filter(|pc| pc.a == w.a && pc.b == w.b) {
                        for v in [pc.p, pc.q] {
                            assert!(v[0] >= x0 - 1e-6 && v[0] <= x0 + cell + 1e-6 && v[1] >= y0 - 1e-6 && v[1] <= y0 + cell + 1e-6, "wall {k}");
                            assert!(v[0] >= bx[0] && v[0] <= bx[2] && v[1] >= bx[1] && v[1] <= bx[3]);
                            assert!(w.distance_to_point(v) < 1e-12, "wall {k}: {v:?} off the wall");
                        }
                        // same direction as the wall
                        let (e, f) = ([w.b[0] - w.a[0], w.b[1] - w.a[1]], [pc.q[0] - pc.p[0], pc.q[1] - pc.p[1]]);
                        assert!(e[0] * f[0] + e[1] * f[1] >= 0.0);
                        covered += f[0].hypot(f[1]);
                    }
                }
            }
            // (neighbouring pieces overlap by the clip's rounding allowance, ~1e-7 m)
            assert!(covered >= w.length() - 1e-9 && covered <= w.length() + 1e-4, "wall {k}: pieces cover {covered} of {}", w.length());
        }
    }
}
