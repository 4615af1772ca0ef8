//! Procedural site generation: one `generate()` call per iteration, office and tunnel, over a
//! cycle of 32 seeds (so the figure is an average over layouts, not one lucky site).
//!
//! `cargo bench -p shieldnav-core --bench generate`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use shieldnav_core::world::generate::{generate, GeneratorConfig, SiteKind};

/// Seeds cycled through by each bench.
const SEEDS: u64 = 32;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("generate");
    for (name, kind) in [("office", SiteKind::Office), ("tunnel", SiteKind::Tunnel)] {
        let cfg = GeneratorConfig { kind, ..GeneratorConfig::default() };
        let mut seed = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                seed = (seed + 1) % SEEDS;
                black_box(generate(black_box(seed), &cfg).unwrap());
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
