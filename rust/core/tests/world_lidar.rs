//! The polar-sweep LIDAR against an independent brute-force f64 ray caster.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shieldnav_core::sensors::{Lidar, LidarConfig, LidarMount, Scan};
use shieldnav_core::world::{preset, Polygon, Pose2, Segment, PRESET_NAMES};

/// Brute force in the world frame: every beam against every wall, Cramer's rule on
/// `o + t·d = a + s·(b − a)`, then the height window of the beam's elevation.
fn reference(walls: &[Segment], cfg: &LidarConfig, body: Pose2) -> Vec<f64> {
    reference_with_tops(walls, &[], cfg, body)
}

/// [`reference`] with the top faces of the solid polygons `solids` (whose edges are among
/// `walls`): a descending beam hits the plane `z = height` at horizontal distance
/// `(height − z) / tan(el)`, a hit where that point is inside the polygon.
fn reference_with_tops(walls: &[Segment], solids: &[Polygon], cfg: &LidarConfig, body: Pose2) -> Vec<f64> {
    let m = cfg.mount;
    let (sy, cy) = body.yaw.sin_cos();
    let o = [body.x + cy * m.x - sy * m.y, body.y + sy * m.x + cy * m.y];
    let yaw = body.yaw + m.yaw;
    let elev: Vec<f64> =
        if cfg.channels == 1 { vec![0.0] } else { (0..cfg.channels).map(|k| cfg.vertical_fov.0 + k as f64 * (cfg.vertical_fov.1 - cfg.vertical_fov.0) / (cfg.channels - 1) as f64).collect() };
    let mut out = vec![f64::INFINITY; cfg.channels * cfg.columns];
    for (k, el) in elev.iter().enumerate() {
        for i in 0..cfg.columns {
            let az = yaw + std::f64::consts::TAU * i as f64 / cfg.columns as f64;
            let d = [az.cos(), az.sin()];
            let mut best = f64::INFINITY;
            for w in walls {
                let e = [w.b[0] - w.a[0], w.b[1] - w.a[1]];
                // [d, -e] [t, s]^T = a - o
                let det = d[0] * (-e[1]) - d[1] * (-e[0]);
                if det.abs() < 1e-300 {
                    continue;
                }
                let r = [w.a[0] - o[0], w.a[1] - o[1]];
                let t = (r[0] * (-e[1]) - r[1] * (-e[0])) / det;
                let s = (d[0] * r[1] - d[1] * r[0]) / det;
                if t < 0.0 || !(0.0..=1.0).contains(&s) {
                    continue;
                }
                let z = m.z + t * el.tan();
                if z < 0.0 || z > w.height {
                    continue;
                }
                best = best.min(t / el.cos());
            }
            for p in solids {
                let t = (p.height - m.z) / el.tan();
                if el.tan() < 0.0 && t >= 0.0 && p.contains([o[0] + t * d[0], o[1] + t * d[1]]) {
                    best = best.min(t / el.cos());
                }
            }
            out[k * cfg.columns + i] = if best >= cfg.min_range && best <= cfg.max_range { best } else { f64::INFINITY };
        }
    }
    out
}

fn compare(walls: &[Segment], cfg: LidarConfig, poses: &[Pose2]) -> usize {
    let mut lidar = Lidar::new(cfg).unwrap();
    let mut scan = Scan::default();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut hits = 0;
    for &p in poses {
        lidar.scan_into(&[walls], p, 0.0, &mut rng, &mut scan).unwrap();
        let r = reference(walls, &cfg, p);
        for (j, (a, b)) in scan.ranges.iter().zip(&r).enumerate() {
            if a.is_finite() || b.is_finite() {
                assert!((a - b).abs() <= 1e-6, "pose {p:?} beam {j}: sweep {a} vs reference {b}");
                hits += 1;
            }
        }
    }
    hits
}

fn exact(channels: usize, columns: usize) -> LidarConfig {
    LidarConfig { channels, columns, range_noise_std: 0.0, max_range: 60.0, ..LidarConfig::default() }
}

