use super::numeric::{fast_atan2, iceil, ifloor};
use super::*;
use crate::math::Real;
use crate::simd::SimdLevel;
use crate::world::cross2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[test]
fn fast_atan2_is_within_its_bound() {
    let mut worst: Real = 0.0;
    for k in 0..100_000 {
        let a = k as Real * 1e-4 * std::f64::consts::TAU / 10.0 - 3.2;
        let (y, x) = (a.sin() * 3.7, a.cos() * 3.7);
        worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
    }
    assert!(worst < 2e-5, "worst {worst}");
}

/// The AVX2 and AVX-512 builds of the indexed scan, and the pieces' beams computed eight
/// at once instead of four, give the portable build's ranges, bit for bit, on a generated
/// site and (when `../shared/maps` is beside the repository) on the most cluttered real map.
#[cfg(target_arch = "x86_64")]
#[test]
fn vector_scans_equal_portable_scans() {
    use crate::world::generate::{generate, GeneratorConfig};
    use crate::world::{load_ros_map, RosMapOptions, SegmentIndex};
    let best = SimdLevel::detect();
    if best == SimdLevel::Portable {
        eprintln!("SKIPPED: no AVX2 on this CPU");
        return;
    }
    if best != SimdLevel::Avx512 {
        eprintln!("AVX-512 build not tested: not on this CPU");
    }
    let site = generate(4, &GeneratorConfig::default()).unwrap();
    let mut worlds = vec![("generated", site.scenario.map.segments, site.waypoints.iter().take(12).copied().collect::<Vec<_>>())];
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps/g4s_office");
    let yaml = std::fs::read_dir(&dir).map(|d| d.flatten().map(|e| e.path()).find(|p| p.extension().is_some_and(|x| x == "yaml"))).ok().flatten();
    if let Some(yaml) = yaml {
        let m = load_ros_map(&yaml, &RosMapOptions::default()).unwrap();
        let s = m.scenario.start;
        worlds.push(("g4s_office", m.scenario.map.segments, (0..12).map(|k| [s.x + 0.3 * k as Real, s.y - 0.1 * k as Real]).collect()));
    } else {
        eprintln!("real map skipped: no map in {}", dir.display());
    }
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for (name, walls, points) in worlds {
        let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
        let mesh = ScanMesh::new(&walls).unwrap();
        for channels in [1, 16] {
            let mut l = Lidar::new(LidarConfig { channels, range_noise_std: 0.0, ..Default::default() }).unwrap();
            for (k, w) in points.iter().enumerate() {
                let pose = Pose2::new(w[0] + rng.random_range(-0.2..0.2), w[1], 0.7 * k as Real);
                let mut scans: Vec<Scan> = (0..4).map(|_| Scan::default()).collect();
                for s in scans.iter_mut() {
                    l.beams.begin_scan(pose, 0.0, s).unwrap();
                }
                let sp = l.sensor_pose(pose);
                l.beams.simd = SimdLevel::Portable;
                l.beams.sweep_index::<4>(&mut l.indexed, &index, &[], sp, &mut scans[0]);
                // (eight pieces at once, as the AVX-512 build does, on any CPU)
                l.beams.sweep_index::<8>(&mut l.indexed, &index, &[], sp, &mut scans[3]);
                l.beams.simd = SimdLevel::Avx2;
                // SAFETY: this CPU runs AVX2 and FMA (`best` is not `Portable`).
                unsafe { l.beams.sweep_index_avx2(&mut l.indexed, &index, &[], sp, &mut scans[1]) };
                let bits = |s: &Scan| s.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>();
                assert!(scans[0].ranges.iter().filter(|r| r.is_finite()).count() > 300 * channels);
                assert_eq!(bits(&scans[0]), bits(&scans[1]), "{name}: AVX2, {channels} channels, pose {k}");
                assert_eq!(bits(&scans[0]), bits(&scans[3]), "{name}: eight pieces at once, {channels} channels, pose {k}");
                if channels == 1 {
                    // the walk of the triangulation, portable and built for AVX2 and
                    // AVX-512
                    for simd in [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512].into_iter().filter(|&s| s != SimdLevel::Avx512 || best == SimdLevel::Avx512) {
                        l.beams.simd = simd;
                        let mut s = Scan::default();
                        l.beams.begin_scan(pose, 0.0, &mut s).unwrap();
                        assert!(l.beams.sweep_mesh(&mut l.mesh, &mesh, sp, &mut s), "{name}: pose {k} off the triangulation");
                        // (before the range limits: the walk may keep a hit beyond the
                        // range where the index never swept that wall)
                        let max = l.beams.config.max_range;
                        let clip = |r: Real| if r <= max { r.to_bits() } else { Real::INFINITY.to_bits() };
                        let diff: Vec<_> = (0..s.ranges.len()).filter(|&i| clip(scans[0].ranges[i]) != clip(s.ranges[i])).map(|i| (i, scans[0].ranges[i], s.ranges[i])).take(6).collect();
                        assert!(diff.is_empty(), "{name}: the walk ({simd:?}), pose {k}: {diff:?}");
                    }
                }
                if best == SimdLevel::Avx512 {
                    l.beams.simd = SimdLevel::Avx512;
                    // SAFETY: this CPU runs AVX-512.
                    unsafe { l.beams.sweep_index_avx512(&mut l.indexed, &index, &[], sp, &mut scans[2]) };
                    assert_eq!(bits(&scans[0]), bits(&scans[2]), "{name}: AVX-512, {channels} channels, pose {k}");
                }
                // and the limits, noise, dropout and points alike
                let mut noisy = Lidar::new(LidarConfig { channels, range_noise_std: 0.05, dropout: 0.1, max_range: 8.0, ..Default::default() }).unwrap();
                let mut done: Vec<Scan> = Vec::new();
                for simd in [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512].into_iter().filter(|&s| s != SimdLevel::Avx512 || best == SimdLevel::Avx512) {
                    noisy.beams.simd = simd;
                    let mut s = scans[0].clone();
                    noisy.beams.finish(&mut ChaCha8Rng::seed_from_u64(k as u64), &mut s);
                    done.push(s);
                }
                let point_bits = |s: &Scan| s.points.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert!(done[0].ranges.iter().any(|r| r.is_finite()) && done[0].ranges.iter().any(|r| r.is_infinite()));
                for s in &done[1..] {
                    assert_eq!((bits(&done[0]), point_bits(&done[0])), (bits(s), point_bits(s)), "{name}: finished, {channels} channels, pose {k}");
                }
            }
        }
    }
}

