//! The brute-force sweep: every wall in range, nearest first, and the top faces of solids for
//! multi-channel scans.

use super::beams::Beams;
use super::config::Scan;
use super::numeric::seg_origin_distance;
use crate::math::Real;
use crate::world::{cross2, Pose2, Segment};

/// Reusable buffers of the brute-force sweep.
#[derive(Debug, Clone, Default)]
pub(crate) struct BruteScratch {
    /// Walls in range, in the sensor frame: `(distance, a, b, height)`, nearest first.
    visible: Vec<(Real, [Real; 2], [Real; 2], Real)>,
    /// Sort keys of `visible` (see [`Beams::sweep_walls`]).
    order: Vec<u64>,
    /// The edges of the solids found by [`Beams::sweep_tops`], in the sensor frame.
    top_edges: Vec<([Real; 2], [Real; 2])>,
}

impl Beams {
    /// The ranges of [`Lidar::scan_into`] before limits and noise.
    #[inline(always)]
    pub(crate) fn sweep_walls(&self, sc: &mut BruteScratch, walls: &[&[Segment]], sp: Pose2, out: &mut Scan) {
        let c = self.config;
        let kch = c.channels;
        let (s, co) = sp.yaw.sin_cos();
        let zs = c.mount.z;
        let mut visible = std::mem::take(&mut sc.visible);
        visible.clear();
        for slice in walls {
            for seg in slice.iter() {
                if (kch == 1 && zs > seg.height) || !seg.faces([sp.x, sp.y]) {
                    continue; // the level ring passes over this wall, or sees only its back
                }
                let (dxa, dya) = (seg.a[0] - sp.x, seg.a[1] - sp.y);
                let (dxb, dyb) = (seg.b[0] - sp.x, seg.b[1] - sp.y);
                // the distance to the wall's bounding box: a lower bound of the wall's (exact
                // for axis-aligned walls), all the order and the occluded-beam skip need
                let bx = dxa.min(dxb).max(0.0).max(-dxa.max(dxb));
                let by = dya.min(dyb).max(0.0).max(-dya.max(dyb));
                let dmin = (bx * bx + by * by).sqrt();
                if dmin <= c.max_range {
                    let a = [co * dxa + s * dya, -s * dxa + co * dya];
                    let b = [co * dxb + s * dyb, -s * dxb + co * dyb];
                    visible.push((dmin, a, b, seg.height));
                }
            }
        }
        // nearest first, so that occluded beams of farther walls are skipped by one compare:
        // sorted as keys, a distance's bits (ordered like the distance, which is ≥ 0) with the
        // low 16 replaced by the wall's place (the order only decides how much is skipped)
        let mut order = std::mem::take(&mut sc.order);
        order.clear();
        if visible.len() <= 1 << 16 {
            order.extend(visible.iter().enumerate().map(|(k, v)| (v.0.to_bits() & !0xFFFF) | k as u64));
            order.sort_unstable();
            for key in &order {
                let (dmin, a, b, height) = visible[(key & 0xFFFF) as usize];
                self.sweep_segment(a, b, height, dmin, zs, &mut out.ranges);
            }
        } else {
            visible.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
            for &(dmin, a, b, height) in &visible {
                self.sweep_segment(a, b, height, dmin, zs, &mut out.ranges);
            }
        }
        sc.order = order;
        sc.visible = visible;
    }

