//! Criterion benches of the whole `Shield::filter` call (points in, u* out) over
//! N = 100 … 20,000, planar and 3D, f32 and f64 scans, every SIMD level this CPU has, and the
//! distance baseline's N-row Clarabel QP side by side.
//!
//! `cargo bench -p shieldnav-core --bench shield`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use shieldnav_core::shield::{BodyState, Scan, Shield, ShieldConfig, ShieldMethod, SimdLevel};
use std::hint::black_box;
use std::time::Duration;

#[path = "common.rs"]
mod common;
use common::{corridor_scan, SIZES};

fn shield(dim: usize, method: ShieldMethod, level: SimdLevel) -> Shield {
    let axes = if dim == 2 { vec![0.9, 0.45] } else { vec![0.9, 0.45, 0.3] };
    Shield::new(ShieldConfig { semi_axes: axes, method, u_max: Some(vec![1.0; dim]), ..ShieldConfig::default() }).unwrap().with_simd_level(level).unwrap()
}

fn state(dim: usize) -> BodyState {
    if dim == 2 {
        BodyState::planar(0.3, 0.2).unwrap()
    } else {
        BodyState::spatial(shieldnav_core::math::rot_z(0.3), [0.0, 0.0, 0.2]).unwrap()
    }
}

fn composite(c: &mut Criterion) {
    let mut levels = vec![SimdLevel::detect()];
    if SimdLevel::detect() != SimdLevel::Portable {
        levels.push(SimdLevel::Portable);
    }
    for dim in [2usize, 3] {
        for level in &levels {
            for precision in ["f32", "f64"] {
                let name = format!("composite_{}_{precision}_{:?}", if dim == 2 { "planar" } else { "3d" }, level).to_lowercase();
                let mut group = c.benchmark_group(name);
                group.warm_up_time(Duration::from_millis(300)).measurement_time(Duration::from_secs(1));
                for &n in &SIZES {
                    let pts = corridor_scan(n, dim, n as u64);
                    let pts32: Vec<f32> = pts.iter().map(|&v| v as f32).collect();
                    let mut s = shield(dim, ShieldMethod::Composite, *level);
                    let st = state(dim);
                    let u_nom = vec![0.8; dim];
                    group.throughput(Throughput::Elements(n as u64));
                    group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
                        if precision == "f32" {
                            let scan = Scan::new_f32(&pts32, dim).unwrap();
                            b.iter(|| s.filter(black_box(&scan), &st, black_box(&u_nom)).unwrap())
                        } else {
                            let scan = Scan::new_f64(&pts, dim).unwrap();
                            b.iter(|| s.filter(black_box(&scan), &st, black_box(&u_nom)).unwrap())
                        }
                    });
                }
                group.finish();
            }
        }
    }
}

fn distance(c: &mut Criterion) {
    let mut group = c.benchmark_group("distance_clarabel_planar_f64");
    group.sample_size(10).warm_up_time(Duration::from_millis(200)).measurement_time(Duration::from_secs(2));
    for &n in &SIZES {
        let pts = corridor_scan(n, 2, n as u64);
        let mut s = shield(2, ShieldMethod::Distance, SimdLevel::detect());
        let st = state(2);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            let scan = Scan::new_f64(&pts, 2).unwrap();
            b.iter(|| s.filter(black_box(&scan), &st, black_box(&[0.8, 0.8])).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, composite, distance);
criterion_main!(benches);
