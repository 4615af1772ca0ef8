//! A uniform bucket grid over wall segments, to fetch the walls near a point on big maps.

use super::geometry::{cross2, Point2, Segment};
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
    /// The pieces again, as lanes.
    lanes: PieceLanes,
    /// Per bucket: the box `[x0, y0, x1, y1]` of its pieces.
    content: Vec<[Real; 4]>,
    /// Per bucket: its [`Group`]s, `GROUPS` of them, in sub-cell order `sx + SUB * sy`.
    groups: Vec<Group>,
    /// Per non-empty group: per sector class, whether a point is behind all its walls (see
    /// [`behind`]).
    behinds: Vec<[[Real; 6]; SECTORS]>,
    /// Per sub-cell `(sx, sy)` of a bucket nearest the sensor: the groups nearest first.
    orders: [[u8; GROUPS]; GROUPS],
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
        // (counted in floating point: a tiny cell or far walls overflow any integer)
        let (fx, fy) = (((hi[0] - lo[0]) / cell).floor() + 1.0, ((hi[1] - lo[1]) / cell).floor() + 1.0);
        if fx * fy > 50_000_000.0 {
            return Err(Error::invalid("cell", format!("{cell} m gives {fx:e} x {fy:e} buckets over the walls' extent; use a larger cell")));
        }
        let (nx, ny) = (fx as usize, fy as usize);
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
        let mut groups = Vec::with_capacity(nx * ny * GROUPS);
        let mut behinds = Vec::new();
        let mut keyed: Vec<((usize, usize), Piece)> = Vec::new();
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
            // grouped by the sub-cell of their middle, then sorted by class
            let start = *piece_starts.last().unwrap() as usize;
            let mine = &mut pieces[start..];
            if mine.is_empty() {
                let empty = Group { bx, start: 0, ends: [0; CLASSES], behind: u32::MAX };
                groups.extend(std::iter::repeat_n(empty, GROUPS));
                continue;
            }
            let sub = |pc: &Piece| {
                let f = |v: Real, o: Real| (((v - o) / cell * SUB as Real).floor().max(0.0) as usize).min(SUB - 1);
                f((pc.p[0] + pc.q[0]) / 2.0, x0) + SUB * f((pc.p[1] + pc.q[1]) / 2.0, y0)
            };
            keyed.clear();
            keyed.extend(mine.iter().map(|pc| ((sub(pc), facing_class(pc)), *pc)));
            keyed.sort_by_key(|(key, _)| *key);
            for (slot, (_, pc)) in mine.iter_mut().zip(&keyed) {
                *slot = *pc;
            }
            let mut from = 0;
            for g in 0..GROUPS {
                // (sorted by group, then class: each class's pieces follow the last's)
                let (mut ends, mut to) = ([0u32; CLASSES], from);
                for (c, end) in ends.iter_mut().enumerate() {
                    while to < keyed.len() && keyed[to].0 == (g, c) {
                        to += 1;
                    }
                    *end = to as u32;
                }
                let of = &mine[from..to];
                let behind = if to > from {
                    behinds.push(std::array::from_fn(|k| {
                        let a = if k == 0 { from } else { ends[k - 1] as usize };
                        behind(&mine[a..ends[k] as usize])
                    }));
                    (behinds.len() - 1) as u32
                } else {
                    u32::MAX
                };
                let bx = of.iter().fold([Real::INFINITY, Real::INFINITY, Real::NEG_INFINITY, Real::NEG_INFINITY], |b, pc| {
                    [b[0].min(pc.p[0]).min(pc.q[0]), b[1].min(pc.p[1]).min(pc.q[1]), b[2].max(pc.p[0]).max(pc.q[0]), b[3].max(pc.p[1]).max(pc.q[1])]
                });
                groups.push(Group { bx, start: from as u32, ends, behind });
                from = to;
            }
        }
        piece_starts.push(pieces.len() as u32);
        let lanes = PieceLanes::of(&pieces);
        // each sub-cell's groups by the distance between sub-cell centres, nearest first
        let mut orders = [[0u8; GROUPS]; GROUPS];
        for (s, order) in orders.iter_mut().enumerate() {
            let d = |g: usize| ((g % SUB) as i64 - (s % SUB) as i64).pow(2) + ((g / SUB) as i64 - (s / SUB) as i64).pow(2);
            let mut gs: Vec<usize> = (0..GROUPS).collect();
            gs.sort_by_key(|&g| (d(g), g));
            for (o, g) in order.iter_mut().zip(gs) {
                *o = g as u8;
            }
        }
        let n = segments.len();
        Ok(Self { segments, cell, origin: lo, nx, ny, starts: counts, ids, piece_starts, pieces, lanes, content, groups, behinds, orders, stamp: vec![0; n], epoch: 0 })
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

    /// Whether bucket `(i, j)` holds no piece.
    #[inline(always)]
    pub(crate) fn bucket_is_empty(&self, i: usize, j: usize) -> bool {
        let b = j * self.nx + i;
        self.piece_starts[b] == self.piece_starts[b + 1]
    }

    /// The box `[x0, y0, x1, y1]` of the pieces in bucket `(i, j)` (empty, `x0 > x1`, if there
    /// are none).
    #[inline(always)]
    pub(crate) fn bucket_box(&self, i: usize, j: usize) -> [Real; 4] {
        self.content[j * self.nx + i]
    }

    /// The pieces of the walls in bucket `(i, j)`, the box `[x0, y0, x1, y1]` holding them
    /// (empty, `x0 > x1`, if there are none), their [`Group`]s (in sub-cell order), and where
    /// they start in [`SegmentIndex::lanes`].
    #[inline(always)]
    pub(crate) fn bucket_pieces(&self, i: usize, j: usize) -> (&[Piece], [Real; 4], &[Group], usize) {
        let b = j * self.nx + i;
        let start = self.piece_starts[b] as usize;
        (&self.pieces[start..self.piece_starts[b + 1] as usize], self.content[b], &self.groups[b * GROUPS..(b + 1) * GROUPS], start)
    }

    /// The behind tests of the classes of the group `grp` (not empty): see [`is_behind`].
    #[inline(always)]
    pub(crate) fn behind(&self, grp: &Group) -> &[[Real; 6]; SECTORS] {
        &self.behinds[grp.behind as usize]
    }

    /// Every bucket's pieces, bucket after bucket, as lanes.
    #[inline]
    pub(crate) fn lanes(&self) -> &PieceLanes {
        &self.lanes
    }

    /// The groups of bucket `(i, j)` in order of distance from `point` (by sub-cell centres:
    /// the sub-cell nearest `point`'s first).
    #[inline]
    pub(crate) fn group_order(&self, i: usize, j: usize, point: Point2) -> &[u8; GROUPS] {
        let f = |v: Real, o: Real, k: usize| (((v - o) / self.cell - k as Real) * SUB as Real).floor().clamp(0.0, (SUB - 1) as Real) as usize;
        &self.orders[f(point[0], self.origin[0], i) + SUB * f(point[1], self.origin[1], j)]
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

/// Sub-cells per bucket side: a bucket's pieces are grouped by the sub-cell of their middle,
/// so that the LIDAR can skip the groups hidden behind nearer walls.
pub(crate) const SUB: usize = 2;
/// Groups per bucket.
pub(crate) const GROUPS: usize = SUB * SUB;

/// The pieces of a bucket whose middles lie in one of its sub-cells:
/// `pieces[start..ends[CLASSES - 1]]` of the bucket, sorted by [`facing_class`] (class `c`
/// ends at `ends[c]`), the box `[x0, y0, x1, y1]` holding them (empty, `x0 > x1`, if there
/// are none), and (if it is not empty) where its classes' tests of whether a point is behind
/// all their walls are kept (see [`SegmentIndex::behind`], [`is_behind`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Group {
    pub bx: [Real; 4],
    pub start: u32,
    pub ends: [u32; CLASSES],
    pub behind: u32,
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

/// Pieces as lanes, one array per coordinate (so that many are computed at once): the part's
/// ends `p`, `q`, the wall's start `a` and direction `e = b - a`, height and sidedness.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct PieceLanes {
    pub px: Vec<Real>,
    pub py: Vec<Real>,
    pub qx: Vec<Real>,
    pub qy: Vec<Real>,
    pub ax: Vec<Real>,
    pub ay: Vec<Real>,
    pub ex: Vec<Real>,
    pub ey: Vec<Real>,
    pub height: Vec<Real>,
    pub one_sided: Vec<bool>,
}