#[test]
fn planar_ranges_match_brute_force_on_every_preset() {
    for name in PRESET_NAMES {
        let s = preset(name).unwrap();
        let poses = [s.start, Pose2::new(s.start.x + 3.3, s.start.y + 0.2, 0.77), Pose2::new(s.start.x + 4.1, s.start.y - 0.3, -2.5)];
        for cols in [512, 1024, 2048] {
            let hits = compare(&s.map.segments, exact(1, cols), &poses);
            assert!(hits > cols, "{name}: only {hits} returns");
        }
    }
}

#[test]
fn grazing_beams_down_a_long_corridor_are_exact() {
    let walls = [Segment::new([-200.0, -1.0], [200.0, -1.0], 2.5), Segment::new([-200.0, 1.0], [200.0, 1.0], 2.5)];
    // beams nearly parallel to the walls hit them at up to ~60 m: the worst case for f32 casts
    let poses = [Pose2::new(0.0, 0.0, 0.0), Pose2::new(3.0, 0.37, 0.001), Pose2::new(-7.0, -0.6, std::f64::consts::PI - 1e-4)];
    let hits = compare(&walls, exact(1, 2048), &poses);
    assert!(hits > 3 * 2000);
}

#[test]
fn random_segment_soups_match_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    for _ in 0..5 {
        let walls: Vec<Segment> = (0..200)
            .map(|_| {
                let a = [rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0)];
                let b = [a[0] + rng.random_range(-3.0..3.0), a[1] + rng.random_range(-3.0..3.0)];
                Segment::new(a, b, rng.random_range(0.3..3.0))
            })
            .collect();
        let pose = Pose2::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0), rng.random_range(-3.0..3.0));
        compare(&walls, exact(1, 1024), &[pose]);
        compare(&walls, LidarConfig { mount: LidarMount { x: 0.3, y: -0.1, z: 0.7, yaw: 0.4 }, ..exact(32, 1024) }, &[pose]);
    }
}

#[test]
fn three_d_scan_sees_over_low_clutter_and_matches_brute_force() {
    let s = preset("dynamic_obstacles").unwrap();
    let cfg = exact(32, 1024);
    let hits = compare(&s.map.segments, cfg, &[s.start, Pose2::new(6.0, 0.1, 0.2)]);
    assert!(hits > 10_000);
}

#[test]
fn beam_through_a_segment_end_point_hits_it() {
    // a wall whose end point lies exactly on beam 0 (+x)
    let walls = [Segment::new([2.0, 0.0], [2.0, 1.0], 2.0), Segment::new([3.0, 0.0], [3.0, -1.0], 2.0)];
    let mut lidar = Lidar::new(exact(1, 1024)).unwrap();
    let mut scan = Scan::default();
    lidar.scan_into(&[&walls], Pose2::default(), 0.0, &mut ChaCha8Rng::seed_from_u64(0), &mut scan).unwrap();
    assert_eq!(scan.ranges[0], 2.0);
}

#[test]
fn tiny_walls_starting_on_or_beside_a_beam_match_brute_force() {
    // walls whose angular interval begins exactly on a beam's azimuth, or a hair beside it,
    // and spans less than a beam step: the beam interval of each wall must still include
    // every beam that hits it (the angle slack of `wall_beams`)
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for cols in [512, 1024, 2048] {
        let lidar = Lidar::new(exact(1, cols)).unwrap();
        let mut walls = Vec::new();
        for j in (0..cols).step_by(7) {
            let d = lidar.beam_direction(0, j);
            let r = rng.random_range(0.5..12.0);
            let off = [0.0, 1e-12, -1e-12, 1e-9, -1e-9][j % 5];
            let p = [r * d[0] - off * d[1], r * d[1] + off * d[0]];
            let side = if j % 2 == 0 { 1.0 } else { -1.0 };
            let len = [1e-4, 1e-3, 0.01][j % 3];
            walls.push(Segment::new(p, [p[0] - side * len * d[1], p[1] + side * len * d[0]], 2.0));
        }
        let hits = compare(&walls, exact(1, cols), &[Pose2::default()]);
        assert!(hits > cols / 14, "{cols} columns: only {hits} returns");
    }
}

