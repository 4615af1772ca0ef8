//! The LIDAR on big maps: walls fetched bucket by bucket from a [`SegmentIndex`], nearest
//! buckets first, as pieces (a wall's part inside a bucket: its beams are those through the
//! part, its hits those of the whole wall). A planar scan skips every bucket whose beams all
//! already hit something nearer than the box of its pieces, then, within a bucket, every
//! group of pieces (those of one of its sub-cells, nearest sub-cell first) that is hidden so,
//! and every piece whose beams all already hit something no farther than the piece's box
//! (occlusion culling, beam by beam). Per group, the beams of all its pieces are computed at
//! once, in lanes, before any is swept (only for the classes of pieces that may face the
//! sensor). Same ranges as [`Lidar::scan_into`] over all
//! walls (culling only skips walls that cannot be seen), bit for bit but where a beam meets
//! two walls at a corner and the two scans round differently which is first.

use super::beams::Beams;
use super::config::Scan;
use super::numeric::{max, min, none_beyond, seg_origin_distance};
use crate::math::Real;
use crate::simd::SimdLevel;
use crate::world::index::{is_behind, Piece, PieceLanes, CLASSES, LANES, SECTORS};
use crate::world::{cross2, Pose2, Segment, SegmentIndex};

/// Reusable buffers of the indexed scan.
#[derive(Debug, Clone, Default)]
pub(crate) struct IndexedScratch {
    /// Bucket offsets `(di, dj)` sorted by a lower bound of their distance, for `key`.
    offsets: Vec<(i32, i32)>,
    key: (u64, u64, i32),
    /// Per piece of a group (or of a small bucket), computed at once (see [`Lidar::piece_beams`]).
    beams: BeamLanes,
    /// What the last scan did.
    pub(crate) stats: IndexedScanStats,
}

/// What [`Lidar::piece_beams`] finds for each of a run of pieces: its beams (first column and
/// count, see [`Lidar::wall_beams`]), squared distance to its box, whether it may be seen
/// (faces the sensor, tall enough for a planar scan, in range), and whether it is collinear
/// with the sensor.
#[derive(Debug, Clone, Default)]
struct BeamLanes {
    j0: Vec<i64>,
    count: Vec<usize>,
    box2: Vec<Real>,
    keep: Vec<bool>,
    collinear: Vec<bool>,
}

impl BeamLanes {
    fn reserve(&mut self, n: usize) {
        if self.j0.len() < n {
            self.j0.resize(n, 0);
            self.count.resize(n, 0);
            self.box2.resize(n, 0.0);
            self.keep.resize(n, false);
            self.collinear.resize(n, false);
        }
    }
}

/// Work done by the last [`Lidar::scan_indexed_into`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct IndexedScanStats {
    /// Non-empty buckets within range.
    pub buckets: usize,
    /// Of those, skipped as occluded.
    pub buckets_occluded: usize,
    /// Wall pieces read from those buckets.
    pub walls_visited: usize,
    /// Pieces swept (facing the sensor, in range, not occluded).
    pub walls_swept: usize,
    /// Non-empty groups of pieces (a bucket's sub-cell, see [`crate::world::SegmentIndex`]) in
    /// the buckets not skipped, skipped as out of range or occluded.
    pub groups_occluded: usize,
    /// Pieces facing the sensor and in range but skipped as occluded (every beam of theirs
    /// already hits something nearer).
    pub walls_occluded: usize,
    /// Beams computed by the sweeps of the pieces swept (a beam once per piece through it).
    pub beams_swept: usize,
}

/// Pieces a group needs for the LIDAR to test whether its box is hidden before reading them.
const GROUP_TEST_MIN: u32 = 8;
/// Pieces a bucket needs for the LIDAR to read it group by group (fewer are read at once).
const BUCKET_GROUPS_MIN: u32 = 48;

/// [`none_beyond`] against a squared distance `d2`.
#[inline]
fn none_beyond_sq(ranges: &[Real], j0: i64, count: usize, d2: Real) -> bool {
    let n = ranges.len();
    let mut i = (j0 & (n as i64 - 1)) as usize;
    for _ in 0..count {
        if ranges[i] * ranges[i] > d2 {
            return false;
        }
        i = (i + 1) & (n - 1);
    }
    true
}

