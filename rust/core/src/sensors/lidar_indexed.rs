//! The LIDAR on big maps: walls fetched bucket by bucket from a [`SegmentIndex`], nearest
//! buckets first, as pieces (a wall's part inside a bucket: its beams are those through the
//! part, its hits those of the whole wall). A planar scan skips every bucket whose beams all
//! already hit something nearer than the box of its pieces, and every piece whose beams all
//! already hit something no farther than the piece's box (occlusion culling, beam by beam).
//! Per bucket, the pieces that face the sensor are picked without branches and their beams
//! computed side by side before any is swept. Same ranges as [`Lidar::scan_into`] over all
//! walls (culling only skips walls that cannot be seen), bit for bit but where a beam meets
//! two walls at a corner and the two scans round differently which is first.

use rand::Rng;

use super::lidar::{seg_origin_distance, Lidar, Scan};
use crate::error::Result;
use crate::math::Real;
use crate::world::{cross2, Pose2, Segment, SegmentIndex};

/// Reusable buffers of the indexed scan.
#[derive(Debug, Clone, Default)]
pub(super) struct IndexedScratch {
    /// Bucket offsets `(di, dj)` sorted by a lower bound of their distance, for `key`.
    offsets: Vec<(i32, i32)>,
    key: (u64, u64, i32),
    /// Per piece of a bucket: its place and squared box distance, if it may be seen.
    candidates: Vec<(u32, Real)>,
    /// The beams of each candidate (see [`Lidar::wall_beams`]) and whether it is collinear
    /// with the sensor.
    beams: Vec<(i64, usize, bool)>,
    /// What the last scan did.
    stats: IndexedScanStats,
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
    /// Pieces facing the sensor and in range but skipped as occluded (every beam of theirs
    /// already hits something nearer).
    pub walls_occluded: usize,
}

/// Whether none of the `count` ranges from column `j0` (modulo their number, a power of two)
/// exceeds `d`.
#[inline]
fn none_beyond(ranges: &[Real], j0: i64, count: usize, d: Real) -> bool {
    let n = ranges.len();
    let i = (j0 & (n as i64 - 1)) as usize;
    let beyond = |s: &[Real]| s.iter().fold(false, |acc, &r| acc | (r > d));
    if i + count <= n {
        !beyond(&ranges[i..i + count])
    } else {
        !beyond(&ranges[i..]) && !beyond(&ranges[..i + count - n])
    }
}

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

impl Lidar {
    /// What the last [`Lidar::scan_indexed_into`] did (buckets visited and culled, walls swept).
    pub fn last_indexed_stats(&self) -> IndexedScanStats {
        self.indexed.stats
    }

    /// Scans the walls of `index` plus `extra` (moving obstacles, few) from a robot at `body`.
    /// Ranges are identical to [`Lidar::scan_into`] over the same walls.
    pub fn scan_indexed_into<R: Rng + ?Sized>(&mut self, index: &SegmentIndex, extra: &[Segment], body: Pose2, stamp: Real, rng: &mut R, out: &mut Scan) -> Result<()> {
        let sp = self.begin_scan(body, stamp, out)?;
        #[cfg(target_arch = "x86_64")]
        if super::lidar::has_avx2() {
            // SAFETY: the CPU has AVX2 and FMA, checked just above.
            unsafe { self.sweep_index_avx2(index, extra, sp, out) };
            self.finish(rng, out);
            return Ok(());
        }
        self.sweep_index(index, extra, sp, out);
        self.finish(rng, out);
        Ok(())
    }

