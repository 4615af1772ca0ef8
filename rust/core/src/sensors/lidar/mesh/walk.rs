//! The walk of a planar scan through the triangulation's cells.

use super::super::beams::Beams;
use super::super::config::Scan;
use super::super::numeric::{fast_atan2, iceil, seg_origin_distance};
use super::build::ScanMesh;
#[cfg(target_arch = "x86_64")]
use super::kernels::{atan2_rcp14, small_sweeps_avx512};
use super::tables::*;
use crate::math::Real;
use crate::simd::SimdLevel;
use crate::world::{cross2, sub2, Pose2, Segment};

impl Beams {
    /// The ranges of a planar scan of `mesh`'s walls from the sensor pose `sp` into `out`
    /// (every range `inf` before); `false` (ranges untouched) if the sensor stands on a line
    /// of the triangulation or outside it, or the scan is not planar.
    pub(crate) fn sweep_mesh(&self, scratch: &mut MeshScratch, mesh: &ScanMesh, sp: Pose2, out: &mut Scan) -> bool {
        scratch.stats = MeshScanStats::default();
        let ok = self.config.channels == 1
            && match self.simd {
                // SAFETY: `simd` is found from the CPU: it runs these instructions.
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx512 => unsafe { self.walk_avx512(mesh, sp, &mut out.ranges, scratch) },
                #[cfg(target_arch = "x86_64")]
                SimdLevel::Avx2 => unsafe { self.walk_avx2(mesh, sp, &mut out.ranges, scratch) },
                _ => self.walk::<false>(mesh, sp, &mut out.ranges, scratch),
            };
        scratch.stats.fell_back = !ok;
        ok
    }