#[test]
fn moving_obstacles_are_seen_when_they_arrive() {
    let s = preset("dynamic_obstacles").unwrap();
    let door = s.obstacles.iter().find(|o| o.name == "door").unwrap();
    let mut lidar = Lidar::new(exact(1, 1024)).unwrap();
    let pose = Pose2::new(21.0, 0.4, 0.0);
    let mut closed = Vec::new();
    let mut open = Vec::new();
    door.segments_at(19.0, &mut closed);
    door.segments_at(23.0, &mut open);
    let mut a = Scan::default();
    let mut b = Scan::default();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    lidar.scan_into(&[&s.map.segments, &closed], pose, 19.0, &mut rng, &mut a).unwrap();
    lidar.scan_into(&[&s.map.segments, &open], pose, 23.0, &mut rng, &mut b).unwrap();
    // the beam toward the open door's leaf (x = 23, y in [-0.9, -0.15]) from (21, 0.4)
    let az = (-0.9f64).atan2(2.0).rem_euclid(std::f64::consts::TAU);
    let i = (az / std::f64::consts::TAU * 1024.0).round() as usize;
    assert!(b.ranges[i] < a.ranges[i] - 0.5, "open {} closed {}", b.ranges[i], a.ranges[i]);
    assert!((b.ranges[i] - 2.0 / az.cos()).abs() < 0.06);
}

#[test]
fn indexed_scan_equals_the_full_scan_bit_for_bit() {
    use shieldnav_core::world::generate::{generate, GeneratorConfig, SiteKind};
    use shieldnav_core::world::SegmentIndex;
    let mut worlds: Vec<Vec<Segment>> = PRESET_NAMES.iter().map(|n| preset(n).unwrap().map.segments).collect();
    worlds.push(generate(2, &GeneratorConfig::default()).unwrap().scenario.map.segments);
    worlds.push(generate(2, &GeneratorConfig { kind: SiteKind::Tunnel, ..Default::default() }).unwrap().scenario.map.segments);
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let extra = [Segment::new([3.0, -0.3], [3.2, 0.4], 1.0)];
    for walls in worlds {
        let (lo, hi) = {
            let xs = walls.iter().flat_map(|s| [s.a[0], s.b[0]]);
            let ys = walls.iter().flat_map(|s| [s.a[1], s.b[1]]);
            ([xs.clone().fold(f64::INFINITY, f64::min), ys.clone().fold(f64::INFINITY, f64::min)], [xs.fold(f64::NEG_INFINITY, f64::max), ys.fold(f64::NEG_INFINITY, f64::max)])
        };
        for cell in [1.0, 2.0, 3.7] {
            let index = SegmentIndex::new(walls.clone(), cell).unwrap();
            for (channels, max_range) in [(1, 20.0), (1, 6.0), (16, 20.0)] {
                let mut lidar = Lidar::new(LidarConfig { channels, max_range, ..exact(channels, 1024) }).unwrap();
                let (mut a, mut b) = (Scan::default(), Scan::default());
                for _ in 0..20 {
                    let p = Pose2::new(rng.random_range(lo[0]..hi[0]), rng.random_range(lo[1]..hi[1]), rng.random_range(-3.2..3.2));
                    lidar.scan_into(&[&walls, &extra], p, 0.0, &mut rng, &mut a).unwrap();
                    lidar.scan_indexed_into(&index, &extra, p, 0.0, &mut rng, &mut b).unwrap();
                    let (ba, bb): (Vec<u64>, Vec<u64>) = (a.ranges.iter().map(|r| r.to_bits()).collect(), b.ranges.iter().map(|r| r.to_bits()).collect());
                    assert_eq!(ba, bb, "pose {p:?} cell {cell} channels {channels}");
                }
            }
        }
    }
}