/// The two corners of the box `[x0, x1] × [y0, y1]` between which it lies as seen from
/// `(x, y)` outside it: its angular extent is the angle between them.
#[inline]
fn silhouette(x: Real, y: Real, x0: Real, y0: Real, x1: Real, y1: Real) -> ([Real; 2], [Real; 2]) {
    let (left, right, below, above) = (x < x0, x > x1, y < y0, y > y1);
    match (left, right, below, above) {
        (true, _, true, _) | (_, true, _, true) => ([x1, y0], [x0, y1]),
        (true, _, _, true) | (_, true, true, _) => ([x0, y0], [x1, y1]),
        (true, _, _, _) => ([x0, y0], [x0, y1]),
        (_, true, _, _) => ([x1, y0], [x1, y1]),
        (_, _, true, _) => ([x0, y0], [x1, y0]),
        _ => ([x0, y1], [x1, y1]),
    }
}

/// [`silhouette`] as selects, for several boxes at once (see [`Lidar::box_beams`]); the
/// branches are faster for one box at a time. The same corners (tested).
#[inline(always)]
fn silhouette_lanes(x: Real, y: Real, x0: Real, y0: Real, x1: Real, y1: Real) -> ([Real; 2], [Real; 2]) {
    let (left, right, below, above) = (x < x0, x > x1, y < y0, y > y1);
    // beside a corner: the other two corners; beside an edge: that edge's ends
    let diag1 = (left & below) | (right & above);
    let diag2 = (left & above) | (right & below);
    let beside = left | right;
    let xs = if left { x0 } else { x1 };
    let ys = if below { y0 } else { y1 };
    let pick = |d1: Real, d2: Real, side: Real, other: Real| {
        if diag1 {
            d1
        } else if diag2 {
            d2
        } else if beside {
            side
        } else {
            other
        }
    };
    ([pick(x1, x0, xs, x0), pick(y0, y0, y0, ys)], [pick(x0, x1, xs, x1), pick(y1, y1, y1, ys)])
}

/// The sensor's pose in the world, with its yaw's sine and cosine.
#[derive(Debug, Clone, Copy)]
struct SensorFrame {
    x: Real,
    y: Real,
    s: Real,
    c: Real,
}

impl SensorFrame {
    fn new(sp: Pose2) -> Self {
        let (s, c) = sp.yaw.sin_cos();
        Self { x: sp.x, y: sp.y, s, c }
    }

    /// The world point `p` in the sensor's frame.
    #[inline(always)]
    fn point(&self, p: [Real; 2]) -> [Real; 2] {
        let (dx, dy) = (p[0] - self.x, p[1] - self.y);
        [self.c * dx + self.s * dy, -self.s * dx + self.c * dy]
    }

    /// Squared distance from the sensor to the box `[x0, y0, x1, y1]` (0 inside it).
    #[inline(always)]
    fn box_distance2(&self, [x0, y0, x1, y1]: [Real; 4]) -> Real {
        let ddx = max(max(x0 - self.x, 0.0), self.x - x1);
        let ddy = max(max(y0 - self.y, 0.0), self.y - y1);
        ddx * ddx + ddy * ddy
    }

    /// Distance from the sensor to the box `[x0, y0, x1, y1]` (0 inside it).
    #[inline(always)]
    fn box_distance(&self, bx: [Real; 4]) -> Real {
        self.box_distance2(bx).sqrt()
    }
}

impl Beams {
    /// Whether the walls in the box `[x0, y0, x1, y1]` (not empty, at `dmin` from the sensor
    /// `f`) are hidden: for a planar scan seen from outside the box, every beam through it
    /// already hits something no farther than the box.
    #[inline(always)]
    fn box_hidden(&self, [x0, y0, x1, y1]: [Real; 4], dmin: Real, f: &SensorFrame, ranges: &[Real]) -> bool {
        if self.config.channels > 1 || dmin == 0.0 {
            return false;
        }
        // seen from outside, the box spans the angle between its two silhouette corners (the
        // others lie between them)
        let (p, q) = silhouette(f.x, f.y, x0, y0, x1, y1);
        let (a, b) = (f.point(p), f.point(q));
        let cr = cross2(a, b);
        let (j0, count) = self.wall_beams(a, b, cr);
        self.hidden((j0, count, cr != 0.0), dmin, ranges)
    }

