//! One environment step of each paper scenario, of a procedural site and of the real map of
//! `MapInspection-v0`: the whole pipeline
//! (action → shield on the compensated scan → tracker and physics → LIDAR at 10 Hz → coverage,
//! reward, metrics) plus the flat observation, with seeded random actions cycled.
//!
//! `cargo bench -p shieldnav-core --bench episode`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shieldnav_core::env::{Episode, EpisodeConfig, Site};
use shieldnav_core::world::generate::GeneratorConfig;
use shieldnav_core::world::{load_ros_map, RosMapOptions};

fn bench(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let actions: Vec<[f64; 3]> = (0..4096).map(|_| [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)]).collect();
    let mut g = c.benchmark_group("episode_step");
    g.throughput(Throughput::Elements(1));
    let mut sites = vec![
        ("constricted_passage".to_string(), Site::Preset("constricted_passage".into())),
        ("dynamic_obstacles".to_string(), Site::Preset("dynamic_obstacles".into())),
        ("procedural_office".to_string(), Site::Procedural(GeneratorConfig::default())),
    ];
    // MapInspection's default map (MIT Building 31), if the shared maps are beside the repository
    let yaml = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps/mit_building31/building_31.yaml");
    match load_ros_map(&yaml, &RosMapOptions::default()) {
        Ok(m) => sites.push((format!("map_mit_building31_{}walls", m.scenario.map.segments.len()), Site::Scenario(Box::new(m.scenario)))),
        Err(e) => eprintln!("skipping the real map: {e}"),
    }
    for (name, site) in sites {
        // random actions never finish an inspection: no reset inside a measurement
        let cfg = EpisodeConfig::default();
        let mut ep = Episode::new(site, cfg, 1).unwrap();
        let mut obs = vec![0f32; ep.observation_len()];
        let mut k = 0usize;
        g.bench_function(name, |b| {
            b.iter(|| {
                let r = ep.step(actions[k & 4095]).unwrap();
                ep.observe(&mut obs).unwrap();
                k += 1;
                if r.terminated || r.truncated {
                    ep.reset(k as u64).unwrap();
                }
                black_box(&obs);
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
