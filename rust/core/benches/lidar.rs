//! LIDAR scan cost: planar 1024 columns in a 200-wall world, 32 × 1024 3D, and a preset.
//!
//! `cargo bench -p shieldnav-core --bench lidar`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shieldnav_core::sensors::{Lidar, LidarConfig, Scan, ScanMesh};
use shieldnav_core::world::{load_ros_map, preset, Pose2, RosMapOptions, Segment, SegmentIndex};

#[path = "common.rs"]
mod common;
use common::pacing;

/// Poses cycled through by a bench (none repeats within it: see [`pacing`]).
const POSES: usize = 4096;

/// 200 walls: a 20 × 20 m building outline cut into 2 m pieces (40 walls), 40 boxes
/// (160 walls), seeded. `solid_boxes`: box edges one-sided (as `StaticMap::add_polygon` stores
/// furniture), else all walls two-sided.
fn world_200(solid_boxes: bool) -> Vec<Segment> {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut w = Vec::new();
    for k in 0..10 {
        let (a, b) = (-10.0 + 2.0 * k as f64, -8.0 + 2.0 * k as f64);
        w.push(Segment::new([a, -10.0], [b, -10.0], 2.5));
        w.push(Segment::new([a, 10.0], [b, 10.0], 2.5));
        w.push(Segment::new([-10.0, a], [-10.0, b], 2.5));
        w.push(Segment::new([10.0, a], [10.0, b], 2.5));
    }
    while w.len() < 200 {
        let (cx, cy) = (rng.random_range(-9.0..9.0), rng.random_range(-9.0..9.0));
        if f64::hypot(cx, cy) < 1.5 {
            continue;
        }
        let (hx, hy) = (rng.random_range(0.1..0.6), rng.random_range(0.1..0.6));
        let v = [[cx - hx, cy - hy], [cx + hx, cy - hy], [cx + hx, cy + hy], [cx - hx, cy + hy]];
        for i in 0..4 {
            w.push(if solid_boxes { Segment::one_sided(v[i], v[(i + 1) % 4], 1.5) } else { Segment::new(v[i], v[(i + 1) % 4], 1.5) });
        }
    }
    w
}