    /// [`Lidar::walk`] built for AVX2 and FMA (the same ranges: no fused multiply-add is
    /// asked for).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn walk_avx2(&self, mesh: &ScanMesh, sp: Pose2, ranges: &mut [Real], sc: &mut MeshScratch) -> bool {
        self.walk::<false>(mesh, sp, ranges, sc)
    }

    /// [`Lidar::walk`] built for AVX-512: the same code and ranges, with 32 vector registers
    /// instead of 16, so that the walk's loop keeps its values in registers (5–6 % faster on
    /// the atrium of `ut_gdc_floor2`), and the angles of corners from a 14-bit reciprocal
    /// instead of a division (see [`atan2_rcp14`]; 3–5 % faster there).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq")]
    fn walk_avx512(&self, mesh: &ScanMesh, sp: Pose2, ranges: &mut [Real], sc: &mut MeshScratch) -> bool {
        self.walk::<true>(mesh, sp, ranges, sc)
    }

    /// The walk (see the module's doc); `RCP14`: the CPU runs AVX-512 (see [`atan2_rcp14`]).
    #[inline(always)]
    fn walk<const RCP14: bool>(&self, mesh: &ScanMesh, sp: Pose2, ranges: &mut [Real], sc: &mut MeshScratch) -> bool {
        let s = [sp.x, sp.y];
        let Some(t0) = mesh.locate(s) else {
            return false;
        };
        let c = self.config;
        let (ys, yc) = sp.yaw.sin_cos();
        let w = Walker { lidar: self, mesh, s, ys, yc, mask: c.columns as i64 - 1, r2: c.max_range * c.max_range, zs: c.mount.z, low: c.mount.z <= mesh.lowest, rcp14: RCP14 };
        // (`Lidar::new` builds the beam tables of `columns` beams, a power of two)
        debug_assert!(c.columns.is_power_of_two() && self.az_sin.len() == c.columns && self.az_cos.len() == c.columns);
        let n = c.columns as i64;
        let recast = &mut sc.recast;
        recast.clear();
        let stack = &mut sc.stack;
        stack.clear();
        let sweeps = &mut sc.sweeps;
        sweeps.clear();
        let stats = &mut sc.stats;
        // the start cell: its corners' columns, in turn counter-clockwise round the sensor
        let (cs, at) = mesh.corners(t0);
        let k = cs.len();
        let mut p = [[0.0; 2]; MAX_CORNERS + 1];
        let mut cols = [0i64; MAX_CORNERS + 1];
        for i in 0..k {
            p[i] = w.frame(cs[i]);
            cols[i] = w.col(p[i], recast);
            if i > 0 {
                let behind = cols[i - 1] - cols[i];
                if behind > 0 {
                    cols[i] += n * ((behind + n - 1) / n);
                }
            }
        }
        (p[k], cols[k]) = (p[0], cols[0] + n);
        for i in 0..k {
            if let Some(next) = w.edge(at + i, p[i], p[i + 1], cols[i], cols[i + 1], sweeps) {
                stack.push(next);
            }
        }
        let mut cur = stack.pop();
        let mut cells = 0;
        while let Some(win) = cur {
            cells += 1;
            let (cs, at) = mesh.corners_across(win.t);
            let k = cs.len();
            let e = win.e as usize;
            // out through the edges from corner e + 1 round to corner e: each takes the beams
            // up to (clockwise of) its far corner
            let (mut lo, j1) = (win.j0 as i64, win.j1 as i64);
            if j1 - lo == 1 {
                cur = w.one_beam(cs, at, e, &win, recast, sweeps).or_else(|| stack.pop());
                continue;
            }
            let mut from = win.pu;
            let mut i = if e + 1 == k { 0 } else { e + 1 };
            let mut next: Option<Window> = None;
            loop {
                let i1 = if i + 1 == k { 0 } else { i + 1 };
                let (to, m) = if i1 == e {
                    (win.pv, j1)
                } else {
                    // SAFETY: `i1 < k`, a corner of the cell
                    let to = w.frame(unsafe { *cs.get_unchecked(i1) });
                    (to, w.split(to, lo, j1, recast))
                };
                if let Some(out) = w.edge(at + i, from, to, lo, m, sweeps) {
                    match next {
                        None => next = Some(out),
                        Some(_) => stack.push(out),
                    }
                }
                if m >= j1 {
                    break;
                }
                (lo, from, i) = (m, to, i1);
            }
            // on through one side at once, the others later
            cur = next.or_else(|| stack.pop());
        }
        stats.cells = cells;
        match self.simd {
            // SAFETY: `simd` is found from the CPU: it runs these instructions.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => unsafe { self.sweep_walked_avx512(&w, ranges, sc) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => unsafe { self.sweep_walked_avx2(&w, ranges, sc) },
            _ => self.sweep_walked_portable(&w, ranges, sc),
        }
        true
    }

    /// [`Lidar::sweep_walked`] built for AVX-512 (the same ranges).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq")]
    #[inline(never)]
    fn sweep_walked_avx512(&self, w: &Walker, ranges: &mut [Real], sc: &mut MeshScratch) {
        self.sweep_walked(w, ranges, sc);
    }

    /// [`Lidar::sweep_walked`] built for AVX2 and FMA (the same ranges: no fused multiply-add
    /// is asked for).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline(never)]
    fn sweep_walked_avx2(&self, w: &Walker, ranges: &mut [Real], sc: &mut MeshScratch) {
        self.sweep_walked(w, ranges, sc);
    }

    /// [`Lidar::sweep_walked`] for any CPU.
    #[inline(never)]
    fn sweep_walked_portable(&self, w: &Walker, ranges: &mut [Real], sc: &mut MeshScratch) {
        self.sweep_walked(w, ranges, sc);
    }

    /// After the walk: the beams of each wall edge reached, with its walls' exact hits, and
    /// the beams through a corner or missed cast again against every wall (out of the walk's
    /// function, so that the code after it does not change how its loop is built: with the
    /// small sweeps' code inside it, the loop ran 6–9 % slower on `ut_gdc_floor2`; built for
    /// the CPU as the walk is, so that the sweep of each wall is inlined).
    #[inline(always)]
    fn sweep_walked(&self, w: &Walker, ranges: &mut [Real], sc: &mut MeshScratch) {
        let mesh = w.mesh;
        let (sweeps, recast) = (&sc.sweeps, &mut sc.recast);
        // the beams of each wall edge reached, with its walls' exact hits (after the walk, so
        // that its loop stays small), and those the walls missed marked for recasting
        // (with AVX-512 the sweeps of a few beams first, eight beams at once; the others listed
        // in `big`)
        let mut missed = false;
        let big = &mut sc.big;
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
        let mut batched = false;
        #[cfg(target_arch = "x86_64")]
        if self.simd == SimdLevel::Avx512 && sweeps.len() < 1 << 24 {
            // SAFETY: the CPU runs AVX-512 (`simd`); under 2^24 sweeps (indices times six
            // within an `i32`)
            missed = unsafe { small_sweeps_avx512(sweeps, &mut sc.jobs, big, w.mask, &self.az_cos, &self.az_sin, ranges) };
            batched = true;
        }
        if !batched {
            big.clear();
            big.extend(0..sweeps.len() as u32);
        }
        for sw in big.iter().map(|&i| &sweeps[i as usize]) {
            let (j0, count) = (sw.j0 as i64, (sw.j1 - sw.j0) as usize);
            if sw.edge == NONE {
                // (its ends as the walk transformed them, the wall's own)
                missed |= self.sweep_flat(sw.a, sw.b, j0, count, ranges);
                continue;
            }
            for seg in mesh.walls_on(sw.edge as usize) {
                if w.blocks(seg) {
                    missed |= self.sweep_flat(w.frame(seg.a), w.frame(seg.b), j0, count, ranges);
                }
            }
        }
        if missed {
            // (rare: a beam may also have been missed by one wall of an edge and hit by another)
            for sw in sweeps.iter() {
                for j in sw.j0..sw.j1 {
                    let i = (j as i64 & w.mask) as usize;
                    if ranges[i] == Real::INFINITY {
                        recast.push(i as u32);
                    }
                }
            }
        }
        // beams through a corner, or missed by the wall they crossed: against every wall
        recast.sort_unstable();
        recast.dedup();
        (sc.stats.walls_swept, sc.stats.beams_recast) = (sweeps.len(), recast.len());
        // (a beam along a wall's line, within rounding, gets from its hit test a quotient of
        // two roundings: a "hit" nearer than the wall itself is no hit, as the other scans,
        // which skip a wall no nearer than the beam's range so far, never see it)
        for &i in recast.iter() {
            let i = i as usize;
            let mut best = Real::INFINITY;
            for seg in mesh.segments.iter().filter(|seg| w.blocks(seg)) {
                let (a, b) = (w.frame(seg.a), w.frame(seg.b));
                ranges[i] = Real::INFINITY;
                self.sweep(a, b, seg.height, i as i64, 1, w.zs, -1.0, ranges);
                let t = ranges[i];
                if t < best && t >= seg_origin_distance(a, b) * (1.0 - 1e-9) {
                    best = t;
                }
            }
            ranges[i] = best;
        }
    }
}

