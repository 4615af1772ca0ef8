//! Seeded scans shared by the shield benches: N points on the walls of a 2 m corridor (and a
//! 2.4 m high ceiling in 3D), all inside the 3.5 m crop so every point counts.
#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub const SIZES: [usize; 6] = [100, 400, 800, 1300, 5000, 20_000];

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