/// The planar sweep four beams at once gives the beam-by-beam sweep's ranges, bit for bit:
/// walls at any angle and axis-aligned ones (beams parallel to them), near and far, over
/// ranges already partly filled, without and across the wrap at column 0.
#[cfg(target_arch = "x86_64")]
#[test]
fn vector_planar_sweep_equals_portable_sweep() {
    if SimdLevel::detect() == SimdLevel::Portable {
        eprintln!("SKIPPED: no AVX2 on this CPU");
        return;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut l = Lidar::new(LidarConfig { range_noise_std: 0.0, ..Default::default() }).unwrap();
    let mut parallel = 0;
    for trial in 0..20_000 {
        let mut a = [rng.random_range(-6.0..6.0), rng.random_range(-6.0..6.0)];
        if trial % 8 == 0 {
            // a horizontal wall nearly through the sensor: the beams along it are in its
            // interval's slack
            a[1] = rng.random_range(-1e-5..1e-5);
        }
        let b = match trial % 4 {
            0 => [a[0] + rng.random_range(-3.0..3.0), a[1]],
            1 => [a[0], a[1] + rng.random_range(-3.0..3.0)],
            _ => [a[0] + rng.random_range(-3.0..3.0), a[1] + rng.random_range(-3.0..3.0)],
        };
        let cr = cross2(a, b);
        if cr == 0.0 {
            continue;
        }
        let (j0, count) = l.beams.wall_beams(a, b, cr);
        parallel += (0..count).any(|k| {
            let i = (j0 + k as i64).rem_euclid(1024) as usize;
            l.beams.az_cos[i] * (b[1] - a[1]) - l.beams.az_sin[i] * (b[0] - a[0]) == 0.0
        }) as usize;
        let start: Vec<Real> = (0..1024).map(|_| if rng.random_bool(0.3) { Real::INFINITY } else { rng.random_range(0.1..8.0) }).collect();
        let (mut portable, mut vector) = (start.clone(), start);
        l.beams.simd = SimdLevel::Portable;
        let portable_missed = l.beams.sweep_flat(a, b, j0, count, &mut portable);
        l.beams.simd = SimdLevel::Avx2;
        let vector_missed = l.beams.sweep_flat(a, b, j0, count, &mut vector);
        let bits = |v: &[Real]| v.iter().map(|r| r.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&portable), bits(&vector), "wall {a:?} {b:?}, beams {j0} + {count}");
        // whether a swept beam is left without a range, from either build
        let missed = (0..count).any(|k| portable[(j0 + k as i64).rem_euclid(1024) as usize] == Real::INFINITY);
        assert_eq!((portable_missed, vector_missed), (missed, missed), "wall {a:?} {b:?}, beams {j0} + {count}");
    }
    assert!(parallel > 100, "{parallel} walls with a parallel beam");
}