    /// The top faces of solids, for scans of more than one channel (a planar ring never looks
    /// down on one): a solid is a closed run of consecutive one-sided walls of one height, each
    /// ending where the next starts (or each starting where the next ends), running
    /// counter-clockwise around it (the solid on their left) — the edges of a polygon of a map
    /// and of a moving obstacle, as [`crate::world::Polygon::edges`] and
    /// [`crate::world::MovingObstacle::segments_at`] give them. Its top is the horizontal face at
    /// its height over the polygon: a beam descending from above it (mount higher than the
    /// solid) hits it at the exact ray–plane distance `(height − z) / tan(elevation)` (horizontal)
    /// wherever that point lies inside the polygon, and keeps the nearer of that and its wall
    /// hits. (A beam inside a solid's outline below its top has hit the top or a front face
    /// first, so its back faces, skipped, would never be the nearest hit.)
    pub(crate) fn sweep_tops(&self, sc: &mut BruteScratch, walls: &[&[Segment]], sp: Pose2, best: &mut [Real]) {
        let c = self.config;
        if c.channels == 1 {
            return;
        }
        let zs = c.mount.z;
        if !self.el_tan.iter().any(|&t| t < 0.0) {
            return;
        }
        let (s, co) = sp.yaw.sin_cos();
        let frame = |p: [Real; 2]| {
            let (dx, dy) = (p[0] - sp.x, p[1] - sp.y);
            [co * dx + s * dy, -s * dx + co * dy]
        };
        let mut edges = std::mem::take(&mut sc.top_edges);
        for slice in walls {
            let n = slice.len();
            let mut i = 0;
            while i < n {
                let first = slice[i];
                if !(first.one_sided && first.height < zs) {
                    i += 1;
                    continue;
                }
                // grow a chain of one-sided walls of the same height until it closes
                let mut j = i + 1;
                let mut forward: Option<bool> = None;
                let mut closed = false;
                while j < n {
                    let (prev, next) = (slice[j - 1], slice[j]);
                    let link_fwd = prev.b == next.a;
                    let link_bwd = prev.a == next.b;
                    let ok = next.one_sided
                        && next.height == first.height
                        && match forward {
                            None => link_fwd || link_bwd,
                            Some(true) => link_fwd,
                            Some(false) => link_bwd,
                        };
                    if !ok {
                        break;
                    }
                    if forward.is_none() {
                        forward = Some(link_fwd);
                    }
                    j += 1;
                    let last = slice[j - 1];
                    if j - i >= 3 && (if forward == Some(true) { last.b == first.a } else { last.a == first.b }) {
                        closed = true;
                        break;
                    }
                }
                if closed {
                    let run = &slice[i..j];
                    // twice the signed area: the solid on the walls' left is inside the loop
                    let area2: Real = run.iter().map(|w| cross2(w.a, w.b)).sum();
                    if area2 > 0.0 {
                        edges.clear();
                        edges.extend(run.iter().map(|w| (frame(w.a), frame(w.b))));
                        self.sweep_top(&edges, first.height, zs, best);
                    }
                    i = j;
                } else {
                    i = j.max(i + 1);
                }
            }
        }
        sc.top_edges = edges;
    }

    /// The top at `height` of one solid whose outline's `edges` (counter-clockwise, sensor
    /// frame) do not enclose the sensor (see [`Beams::sweep_tops`]).
    fn sweep_top(&self, edges: &[([Real; 2], [Real; 2])], height: Real, zs: Real, best: &mut [Real]) {
        let c = self.config;
        let n = c.columns;
        let dmin = edges.iter().map(|&(a, b)| seg_origin_distance(a, b)).fold(Real::INFINITY, Real::min);
        let dmax = edges.iter().map(|&(a, _)| (a[0] * a[0] + a[1] * a[1]).sqrt()).fold(0.0, Real::max);
        if dmin <= 0.0 || dmin > c.max_range {
            return; // the sensor is on the outline (not in free space), or it is out of range
        }
        let inside = |p: [Real; 2]| {
            let mut inside = false;
            for &(a, b) in edges {
                if (a[1] > p[1]) != (b[1] > p[1]) {
                    let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                    if p[0] < x {
                        inside = !inside;
                    }
                }
            }
            inside
        };
        for (k, &tan) in self.el_tan.iter().enumerate() {
            if tan >= 0.0 {
                continue;
            }
            // horizontal distance at which the beam is at the top's height
            let t = (height - zs) / tan;
            if !(t >= dmin && t <= dmax) {
                continue;
            }
            let r = t * self.el_sec[k];
            // every beam into the outline crosses an edge facing the sensor: their columns
            for &(a, b) in edges {
                let cr = cross2(a, b);
                if cr >= 0.0 {
                    continue; // seen from behind, or collinear with the sensor
                }
                let (j0, count) = self.wall_beams(a, b, cr);
                let mut i = (j0 & (n as i64 - 1)) as usize;
                for _ in 0..count {
                    let cell = &mut best[k * n + i];
                    if r < *cell && inside([t * self.az_cos[i], t * self.az_sin[i]]) {
                        *cell = r;
                    }
                    i = (i + 1) & (n - 1);
                }
            }
        }
    }
}