/// A non-finite stamp or wall is an error naming it (a NaN wall was skipped, a NaN height
/// scanned, silently).
#[test]
fn non_finite_stamps_and_walls_are_errors() {
    let mut lidar = Lidar::new(exact(1, 1024)).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut out = Scan::default();
    let good = [Segment::new([1.0, -1.0], [1.0, 1.0], 2.0)];
    let e = lidar.scan_into(&[&good], Pose2::new(0.0, 0.0, 0.0), f64::NAN, &mut rng, &mut out).unwrap_err().to_string();
    assert!(e.contains("`stamp`"), "{e}");
    for bad in [Segment::new([1.0, f64::NAN], [1.0, 1.0], 2.0), Segment::new([1.0, -1.0], [1.0, 1.0], f64::NAN)] {
        let e = lidar.scan_into(&[&good, &[bad]], Pose2::new(0.0, 0.0, 0.0), 0.0, &mut rng, &mut out).unwrap_err().to_string();
        assert!(e.contains("`walls`"), "{e}");
    }
    lidar.scan_into(&[&good], Pose2::new(0.0, 0.0, 0.0), 0.0, &mut rng, &mut out).unwrap();
}

/// A sensor outside the walls' box, farther than the index is wide, still sees them (the
/// buckets searched were capped at the index's width from the sensor: a 2 m wall seen from
/// 8 m gave no return).
#[test]
fn indexed_scan_from_outside_the_walls_box_equals_the_full_scan() {
    use shieldnav_core::world::SegmentIndex;
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let worlds = [vec![Segment::new([0.0, 0.0], [2.0, 0.0], 2.0)], preset("constricted_passage").unwrap().map.segments];
    let mut lidar = Lidar::new(exact(1, 1024)).unwrap();
    let (mut a, mut b) = (Scan::default(), Scan::default());
    for walls in worlds {
        let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
        let hi = walls.iter().flat_map(|s| [s.a[1], s.b[1]]).fold(f64::NEG_INFINITY, f64::max);
        let mut poses = vec![Pose2::new(1.0, hi + 8.0, 0.0), Pose2::new(-12.0, 0.5, 0.3)];
        poses.extend((0..40).map(|_| Pose2::new(rng.random_range(-18.0..18.0), rng.random_range(hi - 18.0..hi + 18.0), rng.random_range(-3.2..3.2))));
        for p in poses {
            lidar.scan_into(&[&walls], p, 0.0, &mut rng, &mut a).unwrap();
            lidar.scan_indexed_into(&index, &[], p, 0.0, &mut rng, &mut b).unwrap();
            let (ba, bb): (Vec<u64>, Vec<u64>) = (a.ranges.iter().map(|r| r.to_bits()).collect(), b.ranges.iter().map(|r| r.to_bits()).collect());
            assert!(ba == bb, "pose {p:?}: {} returns against {}", b.ranges.iter().filter(|r| r.is_finite()).count(), a.ranges.iter().filter(|r| r.is_finite()).count());
        }
    }
}