    /// [`Lidar::box_hidden`] for a box whose beams `(j0, count, sides)` are known (see
    /// [`Lidar::box_beams`]).
    #[inline(always)]
    fn hidden(&self, (j0, count, sides): (i64, usize, bool), dmin: Real, ranges: &[Real]) -> bool {
        self.config.channels == 1 && dmin != 0.0 && sides && none_beyond(ranges, j0, count, dmin)
    }

    /// The beams through each of the boxes `[x0, y0, x1, y1]` (not empty), `L` at once, as
    /// [`Lidar::box_hidden`] finds them (for a sensor `f` outside the box): the first column
    /// and count of [`Lidar::wall_beams`] between the two corners the box lies between
    /// ([`silhouette_lanes`]), and whether those are not in line with the sensor (else the
    /// beams are not used).
    #[inline(always)]
    fn box_beams<const L: usize>(&self, boxes: &[[Real; 4]; L], f: &SensorFrame) -> ([i64; L], [usize; L], [bool; L]) {
        let (mut j0s, mut counts, mut sides) = ([0i64; L], [0usize; L], [false; L]);
        for k in 0..L {
            let [x0, y0, x1, y1] = boxes[k];
            let (p, q) = silhouette_lanes(f.x, f.y, x0, y0, x1, y1);
            let (a, b) = (f.point(p), f.point(q));
            let cr = cross2(a, b);
            (j0s[k], counts[k]) = self.wall_beams(a, b, cr);
            sides[k] = cr != 0.0;
        }
        (j0s, counts, sides)
    }

    /// The [`BeamLanes`] of the `m` pieces of `l` from `k0` seen from the sensor `f`, written
    /// to `out` from its start: the same arithmetic as piece by
    /// piece, in blocks of `L` (at most [`LANES`]; past the last piece, `l`'s padding is
    /// computed and ignored).
    #[inline(always)]
    fn piece_beams<const L: usize>(&self, l: &PieceLanes, k0: usize, m: usize, f: &SensorFrame, out: &mut BeamLanes) {
        let c = &self.config;
        let (planar, zs, max2) = (c.channels == 1, c.mount.z, c.max_range * c.max_range);
        let nb = m.div_ceil(L);
        let len = nb * L;
        // the blocks, every lane sliced to the same length once (no bounds checks inside)
        fn blocks<const L: usize>(v: &[Real], r: std::ops::Range<usize>) -> &[[Real; L]] {
            v[r].as_chunks::<L>().0
        }
        let r = k0..k0 + len;
        let (px, py, qx, qy, ax, ay) =
            (blocks::<L>(&l.px, r.clone()), blocks::<L>(&l.py, r.clone()), blocks::<L>(&l.qx, r.clone()), blocks::<L>(&l.qy, r.clone()), blocks::<L>(&l.ax, r.clone()), blocks::<L>(&l.ay, r.clone()));
        let (ex, ey, height) = (blocks::<L>(&l.ex, r.clone()), blocks::<L>(&l.ey, r.clone()), blocks::<L>(&l.height, r));
        let one_sided = l.one_sided[k0..k0 + len].as_chunks::<L>().0;
        let j0_out = out.j0[..len].as_chunks_mut::<L>().0;
        let count_out = out.count[..len].as_chunks_mut::<L>().0;
        let box2_out = out.box2[..len].as_chunks_mut::<L>().0;
        let keep_out = out.keep[..len].as_chunks_mut::<L>().0;
        let collinear_out = out.collinear[..len].as_chunks_mut::<L>().0;
        for blk in 0..nb {
            let (px, py, qx, qy, ax, ay, ex, ey, height, one_sided) = (&px[blk], &py[blk], &qx[blk], &qy[blk], &ax[blk], &ay[blk], &ex[blk], &ey[blk], &height[blk], &one_sided[blk]);
            let (mut j0s, mut counts, mut box2s, mut keep, mut collinear) = ([0i64; L], [0usize; L], [0.0; L], [false; L], [false; L]);
            for i in 0..L {
                let faces = !one_sided[i] | (cross2([ex[i], ey[i]], [f.x - ax[i], f.y - ay[i]]) < 0.0);
                // squared distance to the piece's box: a lower bound of the piece's (exact for
                // the axis-aligned walls of grid maps), without division or root
                box2s[i] = f.box_distance2([min(px[i], qx[i]), min(py[i], qy[i]), max(px[i], qx[i]), max(py[i], qy[i])]);
                let (p, q) = (f.point([px[i], py[i]]), f.point([qx[i], qy[i]]));
                let cr = cross2(p, q);
                (j0s[i], counts[i]) = self.wall_beams(p, q, cr);
                keep[i] = faces & !(planar & (zs > height[i])) & (box2s[i] <= max2);
                collinear[i] = cr == 0.0;
            }
            j0_out[blk] = j0s;
            count_out[blk] = counts;
            box2_out[blk] = box2s;
            keep_out[blk] = keep;
            collinear_out[blk] = collinear;
        }
    }

