//! Latency distribution of single `Shield::filter` calls (points in, u* out), timed one by
//! one: median, p99.6 and max, per method (the paper's composite and the braking shield,
//! whose robot moves at 1 m/s), per N, planar and 3D, f32 scans in beam order, best SIMD level.
//!
//! `cargo bench -p shieldnav-core --bench shield_latency`

use shieldnav_core::shield::{BodyState, Scan, Shield, ShieldConfig, ShieldMethod, SimdLevel};
use std::hint::black_box;
use std::time::Instant;

#[path = "common.rs"]
mod common;
use common::{corridor_scan, SIZES};

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    // SHIELDNAV_SIMD=portable|avx2|avx512 pins the kernel's level (default: the best).
    let level = match std::env::var("SHIELDNAV_SIMD").as_deref() {
        Ok("portable") => SimdLevel::Portable,
        Ok("avx2") => SimdLevel::Avx2,
        Ok("avx512") => SimdLevel::Avx512,
        _ => SimdLevel::detect(),
    };
    println!("| method | dim | N | median µs | p99.6 µs | max µs | SIMD |");
    println!("|---|---|---:|---:|---:|---:|---|");
    for method in [ShieldMethod::Composite, ShieldMethod::Braking] {
        for dim in [2usize, 3] {
            for &n in &SIZES {
                let axes = if dim == 2 { vec![0.9, 0.45] } else { vec![0.9, 0.45, 0.3] };
                let mut s = Shield::new(ShieldConfig { semi_axes: axes, u_max: Some(vec![1.0; dim]), method, ..ShieldConfig::default() }).unwrap().with_simd_level(level).unwrap();
                // in beam order, as a LIDAR delivers them (the braking check skips blocks of
                // neighbouring beams beyond its sweeps)
                let mut rows: Vec<Vec<f64>> = corridor_scan(n, dim, 7).chunks(dim).map(|r| r.to_vec()).collect();
                rows.sort_by(|a, b| a[1].atan2(a[0]).total_cmp(&b[1].atan2(b[0])));
                let pts: Vec<f32> = rows.iter().flatten().map(|&v| v as f32).collect();
                let scan = Scan::new_f32(&pts, dim).unwrap();
                let st = if dim == 2 {
                    BodyState::planar(0.3, 0.2).unwrap().with_velocity([1.0, 0.0, 0.2]).unwrap()
                } else {
                    BodyState::spatial(shieldnav_core::math::rot_z(0.3), [0.0, 0.0, 0.2]).unwrap()
                };
                let u_nom = vec![0.8; dim];
                let calls = (2_000_000 / n).clamp(2_000, 100_000);
                for _ in 0..calls / 10 {
                    black_box(s.filter(&scan, &st, &u_nom).unwrap());
                }
                let mut t: Vec<u64> = (0..calls)
                    .map(|_| {
                        let t0 = Instant::now();
                        black_box(s.filter(black_box(&scan), &st, black_box(&u_nom)).unwrap());
                        t0.elapsed().as_nanos() as u64
                    })
                    .collect();
                t.sort_unstable();
                let q = |f: f64| t[((t.len() - 1) as f64 * f) as usize] as f64 / 1e3;
                println!("| {} | {dim} | {n} | {:.2} | {:.2} | {:.2} | {:?} |", method.name(), q(0.5), q(0.996), q(1.0), s.simd_level());
            }
        }
    }
}