/// The most pieces computed at once from [`PieceLanes`], which hold as many padding pieces
/// past the last.
pub(crate) const LANES: usize = 8;

impl PieceLanes {
    /// The lanes of `pieces`, padded (with copies of a zero-length wall at the origin).
    fn of(pieces: &[Piece]) -> Self {
        let pad = Piece { a: [0.0; 2], b: [0.0; 2], p: [0.0; 2], q: [0.0; 2], height: 0.0, one_sided: false };
        let pieces: Vec<Piece> = pieces.iter().copied().chain(std::iter::repeat_n(pad, LANES)).collect();
        let lane = |f: fn(&Piece) -> Real| pieces.iter().map(f).collect();
        Self {
            px: lane(|pc| pc.p[0]),
            py: lane(|pc| pc.p[1]),
            qx: lane(|pc| pc.q[0]),
            qy: lane(|pc| pc.q[1]),
            ax: lane(|pc| pc.a[0]),
            ay: lane(|pc| pc.a[1]),
            ex: lane(|pc| pc.b[0] - pc.a[0]),
            ey: lane(|pc| pc.b[1] - pc.a[1]),
            height: lane(|pc| pc.height),
            one_sided: pieces.iter().map(|pc| pc.one_sided).collect(),
        }
    }
}

/// One-sided walls' classes by the direction they face: sectors of 45° about `k · 45°`.
pub(crate) const SECTORS: usize = 8;
/// Facing classes: the [`SECTORS`], then two-sided walls and points (decided per piece).
pub(crate) const CLASSES: usize = SECTORS + 1;