    /// The beams of `pieces[run]` (the bucket's pieces, whose lanes start at `start`), then
    /// their sweeps.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn sweep_run<const L: usize>(
        &self,
        lanes: &PieceLanes,
        start: usize,
        pieces: &[Piece],
        run: std::ops::Range<usize>,
        f: &SensorFrame,
        beams: &mut BeamLanes,
        ranges: &mut [Real],
        stats: &mut IndexedScanStats,
    ) {
        if run.is_empty() {
            return;
        }
        self.piece_beams::<L>(lanes, start + run.start, run.len(), f, beams);
        stats.walls_visited += run.len();
        self.sweep_pieces(&pieces[run], beams, f, ranges, stats);
    }

    /// Sweeps those of `pieces` that may be seen from the sensor `f` and are not occluded,
    /// their beams being the first of `beams` (see [`Lidar::piece_beams`]).
    #[inline(always)]
    fn sweep_pieces(&self, pieces: &[Piece], beams: &BeamLanes, f: &SensorFrame, ranges: &mut [Real], stats: &mut IndexedScanStats) {
        let c = &self.config;
        let (planar, zs) = (c.channels == 1, c.mount.z);
        let r = 0..pieces.len();
        let (j0s, counts, box2s, keep, collinear) = (&beams.j0[r.clone()], &beams.count[r.clone()], &beams.box2[r.clone()], &beams.keep[r.clone()], &beams.collinear[r]);
        for (i, pc) in pieces.iter().enumerate() {
            if !keep[i] {
                continue;
            }
            let (j0, count, box2) = (j0s[i], counts[i], box2s[i]);
            if collinear[i] {
                // collinear with the sensor (its beams above are not used)
                stats.walls_swept += 1;
                let (a, b, p, q) = (f.point(pc.a), f.point(pc.b), f.point(pc.p), f.point(pc.q));
                self.sweep_piece(a, b, p, q, pc.height, box2.sqrt(), zs, ranges);
                continue;
            }
            // a planar beam that already hits no farther than the piece's box cannot change
            if planar && none_beyond_sq(ranges, j0, count, box2) {
                stats.walls_occluded += 1;
                continue;
            }
            stats.walls_swept += 1;
            stats.beams_swept += count;
            let (a, b) = (f.point(pc.a), f.point(pc.b));
            if planar {
                self.sweep_flat(a, b, j0, count, ranges);
            } else {
                self.sweep(a, b, pc.height, j0, count, zs, box2.sqrt(), ranges);
            }
        }
    }

    /// Sweeps `extra` (moving obstacles, few) from the sensor pose `sp`, each wall whole.
    #[inline]
    pub(crate) fn sweep_extra(&self, extra: &[Segment], sp: Pose2, ranges: &mut [Real]) {
        let c = self.config;
        let f = SensorFrame::new(sp);
        let zs = c.mount.z;
        for seg in extra.iter().filter(|s| s.faces([sp.x, sp.y])) {
            let (a, b) = (f.point(seg.a), f.point(seg.b));
            let d = seg_origin_distance(a, b);
            if d <= c.max_range && !(c.channels == 1 && zs > seg.height) {
                self.sweep_segment(a, b, seg.height, d, zs, ranges);
            }
        }
    }

    /// [`Lidar::sweep_index`] with the vector instructions of this CPU.
    pub(crate) fn sweep_index_any(&self, sc: &mut IndexedScratch, index: &SegmentIndex, extra: &[Segment], sp: Pose2, out: &mut Scan) {
        match self.simd {
            // SAFETY: `simd` is found from the CPU: it runs these instructions.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => unsafe { self.sweep_index_avx512(sc, index, extra, sp, out) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => unsafe { self.sweep_index_avx2(sc, index, extra, sp, out) },
            _ => self.sweep_index::<4>(sc, index, extra, sp, out),
        }
    }

    /// [`Lidar::sweep_index`] built for AVX2 and FMA (same ranges: no fused multiply-add is
    /// asked for, so none is used).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub(crate) fn sweep_index_avx2(&self, sc: &mut IndexedScratch, index: &SegmentIndex, extra: &[Segment], sp: Pose2, out: &mut Scan) {
        self.sweep_index::<4>(sc, index, extra, sp, out);
    }

    /// [`Lidar::sweep_index`] built for AVX-512 (same ranges): twice the vector registers,
    /// and mask registers, for the many values of [`Lidar::piece_beams`], which computes eight
    /// pieces at once (four with AVX2, whose sixteen registers eight would overflow).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq")]
    pub(crate) fn sweep_index_avx512(&self, sc: &mut IndexedScratch, index: &SegmentIndex, extra: &[Segment], sp: Pose2, out: &mut Scan) {
        self.sweep_index::<8>(sc, index, extra, sp, out);
    }

    /// The ranges of [`Lidar::scan_indexed_into`] before limits and noise, the pieces' beams
    /// computed `L` pieces at once (at most [`LANES`]).
    #[inline(always)]
    pub(crate) fn sweep_index<const L: usize>(&self, sc: &mut IndexedScratch, index: &SegmentIndex, extra: &[Segment], sp: Pose2, out: &mut Scan) {
        let c = self.config;
        let f = SensorFrame::new(sp);
        let scratch = sc;
        self.sweep_extra(extra, sp, &mut out.ranges);
        let cell = index.cell();
        let (nx, ny) = index.dims();
        let origin = index.origin();
        let ci = ((sp.x - origin[0]) / cell).floor() as i64;
        let cj = ((sp.y - origin[1]) / cell).floor() as i64;
        // offsets beyond the index's extent as seen from the sensor's bucket are never inside
        // it (a sensor outside the walls' box is that much farther from its far side)
        let outside = [-ci, ci - (nx as i64 - 1), -cj, cj - (ny as i64 - 1)].into_iter().fold(0i64, i64::max);
        let r = ((c.max_range / cell).ceil() + 1.0).min(nx.max(ny) as Real + outside as Real) as i32;
        let key = (cell.to_bits(), c.max_range.to_bits(), r);
        if scratch.key != key || scratch.offsets.is_empty() {
            let lb = |d: i32| ((d.abs() - 1).max(0) as Real) * cell;
            let mut offs: Vec<(Real, i32, i32)> = Vec::new();
            for dj in -r..=r {
                for di in -r..=r {
                    let l = lb(di).hypot(lb(dj));
                    if l <= c.max_range {
                        offs.push((l, di, dj));
                    }
                }
            }
            offs.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
            scratch.offsets = offs.into_iter().map(|(_, i, j)| (i, j)).collect();
            scratch.key = key;
        }
        let mut stats = IndexedScanStats::default();
        let mut beams = std::mem::take(&mut scratch.beams);
        let lanes = index.lanes();
        let max2 = c.max_range * c.max_range;
        let mut next = 0;
        while next < scratch.offsets.len() {
            // the next `L` non-empty buckets in range, in order, their boxes' beams at once
            let (mut found, mut cells, mut boxes, mut d2s) = (0, [(0usize, 0usize); L], [[0.0; 4]; L], [0.0; L]);
            while next < scratch.offsets.len() && found < L {
                let (di, dj) = scratch.offsets[next];
                next += 1;
                let (i, j) = (ci + di as i64, cj + dj as i64);
                if i < 0 || j < 0 || i >= nx as i64 || j >= ny as i64 || index.bucket_is_empty(i as usize, j as usize) {
                    continue;
                }
                let bx = index.bucket_box(i as usize, j as usize);
                let d2 = f.box_distance2(bx);
                if d2 > max2 {
                    continue;
                }
                (cells[found], boxes[found], d2s[found]) = ((i as usize, j as usize), bx, d2);
                found += 1;
            }
            for k in found..L {
                // (padding, computed and ignored)
                boxes[k] = boxes[0];
            }
            let (j0s, counts, sides) = self.box_beams::<L>(&boxes, &f);
            for k in 0..found {
                let (i, j) = cells[k];
                let (pieces, _, groups, start) = index.bucket_pieces(i, j);
                let dmin = d2s[k].sqrt();
                stats.buckets += 1;
                // occlusion culling, away from the sensor: skip the bucket if every beam through
                // the box of its pieces already hits something no farther than the box
                if self.hidden((j0s[k], counts[k], sides[k]), dmin, &out.ranges) {
                    stats.buckets_occluded += 1;
                    continue;
                }
                beams.reserve(pieces.len() + LANES);
                if pieces.len() < BUCKET_GROUPS_MIN as usize {
                    // a small bucket: all its pieces at once, whether each faces the sensor decided
                    // piece by piece
                    self.sweep_run::<L>(lanes, start, pieces, 0..pieces.len(), &f, &mut beams, &mut out.ranges, &mut stats);
                    continue;
                }
                for &g in index.group_order(i, j, [sp.x, sp.y]) {
                    let grp = &groups[g as usize];
                    if grp.start == grp.ends[CLASSES - 1] {
                        continue;
                    }
                    // occlusion culling, away from the sensor: skip the group if every beam through
                    // the box of its pieces already hits something no farther than the box
                    // (a group of a few pieces is cheaper read than tested)
                    if grp.ends[CLASSES - 1] - grp.start >= GROUP_TEST_MIN {
                        let d = f.box_distance(grp.bx);
                        if d > c.max_range || self.box_hidden(grp.bx, d, &f, &out.ranges) {
                            stats.groups_occluded += 1;
                            continue;
                        }
                    }
                    // the pieces that face the sensor, are tall enough and in range, without
                    // branches; a class of one-sided pieces that all face away is not read at all
                    // (see `world::index::is_behind`): per run of consecutive classes not skipped,
                    // the beams of all its pieces at once (independent, in lanes of `L`), then
                    // their sweeps
                    let (mut run, mut from) = (grp.start as usize, grp.start as usize);
                    let behind = index.behind(grp);
                    for (k, &to) in grp.ends.iter().enumerate() {
                        if k < SECTORS && is_behind(&behind[k], sp.x, sp.y) {
                            self.sweep_run::<L>(lanes, start, pieces, run..from, &f, &mut beams, &mut out.ranges, &mut stats);
                            run = to as usize;
                        }
                        from = to as usize;
                    }
                    self.sweep_run::<L>(lanes, start, pieces, run..from, &f, &mut beams, &mut out.ranges, &mut stats);
                }
            }
        }
        scratch.beams = beams;
        scratch.stats = stats;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The silhouette as selects gives the branches' corners from every side of a box: the
    /// eight around it, on its edges' lines, and inside it.
    #[test]
    fn silhouette_lanes_equals_silhouette() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (x0, y0, x1, y1) = (1.0, -2.0, 3.0, 0.5);
        let mut sides = std::collections::HashSet::new();
        for _ in 0..20_000 {
            // from points on a grid through the box's edges, so that some lie on their lines
            let x = [-1.0, x0, 2.0, x1, 5.0][rng.random_range(0..5)] + if rng.random_bool(0.5) { rng.random_range(-0.5..0.5) } else { 0.0 };
            let y = [-4.0, y0, 0.0, y1, 2.0][rng.random_range(0..5)] + if rng.random_bool(0.5) { rng.random_range(-0.5..0.5) } else { 0.0 };
            sides.insert(((x < x0) as i8 - (x > x1) as i8, (y < y0) as i8 - (y > y1) as i8));
            assert_eq!(silhouette(x, y, x0, y0, x1, y1), silhouette_lanes(x, y, x0, y0, x1, y1), "from ({x}, {y})");
        }
        assert_eq!(sides.len(), 9, "every side of the box and its inside: {sides:?}");
    }
}
