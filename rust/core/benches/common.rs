//! Shared by the benches (and the `lidar_maps` example): seeded scans for the shield benches, N
//! points on the walls of a 2 m corridor (and a 2.4 m high ceiling in 3D), all inside the
//! 3.5 m crop so every point counts; seeded poses for the LIDAR's.
#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Points per scan in the shield benches.
pub const SIZES: [usize; 6] = [100, 400, 800, 1300, 5000, 20_000];

/// `n` points (`dim` 2 or 3 coordinates each, flat) on a 2 m corridor's walls, seeded.
pub fn corridor_scan(n: usize, dim: usize, seed: u64) -> Vec<f64> {
    let mut g = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n * dim);
    for _ in 0..n {
        let x: f64 = g.random_range(-3.0..3.0);
        let side = if g.random_bool(0.5) { 1.0 } else { -1.0 };
        let y = side * (1.0 + g.random_range(-0.02..0.02));
        out.extend_from_slice(&[x, y]);
        if dim == 3 {
            out.push(g.random_range(-0.4..1.0));
        }
    }
    out
}

/// `n` poses `[x, y, yaw]` of a robot pacing the segment from `a` to `b` (turning back at its
/// ends), seeded: each step along it by up to 0.1 m (1 m/s at 10 Hz), off it by up to `side`,
/// its heading turned by up to 0.2 rad. None repeats: scans cycling through a few poses let the
/// CPU's branch predictors learn the cycle, and ran 10–30 % faster than these.
pub fn pacing(a: [f64; 2], b: [f64; 2], side: f64, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut g = ChaCha8Rng::seed_from_u64(seed);
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    let len = ex.hypot(ey);
    let (ux, uy) = (ex / len, ey / len);
    let (mut s, mut dir, mut yaw) = (0.0, 1.0, 0.0);
    (0..n)
        .map(|_| {
            s += dir * g.random_range(0.0..0.1);
            if s > len {
                (s, dir) = (2.0 * len - s, -dir);
            }
            if s < 0.0 {
                (s, dir) = (-s, -dir);
            }
            yaw = (yaw + g.random_range(-0.2..0.2)) % std::f64::consts::TAU;
            let o = g.random_range(-side..=side);
            [a[0] + s * ux - o * uy, a[1] + s * uy + o * ux, yaw]
        })
        .collect()
}