/// The planar scan by walking a triangulation of the walls gives the full scan's ranges bit
/// for bit: from random poses (some outside the walls, where it falls back to the index),
/// with a moving wall, at two ranges; from poses whose beams pass exactly through corners
/// (those beams are cast again against every wall); and a 16-channel scan (the index).
#[test]
fn mesh_scan_equals_the_full_scan_bit_for_bit() {
    use shieldnav_core::sensors::ScanMesh;
    use shieldnav_core::world::generate::{generate, GeneratorConfig, SiteKind};
    use shieldnav_core::world::SegmentIndex;
    let mut worlds: Vec<Vec<Segment>> = PRESET_NAMES.iter().map(|n| preset(n).unwrap().map.segments).collect();
    for seed in 0..3 {
        worlds.push(generate(seed, &GeneratorConfig::default()).unwrap().scenario.map.segments);
        worlds.push(generate(seed, &GeneratorConfig { kind: SiteKind::Tunnel, ..Default::default() }).unwrap().scenario.map.segments);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let extra = [Segment::new([3.0, -0.3], [3.2, 0.4], 1.0)];
    let (mut walked, mut recast, mut fell_back) = (0, 0, 0);
    for walls in &worlds {
        let mesh = ScanMesh::new(walls).unwrap();
        let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
        let (lo, hi) = {
            let xs = walls.iter().flat_map(|s| [s.a[0], s.b[0]]);
            let ys = walls.iter().flat_map(|s| [s.a[1], s.b[1]]);
            ([xs.clone().fold(f64::INFINITY, f64::min), ys.clone().fold(f64::INFINITY, f64::min)], [xs.fold(f64::NEG_INFINITY, f64::max), ys.fold(f64::NEG_INFINITY, f64::max)])
        };
        // random poses, a few beyond the walls' box; poses on wall corners, yaw 0 and a
        // quarter turn, so that beams run exactly along walls and through other corners
        let mut poses: Vec<Pose2> = (0..30).map(|_| Pose2::new(rng.random_range(lo[0] - 3.0..hi[0] + 3.0), rng.random_range(lo[1] - 3.0..hi[1] + 3.0), rng.random_range(-3.2..3.2))).collect();
        for s in walls.iter().step_by((walls.len() / 6).max(1)) {
            poses.push(Pose2::new(s.a[0] + 0.25, s.a[1], 0.0));
            poses.push(Pose2::new(s.a[0], s.a[1] + 0.25, std::f64::consts::FRAC_PI_2));
            poses.push(Pose2::new(s.a[0], s.a[1], 0.0));
        }
        for (channels, max_range) in [(1, 20.0), (1, 6.0), (16, 20.0)] {
            let mut lidar = Lidar::new(LidarConfig { channels, max_range, ..exact(channels, 1024) }).unwrap();
            let (mut a, mut b) = (Scan::default(), Scan::default());
            for &p in &poses {
                lidar.scan_into(&[walls, &extra], p, 0.0, &mut rng, &mut a).unwrap();
                lidar.scan_mesh_into(&mesh, &index, &extra, p, 0.0, &mut rng, &mut b).unwrap();
                let (ba, bb): (Vec<u64>, Vec<u64>) = (a.ranges.iter().map(|r| r.to_bits()).collect(), b.ranges.iter().map(|r| r.to_bits()).collect());
                if ba != bb {
                    let diff: Vec<_> = (0..ba.len()).filter(|&i| ba[i] != bb[i]).map(|i| (i, a.ranges[i], b.ranges[i])).collect();
                    panic!("pose {p:?} channels {channels} range {max_range}: {diff:?} {:?}", lidar.last_mesh_stats());
                }
                let st = lidar.last_mesh_stats();
                assert!(st.fell_back || channels == 1, "a 16-channel scan walked: {st:?}");
                walked += !st.fell_back as usize;
                recast += st.beams_recast;
                fell_back += (channels == 1 && st.fell_back) as usize;
            }
        }
    }
    // the walk ran, cast some beams again, and fell back from outside the triangulation
    assert!(walked > 500 && recast > 0 && fell_back > 0, "walked {walked}, recast {recast}, fell back {fell_back}");
}

/// Walls that cross are split where they cross (200 random walls, and an X), and the walk
/// still gives the full scan's ranges bit for bit; walls without length have no mesh.
#[test]
fn walls_that_cross_are_split_where_they_cross() {
    use shieldnav_core::sensors::ScanMesh;
    use shieldnav_core::world::SegmentIndex;
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let mut walked = 0;
    for round in 0..6 {
        let walls: Vec<Segment> = if round == 0 {
            vec![Segment::new([0.0, 0.0], [2.0, 2.0], 1.0), Segment::new([0.0, 2.0], [2.0, 0.0], 1.0)]
        } else {
            (0..200)
                .map(|_| {
                    let a = [rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0)];
                    let b = [a[0] + rng.random_range(-3.0..3.0), a[1] + rng.random_range(-3.0..3.0)];
                    // (in odd rounds some walls are lower than the sensor, whose walk then
                    // tests an edge's walls one by one; in even rounds every wall is higher)
                    let low = if round % 2 == 1 { 0.3 } else { 1.0 };
                    if rng.random_bool(0.5) {
                        Segment::new(a, b, rng.random_range(low..3.0))
                    } else {
                        Segment::one_sided(a, b, 2.0)
                    }
                })
                .collect()
        };
        let mesh = ScanMesh::new(&walls).unwrap();
        let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
        let mut lidar = Lidar::new(exact(1, 1024)).unwrap();
        let (mut a, mut b) = (Scan::default(), Scan::default());
        for _ in 0..20 {
            let p = Pose2::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0), rng.random_range(-3.2..3.2));
            lidar.scan_into(&[&walls], p, 0.0, &mut rng, &mut a).unwrap();
            lidar.scan_mesh_into(&mesh, &index, &[], p, 0.0, &mut rng, &mut b).unwrap();
            let diff: Vec<_> = (0..1024).filter(|&i| a.ranges[i].to_bits() != b.ranges[i].to_bits()).map(|i| (i, a.ranges[i], b.ranges[i])).collect();
            assert!(diff.is_empty(), "round {round} pose {p:?}: {diff:?}");
            walked += !lidar.last_mesh_stats().fell_back as usize;
        }
    }
    assert!(walked > 90, "walked {walked}");
    let e = ScanMesh::new(&[Segment::new([1.0, 1.0], [1.0, 1.0], 1.0)]).unwrap_err();
    assert!(e.0.contains("wall 0"), "{e:?}");
    assert!(ScanMesh::new(&[]).is_err());
    // walls meeting at their ends, or touching another's middle, triangulate
    let t = [Segment::new([0.0, 0.0], [2.0, 0.0], 1.0), Segment::new([1.0, 0.0], [1.0, 1.0], 1.0), Segment::new([2.0, 0.0], [2.0, 2.0], 1.0)];
    assert!(ScanMesh::new(&t).unwrap().cells() > 0);
}