fn bench(c: &mut Criterion) {
    let walls = world_200(false);
    let solid = world_200(true);
    assert_eq!(walls.len(), 200);
    let poses: Vec<Pose2> = pacing([-0.8, -0.4], [0.7, 0.35], 0.05, POSES, 1).into_iter().map(|[x, y, yaw]| Pose2::new(x, y, yaw)).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut scan = Scan::default();
    let mut g = c.benchmark_group("lidar");
    for (name, cfg) in [
        ("planar_1024_world200", LidarConfig { range_noise_std: 0.0, ..LidarConfig::default() }),
        ("planar_1024_world200_noise", LidarConfig::default()),
        ("3d_32x1024_world200", LidarConfig { channels: 32, range_noise_std: 0.0, ..LidarConfig::default() }),
    ] {
        let mut lidar = Lidar::new(cfg).unwrap();
        g.throughput(Throughput::Elements((cfg.channels * cfg.columns) as u64));
        let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
        let mut k = 0;
        g.bench_function(format!("{name}_indexed"), |b| {
            b.iter(|| {
                k = (k + 1) % poses.len();
                lidar.scan_indexed_into(black_box(&index), &[], poses[k], 0.0, &mut rng, &mut scan).unwrap();
                black_box(&scan.ranges);
            })
        });
        if cfg.channels == 1 {
            let mesh = ScanMesh::new(&walls).unwrap();
            let mut k = 0;
            g.bench_function(format!("{name}_walk"), |b| {
                b.iter(|| {
                    k = (k + 1) % poses.len();
                    lidar.scan_mesh_into(black_box(&mesh), &index, &[], poses[k], 0.0, &mut rng, &mut scan).unwrap();
                    black_box(&scan.ranges);
                })
            });
        }
        let mut k = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) % poses.len();
                lidar.scan_into(&[black_box(&walls)], poses[k], 0.0, &mut rng, &mut scan).unwrap();
                black_box(&scan.ranges);
            })
        });
    }
    let mut lidar = Lidar::new(LidarConfig { range_noise_std: 0.0, ..LidarConfig::default() }).unwrap();
    let mut k = 0;
    g.throughput(Throughput::Elements(1024));
    g.bench_function("planar_1024_world200_solid_boxes", |b| {
        b.iter(|| {
            k = (k + 1) % poses.len();
            lidar.scan_into(&[black_box(&solid)], poses[k], 0.0, &mut rng, &mut scan).unwrap();
            black_box(&scan.ranges);
        })
    });
    let (solid_index, solid_mesh) = (SegmentIndex::new(solid.clone(), 2.0).unwrap(), ScanMesh::new(&solid).unwrap());
    let mut k = 0;
    g.bench_function("planar_1024_world200_solid_boxes_walk", |b| {
        b.iter(|| {
            k = (k + 1) % poses.len();
            lidar.scan_mesh_into(black_box(&solid_mesh), &solid_index, &[], poses[k], 0.0, &mut rng, &mut scan).unwrap();
            black_box(&scan.ranges);
        })
    });
    let s = preset("odometry_jump").unwrap();
    let mut lidar = Lidar::new(LidarConfig { range_noise_std: 0.0, ..LidarConfig::default() }).unwrap();
    g.throughput(Throughput::Elements(1024));
    let mut k = 0;
    g.bench_function(format!("planar_1024_odometry_jump_{}walls", s.map.segments.len()), |b| {
        b.iter(|| {
            k = (k + 1) % 64;
            let p = Pose2::new(2.0 + 2.0 * k as f64, 0.1, 0.1 * k as f64);
            lidar.scan_into(&[black_box(&s.map.segments)], p, 0.0, &mut rng, &mut scan).unwrap();
            black_box(&scan.ranges);
        })
    });
    // real maps (walls of the start's region, as loaded): fetch the walls near the robot
    // from a bucket index, then scan
    let maps = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps");
    let mut dirs: Vec<_> = std::fs::read_dir(&maps).map(|d| d.flatten().map(|e| e.path()).filter(|p| p.is_dir()).collect()).unwrap_or_default();
    dirs.sort();
    if dirs.is_empty() {
        eprintln!("skipping the real maps: {} not found", maps.display());
    }
    for dir in dirs {
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let Some(yaml) = std::fs::read_dir(&dir).unwrap().flatten().map(|f| f.path()).find(|p| p.extension().is_some_and(|x| x == "yaml")) else { continue };
        let m = load_ros_map(&yaml, &RosMapOptions::default()).unwrap();
        for max_range in [10.0, 20.0] {
            let mut lidar = Lidar::new(LidarConfig { range_noise_std: 0.0, max_range, ..LidarConfig::default() }).unwrap();
            let index = SegmentIndex::new(m.scenario.map.segments.clone(), 2.0).unwrap();
            // a robot pacing the 0.75 m in front of the map's start
            let start = m.scenario.start;
            let poses: Vec<Pose2> = pacing([start.x, start.y], [start.x + 0.75, start.y], 0.02, POSES, 1).into_iter().map(|[x, y, yaw]| Pose2::new(x, y, yaw)).collect();
            let mut k = 0;
            g.bench_function(format!("planar_1024_{name}_{}walls_range{max_range}", m.scenario.map.segments.len()), |b| {
                b.iter(|| {
                    k = (k + 1) % POSES;
                    lidar.scan_indexed_into(black_box(&index), &[], poses[k], 0.0, &mut rng, &mut scan).unwrap();
                    black_box(&scan.ranges);
                })
            });
            // the same scans by walking a triangulation of the walls
            let mesh = ScanMesh::new(&m.scenario.map.segments).unwrap();
            let mut k = 0;
            g.bench_function(format!("planar_1024_{name}_{}walls_range{max_range}_walk", m.scenario.map.segments.len()), |b| {
                b.iter(|| {
                    k = (k + 1) % POSES;
                    lidar.scan_mesh_into(black_box(&mesh), &index, &[], poses[k], 0.0, &mut rng, &mut scan).unwrap();
                    black_box(&scan.ranges);
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