#[test]
fn ifloor_and_iceil_equal_floor_and_ceil() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut xs: Vec<Real> = vec![0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 2.5, 3.0, -3.0, 1e-300, -1e-300, 4095.999999, -4096.0000001, 1e15 + 0.5, -(1e15 + 0.5)];
    xs.extend((0..100_000).map(|_| rng.random_range(-5000.0..5000.0)));
    xs.extend((0..1000).map(|k| k as Real * 0.25 - 100.0));
    for x in xs {
        assert_eq!(ifloor(x), x.floor() as i64, "floor {x}");
        assert_eq!(iceil(x), x.ceil() as i64, "ceil {x}");
    }
}

#[test]
fn invalid_configs_name_the_field() {
    for (cfg, field) in [
        (LidarConfig { channels: 8, ..Default::default() }, "channels"),
        (LidarConfig { columns: 1000, ..Default::default() }, "columns"),
        (LidarConfig { max_range: 0.05, ..Default::default() }, "max_range"),
        (LidarConfig { dropout: 1.0, ..Default::default() }, "dropout"),
        (LidarConfig { rate_hz: 5.0, ..Default::default() }, "rate_hz"),
        (LidarConfig { range_noise_std: Real::NAN, ..Default::default() }, "range_noise_std"),
    ] {
        let e = Lidar::new(cfg).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    }
}

#[test]
fn a_scan_rate_faster_than_the_control_rate_is_an_error_naming_both() {
    let c = LidarConfig { rate_hz: 20.0, ..Default::default() };
    let e = c.check_rate(0.1).unwrap_err().to_string();
    assert!(e.contains("rate_hz") && e.contains("dt"), "{e}");
    c.check_rate(0.05).unwrap();
    LidarConfig { rate_hz: 10.0, ..Default::default() }.check_rate(0.1).unwrap();
    LidarConfig { rate_hz: 20.0, ..Default::default() }.check_rate(0.02).unwrap();
}

#[test]
fn planar_ring_passes_over_low_walls() {
    let mut l = Lidar::new(LidarConfig { range_noise_std: 0.0, ..Default::default() }).unwrap();
    let low = [Segment::new([1.0, -1.0], [1.0, 1.0], 0.3)];
    let high = [Segment::new([3.0, -1.0], [3.0, 1.0], 2.0)];
    let mut scan = Scan::default();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    l.scan_into(&[&low, &high], Pose2::default(), 0.0, &mut rng, &mut scan).unwrap();
    assert!((scan.ranges[0] - 3.0).abs() < 1e-12);
}

#[test]
fn mount_offset_moves_points_into_the_body_frame() {
    let cfg = LidarConfig { range_noise_std: 0.0, mount: LidarMount { x: 0.5, y: 0.0, z: 0.4, yaw: std::f64::consts::PI }, ..Default::default() };
    let mut l = Lidar::new(cfg).unwrap();
    let wall = [Segment::new([-2.0, -1.0], [-2.0, 1.0], 2.0)];
    let mut scan = Scan::default();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    l.scan_into(&[&wall], Pose2::default(), 0.0, &mut rng, &mut scan).unwrap();
    // column 0 looks backwards (mount yaw π) from x = 0.5: the wall is 2.5 m away
    assert!((scan.ranges[0] - 2.5).abs() < 1e-12);
    let p = scan.points[0];
    assert!((p[0] + 2.0).abs() < 1e-12 && p[1].abs() < 1e-12 && (p[2] - 0.4).abs() < 1e-15);
}

#[test]
fn dropout_and_noise_use_the_given_rng() {
    let cfg = LidarConfig { dropout: 0.3, range_noise_std: 0.02, ..Default::default() };
    let mut l = Lidar::new(cfg).unwrap();
    let wall = [Segment::new([-2.0, -3.0], [-2.0, 3.0], 2.0), Segment::new([2.0, -3.0], [2.0, 3.0], 2.0)];
    let mut s1 = Scan::default();
    let mut s2 = Scan::default();
    l.scan_into(&[&wall], Pose2::default(), 0.0, &mut ChaCha8Rng::seed_from_u64(5), &mut s1).unwrap();
    l.scan_into(&[&wall], Pose2::default(), 0.0, &mut ChaCha8Rng::seed_from_u64(5), &mut s2).unwrap();
    assert_eq!(s1.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>(), s2.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>());
    let hits = s1.ranges.iter().filter(|r| r.is_finite()).count();
    // the two walls cover 2·2·atan(1.5) of the circle; ~30 % of those returns are dropped
    let expected = 1024.0 * 4.0 * (1.5f64).atan() / std::f64::consts::TAU * 0.7;
    assert!((hits as Real - expected).abs() < 0.08 * expected, "{hits} vs {expected}");
}