/// Thin walls outlined both ways (two one-sided walls on one line, as a map's one-cell-thick
/// obstacles are), two-sided walls given twice, and a two-sided wall with a one-sided one
/// on it: the walk takes each edge's wall facing the sensor and still gives the full scan's
/// ranges bit for bit (a sensor below every wall's top, and one above some).
#[test]
fn walls_on_one_line_give_the_full_scan_bit_for_bit() {
    use shieldnav_core::sensors::ScanMesh;
    use shieldnav_core::world::SegmentIndex;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut walked = 0;
    for round in 0..4 {
        // one wall a cell of a 3 m grid, so that none crosses another, in one of four forms
        let mut walls = Vec::new();
        for i in 0..6 {
            for j in 0..6 {
                let o = [i as f64 * 3.0, j as f64 * 3.0];
                let a = [o[0] + rng.random_range(0.2..2.8), o[1] + rng.random_range(0.2..2.8)];
                let b = [o[0] + rng.random_range(0.2..2.8), o[1] + rng.random_range(0.2..2.8)];
                let h = if round % 2 == 1 { rng.random_range(0.3..2.0) } else { 2.0 };
                match rng.random_range(0..4) {
                    0 => walls.extend([Segment::one_sided(a, b, h), Segment::one_sided(b, a, h)]),
                    1 => walls.extend([Segment::new(a, b, h), Segment::new(b, a, h)]),
                    2 => walls.extend([Segment::new(a, b, h), Segment::one_sided(b, a, h)]),
                    _ => walls.push(Segment::one_sided(a, b, h)),
                }
            }
        }
        let mesh = ScanMesh::new(&walls).unwrap();
        let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
        let mut lidar = Lidar::new(exact(1, 1024)).unwrap();
        let (mut a, mut b) = (Scan::default(), Scan::default());
        for _ in 0..30 {
            let p = Pose2::new(rng.random_range(0.0..18.0), rng.random_range(0.0..18.0), rng.random_range(-3.2..3.2));
            lidar.scan_into(&[&walls], p, 0.0, &mut rng, &mut a).unwrap();
            lidar.scan_mesh_into(&mesh, &index, &[], p, 0.0, &mut rng, &mut b).unwrap();
            let diff: Vec<_> = (0..1024).filter(|&i| a.ranges[i].to_bits() != b.ranges[i].to_bits()).map(|i| (i, a.ranges[i], b.ranges[i])).collect();
            assert!(diff.is_empty(), "round {round} pose {p:?}: {diff:?}");
            let st = lidar.last_mesh_stats();
            walked += !st.fell_back as usize;
        }
    }
    assert!(walked > 110, "walked {walked}");
}