/// The facing class of `pc`: for a one-sided wall (solid on the left of `a → b`, seen only
/// from points strictly on its right) the sector holding its outward normal `(dy, -dx)`,
/// otherwise [`SECTORS`].
pub(crate) fn facing_class(pc: &Piece) -> usize {
    let (dx, dy) = (pc.b[0] - pc.a[0], pc.b[1] - pc.a[1]);
    if !pc.one_sided || (dx == 0.0 && dy == 0.0) {
        return SECTORS;
    }
    ((-dx).atan2(dy) / std::f64::consts::FRAC_PI_4).round().rem_euclid(SECTORS as Real) as usize
}

/// For the pieces `of`, all of one sector class: their two extreme outward normals `n1`, `n2`
/// (unit, clockwise-most and counter-clockwise-most; every other normal lies between them,
/// within the sector) and, less a margin, the least `m1`, `m2` of `a · n1`, `a · n2` over
/// their walls' starts `a`, as `[n1x, n1y, m1, n2x, n2y, m2]`. A point `s` with `s · n1 <= m1`
/// and `s · n2 <= m2` sees none of them: each normal `n` is `λ1 n1 + λ2 n2` with
/// `λ1, λ2 >= 0`, so `(s - a) · n < 0`. An empty class gets `m = -∞`, which no point passes.
fn behind(of: &[Piece]) -> [Real; 6] {
    let normal = |pc: &Piece| {
        let (dx, dy) = (pc.b[0] - pc.a[0], pc.b[1] - pc.a[1]);
        let l = dx.hypot(dy);
        [dy / l, -dx / l]
    };
    let Some(first) = of.first() else {
        return [0.0, 0.0, Real::NEG_INFINITY, 0.0, 0.0, Real::NEG_INFINITY];
    };
    // within a sector (under half a turn) "clockwise of" is an order
    let (mut n1, mut n2) = (normal(first), normal(first));
    for pc in &of[1..] {
        let n = normal(pc);
        if cross2(n, n1) > 0.0 {
            n1 = n;
        }
        if cross2(n2, n) > 0.0 {
            n2 = n;
        }
    }
    let least = |n: [Real; 2]| {
        let m = of.iter().map(|pc| pc.a[0] * n[0] + pc.a[1] * n[1]).fold(Real::INFINITY, Real::min);
        m - 1e-9 * (1.0 + m.abs())
    };
    [n1[0], n1[1], least(n1), n2[0], n2[1], least(n2)]
}

/// Whether the point `(x, y)` sees none of the walls of a sector class whose test (see
/// [`behind`]) is `b`.
#[inline(always)]
pub(crate) fn is_behind(b: &[Real; 6], x: Real, y: Real) -> bool {
    (x * b[0] + y * b[1] <= b[2]) & (x * b[3] + y * b[4] <= b[5])
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
    let at = |t: Real| {
        if t <= 0.0 {
            a
        } else if t >= 1.0 {
            b
        } else {
            [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
        }
    };
    Some((at(t0), at(t1)))
}

#[cfg(test)]
#[path = "index_tests.rs"]
mod tests;