/// How near (m) a beam passes a corner of the triangulation to be cast again against every
/// wall: far above the rounding of any hit test (about 1e-16 of the distances involved), far
/// below the gap between beams.
const NEAR: Real = 1e-9;

/// Marks beams `i` and `k` (unless [`NONE`]) for recasting: rare, kept out of the walk's loop.
#[cold]
#[inline(never)]
fn mark(recast: &mut Vec<u32>, i: u32, k: u32) {
    recast.push(i);
    if k != NONE {
        recast.push(k);
    }
}

/// One scan's walk (see [`Lidar::walk`]).
struct Walker<'a> {
    lidar: &'a Beams,
    mesh: &'a ScanMesh,
    /// The sensor's place, and its yaw's sine and cosine.
    s: [Real; 2],
    ys: Real,
    yc: Real,
    /// Columns less one (a power of two less one).
    mask: i64,
    /// The squared range.
    r2: Real,
    /// The sensor's height.
    zs: Real,
    /// Whether the sensor is no higher than the lowest wall (see [`WHOLE`]).
    low: bool,
    /// Whether the CPU runs AVX-512: corners' angles by [`atan2_rcp14`] (a constant in each
    /// build of the walk).
    rcp14: bool,
}

impl Walker<'_> {
    /// Whether wall `seg` stops the planar ring's beams: it stands higher than the sensor and
    /// faces it.
    #[inline(always)]
    fn blocks(&self, seg: &Segment) -> bool {
        self.zs <= seg.height && seg.faces(self.s)
    }

    /// The world point `p` in the sensor's frame (as the other scans compute it).
    #[inline(always)]
    fn frame(&self, p: [Real; 2]) -> [Real; 2] {
        let (dx, dy) = (p[0] - self.s[0], p[1] - self.s[1]);
        [self.yc * dx + self.ys * dy, -self.ys * dx + self.yc * dy]
    }

    /// `p × d_j`: ≥ 0 if beam `j` is at or counter-clockwise of `p` (within half a turn).
    #[inline(always)]
    fn side(&self, p: [Real; 2], j: i64) -> Real {
        let i = (j & self.mask) as usize;
        // SAFETY: the beam tables hold `mask + 1` beams (`Lidar::new`).
        unsafe { p[0] * *self.lidar.az_sin.get_unchecked(i) - p[1] * *self.lidar.az_cos.get_unchecked(i) }
    }

    /// Marks for recasting beams `j - 1` and `j` if they pass within [`NEAR`] of `p`: there
    /// the other scans' hit tests may round a wall's end point either way.
    #[inline(always)]
    fn near(&self, p: [Real; 2], j: i64, recast: &mut Vec<u32>) {
        for j in [j - 1, j] {
            if self.side(p, j).abs() <= NEAR {
                mark(recast, (j & self.mask) as u32, NONE);
            }
        }
    }

    /// The first column at or counter-clockwise of `p` (sensor frame), near its angle: from
    /// the angle (within 1.1e-5 rad, or 7.3e-5 with AVX-512's reciprocal, far below a beam
    /// step), set right by the beams beside it.
    #[inline(always)]
    fn column(&self, p: [Real; 2]) -> i64 {
        #[cfg(target_arch = "x86_64")]
        let angle = if self.rcp14 { atan2_rcp14(p[1], p[0]) } else { fast_atan2(p[1], p[0]) };
        #[cfg(not(target_arch = "x86_64"))]
        let angle = fast_atan2(p[1], p[0]);
        let j = iceil(angle * self.lidar.inv_step);
        if self.side(p, j) < 0.0 {
            j + 1
        } else if self.side(p, j - 1) >= 0.0 {
            j - 1
        } else {
            j
        }
    }

    /// [`Walker::column`], the beams beside `p` marked for recasting if near it.
    #[inline(always)]
    fn col(&self, p: [Real; 2], recast: &mut Vec<u32>) -> i64 {
        let j = self.column(p);
        self.near(p, j, recast);
        j
    }

    /// The first column of `j0..j1` at or counter-clockwise of `p` (`j1` if none); `p` and
    /// the beams lie within half a turn of each other.
    #[inline(always)]
    fn split(&self, p: [Real; 2], j0: i64, j1: i64, recast: &mut Vec<u32>) -> i64 {
        // the end beams first, both at once: most windows leave whole by one side (one branch
        // to foresee instead of two)
        let (first, last) = (self.side(p, j0), self.side(p, j1 - 1));
        if (first >= 0.0) | (last < 0.0) {
            if (first.abs() <= NEAR) | (last.abs() <= NEAR) {
                mark(recast, (j0 & self.mask) as u32, ((j1 - 1) & self.mask) as u32);
            }
            return if first >= 0.0 { j0 } else { j1 };
        }
        // beam j0 is clockwise of p, beam j1 - 1 at or counter-clockwise of it
        let m = if j1 - j0 <= 8 {
            let mut m = j0 + 1;
            for j in j0 + 1..j1 - 1 {
                m += (self.side(p, j) < 0.0) as i64;
            }
            m
        } else {
            // (the column taken to the window's turn; within the window by the tests above)
            let n = self.mask + 1;
            let m = self.column(p);
            (m + n * (((j0 + j1) >> 1) - m + n / 2).div_euclid(n)).clamp(j0 + 1, j1 - 1)
        };
        self.near(p, m, recast);
        m
    }

    /// The walk of a window of one beam (`win`, into the cell of corners `cs`, the first at
    /// `at`, through its edge `e`): out through the edge whose far corner the beam passes
    /// clockwise of, the beam marked for recasting if it passes near a corner tested, as the
    /// edges one by one find it (see [`Lidar::walk`]), with one test per corner instead of
    /// [`Walker::split`]'s two, and without its third outcome (a split window). A third of
    /// the windows entering cells on the atrium of `ut_gdc_floor2` at 20 m are of one beam; the
    /// scan there took 5 % less (14.50 against 15.25–15.30 µs; the same test inside `split`
    /// saved 1–2 %).
    #[inline(always)]
    fn one_beam(&self, cs: &[[Real; 2]], at: usize, e: usize, win: &Window, recast: &mut Vec<u32>, sweeps: &mut Vec<Sweep>) -> Option<Window> {
        let k = cs.len();
        let j = win.j0 as i64;
        let b = (j & self.mask) as usize;
        // SAFETY: the beam tables hold `mask + 1` beams (`Lidar::new`)
        let (sin, cos) = unsafe { (*self.lidar.az_sin.get_unchecked(b), *self.lidar.az_cos.get_unchecked(b)) };
        let mut from = win.pu;
        let mut i = if e + 1 == k { 0 } else { e + 1 };
        loop {
            let i1 = if i + 1 == k { 0 } else { i + 1 };
            if i1 == e {
                return self.edge(at + i, from, win.pv, j, j + 1, sweeps);
            }
            // SAFETY: `i1 < k`, a corner of the cell
            let to = self.frame(unsafe { *cs.get_unchecked(i1) });
            // (as `Walker::side`)
            let side = to[0] * sin - to[1] * cos;
            if side.abs() <= NEAR {
                mark(recast, b as u32, NONE);
            }
            if side < 0.0 {
                return self.edge(at + i, from, to, j, j + 1, sweeps);
            }
            (from, i) = (to, i1);
        }
    }

    /// The beams `j0..j1` crossing the corner edge `g` (see [`ScanMesh::link`]; its ends `p`,
    /// `q` in the sensor frame, clockwise end first as the sensor sees it): listed in `sweeps`
    /// (swept after the walk) if a wall there blocks them, else the window into the next cell.
    #[inline(always)]
    fn edge(&self, g: usize, p: [Real; 2], q: [Real; 2], j0: i64, j1: i64, sweeps: &mut Vec<Sweep>) -> Option<Window> {
        if j0 >= j1 {
            return None;
        }
        let (dp, dq) = (p[0] * p[0] + p[1] * p[1], q[0] * q[0] + q[1] * q[1]);
        if dp > self.r2 && dq > self.r2 {
            let e = sub2(q, p);
            let cr = cross2(p, e);
            if cr * cr > self.r2 * (e[0] * e[0] + e[1] * e[1]) {
                return None; // the edge's line is out of range
            }
        }
        let link = self.mesh.link(g);
        if link & LINK_WALL != 0 {
            let kind = (link >> LINK_KIND) & 3;
            if self.low && kind != 0 {
                // one wall, the whole edge: it blocks the beams if it faces the cell, as the
                // sensor, on the cell's side of the edge's line, sees it then
                if kind != BEHIND {
                    let (a, b) = if kind == WHOLE { (p, q) } else { (q, p) };
                    sweeps.push(Sweep { a, b, j0: j0 as i32, j1: j1 as i32, edge: NONE });
                    return None;
                }
            } else if self.mesh.walls_on(g).any(|seg| self.blocks(seg)) {
                sweeps.push(Sweep { a: p, b: q, j0: j0 as i32, j1: j1 as i32, edge: g as u32 });
                return None;
            }
        }
        let nb = link & LINK_CELL;
        (nb != 0).then_some(Window { pv: q, pu: p, j0: j0 as i32, j1: j1 as i32, t: self.mesh.across(g), e: (link >> LINK_BACK) & 15 })
    }
}