#[test]
fn one_sided_grid_walls_give_the_two_sided_reference_ranges_in_free_space() {
    use shieldnav_core::world::generate::{generate, GeneratorConfig, SiteKind};
    for kind in [SiteKind::Office, SiteKind::Tunnel] {
        let site = generate(3, &GeneratorConfig { kind, ..Default::default() }).unwrap();
        assert!(site.scenario.map.segments.iter().any(|s| s.one_sided));
        let poses: Vec<Pose2> = site.waypoints.iter().enumerate().map(|(k, p)| Pose2::new(p[0], p[1], 0.37 * k as f64)).collect();
        let hits = compare(&site.scenario.map.segments, exact(1, 1024), &poses);
        assert!(hits > 500 * poses.len());
    }
}

/// A 3D scan looks down on solid furniture: a 0.8 m box at x 3–6, y ±1 before a wall at
/// x = 10, scanned from z = 1.0 by 16 channels over ±0.2 rad. The channel passing over the
/// box's front face at z = 0.88 hits its top (5.0 m), not the wall behind it (10.008 m, as
/// when the box's back faces were skipped and it had no top). Every beam matches the
/// brute-force caster with top faces, through every scan path, and with the box as a
/// moving obstacle.
#[test]
fn three_d_scan_hits_the_tops_of_solids() {
    use shieldnav_core::world::{MovingObstacle, SegmentIndex, Trajectory};
    let boxed = Polygon::rect(3.0, -1.0, 6.0, 1.0, 0.8);
    let far = Segment::new([10.0, -5.0], [10.0, 5.0], 2.0);
    let mut walls: Vec<Segment> = boxed.edges().collect();
    walls.push(far);
    let cfg = LidarConfig { vertical_fov: (-0.2, 0.2), mount: LidarMount { x: 0.0, y: 0.0, z: 1.0, yaw: 0.0 }, ..exact(16, 1024) };
    let mut lidar = Lidar::new(cfg).unwrap();
    let mut scan = Scan::default();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let pose = Pose2::default();
    lidar.scan_into(&[&walls], pose, 0.0, &mut rng, &mut scan).unwrap();
    // channel 6 looks down at −0.04 rad: z = 0.88 over the front face, 0.8 at x ≈ 5.0
    let el: f64 = -0.2 + 6.0 * 0.4 / 15.0;
    assert!((1.0 + 3.0 * el.tan() - 0.88).abs() < 1e-3);
    let r = scan.ranges[6 * 1024];
    let want = (0.8 - 1.0) / el.tan() / el.cos();
    assert!((r - want).abs() < 1e-9 && r < 5.1, "channel 6 column 0: {r}, the box's top at {want}");
    let check = |got: &Scan, what: &str| {
        let want = reference_with_tops(&walls, std::slice::from_ref(&boxed), &cfg, pose);
        let mut tops = 0;
        for (j, (a, b)) in got.ranges.iter().zip(&want).enumerate() {
            assert!(a == b || (a - b).abs() <= 1e-6, "{what}: beam {j}: {a} vs reference {b}");
            tops += (a.is_finite() && (j / 1024) < 8 && *a < 6.1 && *a > 3.0 / (-0.2f64).cos() && (j % 1024 < 100 || j % 1024 > 924)) as usize;
        }
        assert!(tops > 100, "{what}: {tops} returns from the top");
    };
    check(&scan, "full sweep");
    // through the bucket index
    let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
    let mut b = Scan::default();
    lidar.scan_indexed_into(&index, &[], pose, 0.0, &mut rng, &mut b).unwrap();
    check(&b, "indexed");
    // the box as a moving obstacle, clockwise in its own frame
    let mut shape = Polygon::rect(-1.5, -1.0, 1.5, 1.0, 0.8);
    shape.vertices.reverse();
    let mover = MovingObstacle { name: "box".into(), shape, trajectory: Trajectory::fixed(Pose2::new(4.5, 0.0, 0.0)) };
    let mut moving = Vec::new();
    mover.segments_at(0.0, &mut moving);
    let index = SegmentIndex::new(vec![far], 2.0).unwrap();
    let mut c = Scan::default();
    lidar.scan_into(&[&[far], &moving], pose, 0.0, &mut rng, &mut c).unwrap();
    check(&c, "moving, full sweep");
    lidar.scan_indexed_into(&index, &moving, pose, 0.0, &mut rng, &mut c).unwrap();
    check(&c, "moving, indexed");
    // and a planar ring at the same height passes over the box as before
    let mut planar = Lidar::new(LidarConfig { mount: cfg.mount, ..exact(1, 1024) }).unwrap();
    planar.scan_into(&[&walls], pose, 0.0, &mut rng, &mut scan).unwrap();
    assert_eq!(scan.ranges[0], 10.0);
}