    /// [`Lidar::sweep_index`] built for AVX2 and FMA (same ranges: no fused multiply-add is
    /// asked for, so none is used).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn sweep_index_avx2(&mut self, index: &SegmentIndex, extra: &[Segment], sp: Pose2, out: &mut Scan) {
        self.sweep_index(index, extra, sp, out);
    }

    /// The ranges of [`Lidar::scan_indexed_into`] before limits and noise.
    #[inline(always)]
    pub(super) fn sweep_index(&mut self, index: &SegmentIndex, extra: &[Segment], sp: Pose2, out: &mut Scan) {
        let c = self.config;
        let kch = c.channels;
        let (s, co) = sp.yaw.sin_cos();
        let to_sensor = |p: [Real; 2]| {
            let (dx, dy) = (p[0] - sp.x, p[1] - sp.y);
            [co * dx + s * dy, -s * dx + co * dy]
        };
        let zs = c.mount.z;
        let planar = kch == 1;
        let mut scratch = std::mem::take(&mut self.indexed);
        for seg in extra.iter().filter(|s| s.faces([sp.x, sp.y])) {
            let (a, b) = (to_sensor(seg.a), to_sensor(seg.b));
            let d = seg_origin_distance(a, b);
            if d <= c.max_range && !(planar && zs > seg.height) {
                self.sweep_segment(a, b, seg.height, d, zs, &mut out.ranges);
            }
        }
        let cell = index.cell();
        let (nx, ny) = index.dims();
        // offsets beyond the index's extent are never inside it
        let r = ((c.max_range / cell).ceil() + 1.0).min(nx.max(ny) as Real) as i32;
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
        let origin = index.origin();
        let ci = ((sp.x - origin[0]) / cell).floor() as i64;
        let cj = ((sp.y - origin[1]) / cell).floor() as i64;
        let max2 = c.max_range * c.max_range;
        let mut stats = IndexedScanStats::default();
        let mut cand = std::mem::take(&mut scratch.candidates);
        let mut beams = std::mem::take(&mut scratch.beams);
        for &(di, dj) in &scratch.offsets {
            let (i, j) = (ci + di as i64, cj + dj as i64);
            if i < 0 || j < 0 || i >= nx as i64 || j >= ny as i64 {
                continue;
            }
            let (pieces, [x0, y0, x1, y1], class_ends) = index.bucket_pieces(i as usize, j as usize);
            if pieces.is_empty() {
                continue;
            }
            let ddx = (x0 - sp.x).max(0.0).max(sp.x - x1);
            let ddy = (y0 - sp.y).max(0.0).max(sp.y - y1);
            let dmin_b = (ddx * ddx + ddy * ddy).sqrt();
            if dmin_b > c.max_range {
                continue;
            }
            stats.buckets += 1;
            // occlusion culling, away from the sensor: skip the bucket if every beam through
            // the box of its pieces already hits something no farther than the box
            if planar && dmin_b > 0.0 {
                // seen from outside, the box spans the angle between its two silhouette
                // corners (the others lie between them)
                let (p, q) = silhouette(sp.x, sp.y, x0, y0, x1, y1);
                let (a, b) = (to_sensor(p), to_sensor(q));
                let cr = cross2(a, b);
                let (j0, count) = self.wall_beams(a, b, cr);
                if cr != 0.0 && none_beyond(&out.ranges, j0, count, dmin_b) {
                    stats.buckets_occluded += 1;
                    continue;
                }
            }
            // the pieces that face the sensor, are tall enough and in range, without branches;
            // a class of axis-aligned one-sided pieces that all face away is not read at all
            // (a wall at x = w facing +x is seen only from x > w ≥ x0, and so on)
            let away = [sp.x <= x0, sp.x >= x1, sp.y <= y0, sp.y >= y1, false];
            cand.clear();
            cand.resize(pieces.len(), (0, 0.0));
            let (mut n, mut from) = (0, 0);
            for (class, &away) in away.iter().enumerate() {
                let to = class_ends.get(class).map_or(pieces.len(), |&e| e as usize);
                if !away {
                    stats.walls_visited += to - from;
                    for (k, pc) in pieces.iter().enumerate().take(to).skip(from) {
                        let faces = !pc.one_sided | (cross2([pc.b[0] - pc.a[0], pc.b[1] - pc.a[1]], [sp.x - pc.a[0], sp.y - pc.a[1]]) < 0.0);
                        // squared distance to the piece's box: a lower bound of the piece's
                        // (exact for the axis-aligned walls of grid maps), without division or root
                        let bx = (pc.p[0].min(pc.q[0]) - sp.x).max(0.0).max(sp.x - pc.p[0].max(pc.q[0]));
                        let by = (pc.p[1].min(pc.q[1]) - sp.y).max(0.0).max(sp.y - pc.p[1].max(pc.q[1]));
                        let box2 = bx * bx + by * by;
                        cand[n] = (k as u32, box2);
                        n += (faces & !(planar & (zs > pc.height)) & (box2 <= max2)) as usize;
                    }
                }
                from = to;
            }
            // their beams, side by side (independent, so the divisions and polynomials overlap)
            beams.clear();
            beams.extend(cand[..n].iter().map(|&(k, _)| {
                let pc = &pieces[k as usize];
                let (p, q) = (to_sensor(pc.p), to_sensor(pc.q));
                let cr = cross2(p, q);
                let (j0, count) = self.wall_beams(p, q, cr);
                (j0, count, cr == 0.0)
            }));
            for (&(k, box2), &(j0, count, collinear)) in cand[..n].iter().zip(&beams) {
                let pc = &pieces[k as usize];
                if collinear {
                    // collinear with the sensor (its beams above are not used)
                    stats.walls_swept += 1;
                    let (a, b, p, q) = (to_sensor(pc.a), to_sensor(pc.b), to_sensor(pc.p), to_sensor(pc.q));
                    self.sweep_piece(a, b, p, q, pc.height, box2.sqrt(), zs, &mut out.ranges);
                    continue;
                }
                // a planar beam that already hits no farther than the piece's box cannot change
                if planar && none_beyond_sq(&out.ranges, j0, count, box2) {
                    stats.walls_occluded += 1;
                    continue;
                }
                stats.walls_swept += 1;
                let (a, b) = (to_sensor(pc.a), to_sensor(pc.b));
                if planar {
                    self.sweep_flat(a, b, j0, count, &mut out.ranges);
                } else {
                    self.sweep(a, b, pc.height, j0, count, zs, box2.sqrt(), &mut out.ranges);
                }
            }
        }
        scratch.beams = beams;
        scratch.candidates = cand;
        scratch.stats = stats;
        self.indexed = scratch;
    }
}