/// Random solid boxes below the sensor and random poses: the 3D scan equals the brute-force
/// caster with top faces, and the indexed scan the full sweep bit for bit.
#[test]
fn random_low_solids_match_brute_force_with_tops() {
    use shieldnav_core::world::SegmentIndex;
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    for _ in 0..6 {
        let mut walls = vec![
            Segment::new([-12.0, -12.0], [12.0, -12.0], 2.5),
            Segment::new([12.0, -12.0], [12.0, 12.0], 2.5),
            Segment::new([12.0, 12.0], [-12.0, 12.0], 2.5),
            Segment::new([-12.0, 12.0], [-12.0, -12.0], 2.5),
        ];
        let mut solids = Vec::new();
        while solids.len() < 12 {
            let c: [f64; 2] = [rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0)];
            if c[0].hypot(c[1]) < 4.0 {
                continue;
            }
            let mut p = Polygon::oriented_box(Pose2::new(c[0], c[1], rng.random_range(-3.0..3.0)), rng.random_range(0.3..2.0), rng.random_range(0.3..2.0), rng.random_range(0.2..1.1));
            if rng.random_bool(0.5) {
                p.vertices.reverse();
            }
            walls.extend(p.edges());
            solids.push(p);
        }
        let pose = Pose2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-3.0..3.0));
        let cfg = LidarConfig { vertical_fov: (-0.6, 0.2), mount: LidarMount { x: 0.2, y: 0.1, z: 1.2, yaw: 0.3 }, ..exact(32, 1024) };
        let mut lidar = Lidar::new(cfg).unwrap();
        let (mut a, mut b) = (Scan::default(), Scan::default());
        lidar.scan_into(&[&walls], pose, 0.0, &mut rng, &mut a).unwrap();
        let want = reference_with_tops(&walls, &solids, &cfg, pose);
        for (j, (x, y)) in a.ranges.iter().zip(&want).enumerate() {
            assert!(x == y || (x - y).abs() <= 1e-6, "beam {j}: {x} vs reference {y}");
        }
        let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
        lidar.scan_indexed_into(&index, &[], pose, 0.0, &mut rng, &mut b).unwrap();
        assert_eq!(a.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>(), b.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>());
    }
}
