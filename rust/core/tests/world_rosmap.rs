//! Every map in `<repo>/../shared/maps` loads; its walls lie on occupied-cell boundaries (or,
//! simplified, within the tolerance of them); the start is inside the building; the LIDAR is
//! exact on it.

use std::path::PathBuf;

use image::ImageEncoder;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use shieldnav_core::sensors::{ray_segment_distance, Lidar, LidarConfig, Scan};
use shieldnav_core::world::{load_ros_map, Cell, RosMap, RosMapOptions};

fn maps_dir() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps");
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!("SKIPPED: {} is absent (the shared maps folder beside the repository)", d.display());
        None
    }
}

/// The maps as loaded by default (walls simplified), with or without unknown cells as walls.
fn all_maps(unknown_is_wall: bool) -> Vec<(String, RosMap)> {
    maps_with(RosMapOptions { unknown_is_wall, ..RosMapOptions::default() })
}

fn maps_with(options: RosMapOptions) -> Vec<(String, RosMap)> {
    let Some(dir) = maps_dir() else { return Vec::new() };
    let mut out = Vec::new();
    let mut dirs: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().filter(|e| e.path().is_dir()).collect();
    dirs.sort_by_key(|e| e.path());
    for e in dirs {
        let yaml = std::fs::read_dir(e.path()).unwrap().flatten().map(|f| f.path()).find(|p| p.extension().is_some_and(|x| x == "yaml")).unwrap();
        let m = load_ros_map(&yaml, &options).unwrap_or_else(|err| panic!("{}: {err}", yaml.display()));
        out.push((e.file_name().to_string_lossy().into_owned(), m));
    }
    assert_eq!(out.len(), 8, "expected the 8 maps of SOURCES.md");
    out
}

#[test]
fn every_map_loads_with_walls_on_occupied_boundaries_and_an_interior_start() {
    check_walls_and_start(false, false);
}

#[test]
fn with_unknown_as_wall_walls_bound_the_free_space() {
    check_walls_and_start(true, false);
}

#[test]
fn unreachable_walls_keeps_every_solid_boundary() {
    check_walls_and_start(true, true);
}

/// The cells 4-connected to `start` through cells that are not `solid`, cell by cell.
fn flood(g: &shieldnav_core::world::OccupancyGrid, start: (usize, usize), solid: impl Fn(Cell) -> bool) -> Vec<bool> {
    let (w, h) = (g.width, g.height);
    let mut inside = vec![false; w * h];
    let mut stack = vec![start];
    while let Some((i, j)) = stack.pop() {
        if solid(g.get(i, j)) || inside[j * w + i] {
            continue;
        }
        inside[j * w + i] = true;
        if i > 0 {
            stack.push((i - 1, j))
        }
        if j > 0 {
            stack.push((i, j - 1))
        }
        if i + 1 < w {
            stack.push((i + 1, j))
        }
        if j + 1 < h {
            stack.push((i, j + 1))
        }
    }
    inside
}

/// Walls (not simplified) lie on solid-cell boundaries and, unless `unreachable`, face the
/// start's region: every edge between a region cell and a solid one is a wall and no other
/// edge is; with `unreachable` every solid boundary edge is.
fn check_walls_and_start(unknown_is_wall: bool, unreachable: bool) {
    for (name, m) in maps_with(RosMapOptions { wall_height: 2.5, unknown_is_wall, unreachable_walls: unreachable, simplify: 0.0 }) {
        let g = &m.grid;
        let solid = |c: Cell| c == Cell::Occupied || (unknown_is_wall && c == Cell::Unknown);
        let start = g.world_to_cell([m.scenario.start.x, m.scenario.start.y]).unwrap();
        let region = flood(g, start, solid);
        let on_grid = |i: i64, j: i64| i >= 0 && j >= 0 && (i as usize) < g.width && (j as usize) < g.height;
        // the solid side of an edge: solid cells, or (walls of the region only) cells off the
        // region; beyond the image lies unknown space, solid with unknown_is_wall
        let occ = |i: i64, j: i64| {
            if on_grid(i, j) {
                if unreachable {
                    solid(g.get(i as usize, j as usize))
                } else {
                    !region[j as usize * g.width + i as usize]
                }
            } else {
                unknown_is_wall
            }
        };
        // an edge between a solid and an open side (with the region and open unknown space: both
        // on the grid, the region running on beyond the image)
        let edge = |p: (i64, i64), q: (i64, i64)| occ(p.0, p.1) != occ(q.0, q.1) && (unreachable || unknown_is_wall || (on_grid(p.0, p.1) && on_grid(q.0, q.1)));
        let res = g.resolution;
        let mut length = 0.0;
        for s in &m.scenario.map.segments {
            let a = g.origin.inverse_transform_point(s.a);
            let b = g.origin.inverse_transform_point(s.b);
            let n = (s.length() / res).round() as usize;
            assert!(n >= 1 && (s.length() - n as f64 * res).abs() < 1e-6, "{name}: segment not a whole number of cells");
            length += s.length();
            for k in 0..n {
                // the middle of each unit edge, in cells
                let t = (k as f64 + 0.5) / n as f64;
                let p = [(a[0] + t * (b[0] - a[0])) / res, (a[1] + t * (b[1] - a[1])) / res];
                let horizontal = (a[1] - b[1]).abs() < 1e-6;
                let (c1, c2) = if horizontal {
                    let (i, j) = (p[0].floor() as i64, p[1].round() as i64);
                    ((i, j - 1), (i, j))
                } else {
                    let (i, j) = (p[0].round() as i64, p[1].floor() as i64);
                    ((i - 1, j), (i, j))
                };
                assert!(edge(c1, c2), "{name}: wall edge at cell {p:?} is not a boundary of the {}", if unreachable { "solid cells" } else { "start's region" });
            }
        }
        // and every occupied boundary edge is covered: total lengths agree
        let mut edges = 0usize;
        for j in 0..=g.height as i64 {
            for i in 0..=g.width as i64 {
                if i < g.width as i64 && edge((i, j - 1), (i, j)) {
                    edges += 1;
                }
                if j < g.height as i64 && edge((i - 1, j), (i, j)) {
                    edges += 1;
                }
            }
        }
        assert!((length - edges as f64 * res).abs() < 1e-6 * edges as f64, "{name}: walls {length} m vs {edges} edges");
        // the start: free, with room for the robot, and not connected through free cells to the border
        let (si, sj) = g.world_to_cell([m.scenario.start.x, m.scenario.start.y]).unwrap();
        assert_eq!(g.get(si, sj), Cell::Free, "{name}");
        assert!(m.start_clearance >= 0.6, "{name}: clearance {}", m.start_clearance);
        // inside: rays from the start end on non-free cells, not outside the image (independent of the
        // loader's own test: 720 rays, stepped at a tenth of a cell)
        let mut escaped = 0;
        for k in 0..720 {
            let (sn, cs) = (k as f64 * std::f64::consts::TAU / 720.0).sin_cos();
            let (mut x, mut y) = (si as f64 + 0.5, sj as f64 + 0.5);
            loop {
                x += 0.1 * cs;
                y += 0.1 * sn;
                if x < 0.0 || y < 0.0 || x >= g.width as f64 || y >= g.height as f64 {
                    escaped += 1;
                    break;
                }
                if g.get(x as usize, y as usize) != Cell::Free {
                    break;
                }
            }
        }
        assert!(escaped < 72, "{name}: {escaped}/720 rays from the start leave the map");
        eprintln!("{name}: {} walls, start {:?}, clearance {:.2} m", m.scenario.map.segments.len(), m.scenario.start, m.start_clearance);
    }
}

#[test]
fn lidar_is_exact_on_real_maps() {
    for (name, m) in all_maps(true) {
        let cfg = LidarConfig { range_noise_std: 0.0, max_range: 20.0, ..LidarConfig::default() };
        let mut lidar = Lidar::new(cfg).unwrap();
        let mut scan = Scan::default();
        let pose = m.scenario.start;
        lidar.scan_into(&[&m.scenario.map.segments], pose, 0.0, &mut ChaCha8Rng::seed_from_u64(0), &mut scan).unwrap();
        let sp = lidar.sensor_pose(pose);
        let mut returns = 0;
        for i in 0..cfg.columns {
            let az = sp.yaw + std::f64::consts::TAU * i as f64 / cfg.columns as f64;
            let d = [az.cos(), az.sin()];
            let best = m.scenario.map.segments.iter().filter_map(|s| ray_segment_distance([sp.x, sp.y], d, s.a, s.b)).fold(f64::INFINITY, f64::min);
            let want = if best >= cfg.min_range && best <= cfg.max_range { best } else { f64::INFINITY };
            let got = scan.ranges[i];
            assert!(got == want || (got - want).abs() <= 1e-6, "{name} beam {i}: {got} vs {want}");
            returns += want.is_finite() as usize;
        }
        assert!(returns > 700, "{name}: only {returns} returns from the start");
    }
}

/// Dropping the walls the start's region cannot reach changes no scan from inside it: 3D
/// ring (beams over the walls included) from random places in the region, against all walls.
#[test]
fn unreachable_walls_change_no_scan_from_the_region() {
    use rand::Rng;
    let all = maps_with(RosMapOptions { unreachable_walls: true, ..RosMapOptions::default() });
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for ((name, pruned), (_, full)) in all_maps(true).into_iter().zip(all) {
        assert!(pruned.scenario.map.segments.len() < full.scenario.map.segments.len(), "{name}");
        let g = &pruned.grid;
        let start = g.world_to_cell([pruned.scenario.start.x, pruned.scenario.start.y]).unwrap();
        let region = flood(g, start, |c| c != Cell::Free);
        let cells: Vec<usize> = (0..region.len()).filter(|&k| region[k]).collect();
        let cfg = LidarConfig { channels: 16, range_noise_std: 0.0, max_range: 30.0, mount: shieldnav_core::sensors::LidarMount { z: 1.5, ..Default::default() }, ..LidarConfig::default() };
        let mut lidar = Lidar::new(cfg).unwrap();
        let (mut a, mut b) = (Scan::default(), Scan::default());
        for _ in 0..6 {
            let k = cells[rng.random_range(0..cells.len())];
            let c = g.cell_center(k % g.width, k / g.width);
            let r = 0.45 * g.resolution;
            let pose = shieldnav_core::world::Pose2::new(c[0] + rng.random_range(-r..r), c[1] + rng.random_range(-r..r), rng.random_range(-3.0..3.0));
            lidar.scan_into(&[&pruned.scenario.map.segments], pose, 0.0, &mut ChaCha8Rng::seed_from_u64(0), &mut a).unwrap();
            lidar.scan_into(&[&full.scenario.map.segments], pose, 0.0, &mut ChaCha8Rng::seed_from_u64(0), &mut b).unwrap();
            assert!(a.ranges.iter().filter(|r| r.is_finite()).count() > 1000, "{name}");
            assert_eq!(a.ranges, b.ranges, "{name} at {pose:?}");
        }
    }
}

/// Simplified walls (the default) stay within the tolerance of the cell-edge walls, both ways,
/// are far fewer, and keep every contour closed: at each vertex as many walls start as end,
/// except where the cell-edge walls themselves start or end unpaired (the image's border).
#[test]
fn simplified_walls_stay_within_the_tolerance_and_keep_contours_closed() {
    use shieldnav_core::world::{Segment, SegmentIndex};
    use std::collections::HashMap;
    let raw = maps_with(RosMapOptions { simplify: 0.0, ..RosMapOptions::default() });
    let tolerance = RosMapOptions::default().simplify;
    assert!(tolerance > 0.0);
    for ((name, simple), (_, raw)) in all_maps(true).into_iter().zip(raw) {
        let (a, b) = (&simple.scenario.map.segments, &raw.scenario.map.segments);
        let res = raw.grid.resolution;
        assert!(a.len() * 10 < b.len() * 9, "{name}: {} walls from {}", a.len(), b.len());
        let reach = tolerance * res * (1.0 + 1e-9) + 1e-12;
        // every point of one set within the tolerance of the other (sampled at a tenth of a cell)
        for (from, to, what) in [(a, b, "simplified wall off the cell edges"), (b, a, "cell edge off the simplified walls")] {
            let mut index = SegmentIndex::new(to.clone(), 1.0).unwrap();
            let mut near: Vec<Segment> = Vec::new();
            for s in from {
                let n = (s.length() / (0.1 * res)).ceil() as usize;
                for k in 0..=n {
                    let t = k as f64 / n as f64;
                    let p = [s.a[0] + t * (s.b[0] - s.a[0]), s.a[1] + t * (s.b[1] - s.a[1])];
                    index.query_into(p, reach, &mut near);
                    let d = near.iter().map(|w| w.distance_to_point(p)).fold(f64::INFINITY, f64::min);
                    assert!(d <= reach, "{name}: {what} at {p:?} by {d} m (tolerance {reach} m)");
                }
            }
        }
        // same height and sidedness; the contours' open ends unchanged
        assert!(a.iter().all(|s| s.one_sided && s.height == b[0].height), "{name}");
        let balance = |walls: &[Segment]| {
            let mut m: HashMap<(i64, i64), i64> = HashMap::new();
            for s in walls {
                let key = |p: [f64; 2]| ((p[0] / res * 8.0).round() as i64, (p[1] / res * 8.0).round() as i64);
                *m.entry(key(s.a)).or_default() += 1;
                *m.entry(key(s.b)).or_default() -= 1;
            }
            m.retain(|_, v| *v != 0);
            m
        };
        assert_eq!(balance(a), balance(b), "{name}: a contour was opened or joined");
        eprintln!("{name}: {} cell-edge walls -> {} simplified", b.len(), a.len());
    }
}

/// A 40 × 30 binary PGM: a room of free cells inside a one-cell occupied border.
fn room_pgm() -> Vec<u8> {
    let (w, h) = (40, 30);
    let mut px = vec![0u8; w * h];
    for j in 1..h - 1 {
        for i in 1..w - 1 {
            px[j * w + i] = 254;
        }
    }
    let mut out = format!("P5\n{w} {h}\n255\n").into_bytes();
    out.extend(px);
    out
}

/// A scratch folder, removed when dropped (also when the test fails).
struct TempDir(PathBuf);

impl TempDir {
    fn join(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn temp_dir(tag: &str) -> TempDir {
    let d = std::env::temp_dir().join(format!("shieldnav_rosmap_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    TempDir(d)
}

#[test]
fn rgba_png_uses_luminance_alpha_and_negate() {
    let d = temp_dir("png");
    // 4 x 1 RGBA: black, white, transparent white, pure red (luminance 76 -> p = 0.70)
    let px: [u8; 16] = [0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 0, 255, 0, 0, 255];
    image::save_buffer(d.join("m.png"), &px, 4, 1, image::ExtendedColorType::Rgba8).unwrap();
    for (negate, want) in [(0, [Cell::Occupied, Cell::Free, Cell::Unknown, Cell::Occupied]), (1, [Cell::Free, Cell::Occupied, Cell::Unknown, Cell::Unknown])] {
        std::fs::write(d.join("m.yaml"), format!("image: m.png\nresolution: 0.5\norigin: [1.0, 2.0, 0.0]\nnegate: {negate}\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")).unwrap();
        // no interior start in a 4 x 1 image: the error says so, naming the file
        let err = load_ros_map(d.join("m.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
        assert!(err.contains("m.yaml: map: no free region"), "{err}");
        let meta = shieldnav_core::world::rosmap::parse_ros_yaml(&std::fs::read_to_string(d.join("m.yaml")).unwrap(), &d.join("m.yaml")).unwrap();
        let g = shieldnav_core::world::rosmap::rasterize(&meta).unwrap();
        assert_eq!(g.cells, want, "negate {negate}");
    }
}

#[test]
fn malformed_files_name_file_and_field() {
    let d = temp_dir("bad");
    std::fs::write(d.join("a.yaml"), "image: missing.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("a.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("a.yaml: field image") && e.contains("missing.pgm"), "{e}");
    std::fs::write(d.join("t.pgm"), b"P5\n10 10\n255\n\x00\x00").unwrap();
    std::fs::write(d.join("b.yaml"), "image: t.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("b.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("t.pgm: pixel data"), "{e}");
    std::fs::write(d.join("c.yaml"), "image: t.pgm\nresolution: -1\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("c.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("c.yaml: field resolution"), "{e}");
    // a PGM that ends after its header: the image file and its header are named
    std::fs::write(d.join("short.pgm"), b"P5\n80 60\n255").unwrap();
    std::fs::write(d.join("short.yaml"), "image: short.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("short.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("short.pgm: header: ends after maxval"), "{e}");
    // a file that is no image of a known format, and a PNG cut short
    std::fs::write(d.join("text.pgm"), b"hello").unwrap();
    std::fs::write(d.join("text.yaml"), "image: text.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("text.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("text.pgm: header: not a PGM (P5/P2), PNG, BMP, JPEG or PPM/PBM image"), "{e}");
    image::save_buffer(d.join("cut.png"), &[254u8; 64], 8, 8, image::ExtendedColorType::L8).unwrap();
    let bytes = std::fs::read(d.join("cut.png")).unwrap();
    std::fs::write(d.join("cut.png"), &bytes[..bytes.len() - 20]).unwrap();
    std::fs::write(d.join("cut.yaml"), "image: cut.png\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("cut.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("cut.png: PNG data: "), "{e}");
    // an image of no pixel (a PPM declaring 0 x 0, found by the fuzzer) names the file
    std::fs::write(d.join("empty.pgm"), b"P6\n0 0\n255\n").unwrap();
    std::fs::write(d.join("empty.yaml"), "image: empty.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("empty.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("empty.pgm: header: size 0 x 0"), "{e}");
    let e = load_ros_map(d.join("nope.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("nope.yaml: file"), "{e}");
    // a map beyond the coordinates a scenario may use names its file and the field that put it there
    std::fs::write(d.join("room.pgm"), room_pgm()).unwrap();
    std::fs::write(d.join("far.yaml"), "image: room.pgm\nresolution: 0.05\norigin: [1e9, -11, 0]\n").unwrap();
    let e = load_ros_map(d.join("far.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("far.yaml: field origin"), "{e}");
    std::fs::write(d.join("huge.yaml"), "image: room.pgm\nresolution: 5000\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("huge.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("huge.yaml: field resolution"), "{e}");
    std::fs::write(d.join("fine.yaml"), "image: room.pgm\nresolution: 0.05\norigin: [-3, -2, 0]\n").unwrap();
    load_ros_map(d.join("fine.yaml"), &RosMapOptions::default()).unwrap();
    let folder = d.0.clone();
    drop(d);
    assert!(!folder.exists(), "the scratch folder {} is left behind", folder.display());
}

#[test]
fn indexed_scan_equals_the_full_scan_on_real_maps() {
    use shieldnav_core::sensors::ScanMesh;
    use shieldnav_core::world::SegmentIndex;
    let mut groups_occluded = 0;
    let mut maps = 0;
    let mut recast = 0;
    for (name, m) in all_maps(true) {
        maps += 1;
        let walls = &m.scenario.map.segments;
        let index = SegmentIndex::new(walls.clone(), 2.0).unwrap();
        // every map's walls triangulate, and the walk gives the full scan's ranges too
        let mesh = ScanMesh::new(walls).unwrap_or_else(|e| panic!("{name}: {e:?}"));
        let (mut c, mut c_) = (Scan::default(), Scan::default());
        let mut lidar = Lidar::new(LidarConfig { range_noise_std: 0.0, max_range: 20.0, ..LidarConfig::default() }).unwrap();
        let (mut a, mut b) = (Scan::default(), Scan::default());
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let s = m.scenario.start;
        for k in 0..6 {
            let p = shieldnav_core::world::Pose2::new(s.x + 0.3 * k as f64, s.y - 0.2 * k as f64, 0.9 * k as f64);
            lidar.scan_into(&[walls], p, 0.0, &mut rng, &mut a).unwrap();
            lidar.scan_indexed_into(&index, &[], p, 0.0, &mut rng, &mut b).unwrap();
            // the same hits, up to the rounding of which of two walls meeting at a corner the
            // beam is taken to hit first
            for (i, (x, y)) in a.ranges.iter().zip(&b.ranges).enumerate() {
                assert!(x == y || (x - y).abs() <= 1e-12 * x, "{name} pose {k} beam {i}: {x} vs {y}");
            }
            let st = lidar.last_indexed_stats();
            assert!(st.buckets_occluded > 0 && st.walls_swept < walls.len() / 2, "{name}: {st:?}");
            lidar.scan_mesh_into(&mesh, &index, &[], p, 0.0, &mut rng, &mut c).unwrap();
            for (i, (x, y)) in a.ranges.iter().zip(&c.ranges).enumerate() {
                assert!(x == y || (x - y).abs() <= 1e-12 * x, "{name} pose {k} beam {i}: {x} vs walked {y}");
            }
            let ms = lidar.last_mesh_stats();
            assert!(!ms.fell_back && ms.cells > 0 && ms.walls_swept < walls.len() / 2, "{name}: {ms:?}");
            groups_occluded += st.groups_occluded;
            if k == 0 {
                eprintln!("{name}: {} walls, {st:?}, walked {ms:?}", walls.len());
            }
        }
        // beside wall corners, on the grid's lines, beams along the map's axes: along walls,
        // through corners (the walk casts those beams again)
        let near: Vec<_> = walls.iter().filter(|w| (w.a[0] - s.x).hypot(w.a[1] - s.y) < 6.0).take(12).collect();
        let yaw = m.grid.origin.yaw;
        let (cy, sy) = (yaw.cos(), yaw.sin());
        for (k, w) in near.iter().enumerate() {
            let off = [0.25, 0.0, 0.3][k % 3];
            let (dx, dy) = if k % 2 == 0 { (cy * off, sy * off) } else { (-sy * off, cy * off) };
            let p = shieldnav_core::world::Pose2::new(w.a[0] + dx, w.a[1] + dy, yaw + if k % 2 == 0 { 0.0 } else { std::f64::consts::FRAC_PI_2 });
            lidar.scan_into(&[walls], p, 0.0, &mut rng, &mut a).unwrap();
            lidar.scan_mesh_into(&mesh, &index, &[], p, 0.0, &mut rng, &mut c_).unwrap();
            for (i, (x, y)) in a.ranges.iter().zip(&c_.ranges).enumerate() {
                assert!(x == y || (x - y).abs() <= 1e-12 * x, "{name} beside corner {k} beam {i}: {x} vs walked {y}");
            }
            recast += lidar.last_mesh_stats().beams_recast;
        }
    }
    // some groups of pieces behind nearer walls were skipped whole; beams along the grid's
    // lines were cast again
    assert!(maps == 0 || groups_occluded > 0 && recast > 0, "{groups_occluded} groups skipped, {recast} beams recast");
}

/// The pixels of a 40 × 30 room (free inside a one-cell occupied border), row 0 at the top.
fn room_pixels() -> Vec<u8> {
    room_pgm()[b"P5\n40 30\n255\n".len()..].to_vec()
}

/// The room in every format map_server reads: PGM, PNG (grey, RGB, 16-bit grey), BMP, JPEG and
/// PPM give the same grid and start; colour through its luminance.
#[test]
fn bmp_jpeg_png_and_ppm_maps_load_as_the_pgm_does() {
    use image::ExtendedColorType as C;
    let d = temp_dir("formats");
    let grey = room_pixels();
    let rgb: Vec<u8> = grey.iter().flat_map(|&v| [v, v, v]).collect();
    let grey16: Vec<u8> = grey.iter().flat_map(|&v| (v as u16 * 257).to_be_bytes()).collect();
    std::fs::write(d.join("room.pgm"), room_pgm()).unwrap();
    image::save_buffer(d.join("room.png"), &grey, 40, 30, C::L8).unwrap();
    image::save_buffer(d.join("room_rgb.png"), &rgb, 40, 30, C::Rgb8).unwrap();
    image::save_buffer(d.join("room16.png"), &grey16, 40, 30, C::L16).unwrap();
    image::save_buffer(d.join("room.bmp"), &rgb, 40, 30, C::Rgb8).unwrap();
    image::save_buffer(d.join("room.ppm"), &rgb, 40, 30, C::Rgb8).unwrap();
    // JPEG is lossy: quality 100 keeps 0 and 254 within the thresholds' margins
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 100).encode(&grey, 40, 30, C::L8).unwrap();
    std::fs::write(d.join("room.jpg"), jpeg).unwrap();
    let load = |image: &str| {
        std::fs::write(d.join("m.yaml"), format!("image: {image}\nresolution: 0.1\norigin: [0, 0, 0]\n")).unwrap();
        load_ros_map(d.join("m.yaml"), &RosMapOptions::default()).unwrap_or_else(|e| panic!("{image}: {e}"))
    };
    let want = load("room.pgm");
    assert_eq!(want.grid.cells.iter().filter(|&&c| c == Cell::Free).count(), 38 * 28);
    for image in ["room.png", "room_rgb.png", "room16.png", "room.bmp", "room.jpg", "room.ppm"] {
        let m = load(image);
        assert_eq!(m.grid.cells, want.grid.cells, "{image}");
        assert_eq!(m.scenario.start, want.scenario.start, "{image}");
        assert_eq!(m.scenario.map.segments, want.scenario.map.segments, "{image}");
    }
}

/// CRC-32 of PNG chunks (ISO 3309), to forge headers.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

#[test]
fn a_huge_declared_image_or_a_device_is_refused_before_reading_it() {
    let d = temp_dir("hostile");
    // a 1 x 1 grey PNG whose header then claims 100000 x 100000 pixels (a 10 GB buffer)
    let mut png_bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png_bytes).write_image(&[254], 1, 1, image::ExtendedColorType::L8).unwrap();
    png_bytes[16..24].copy_from_slice(&[100_000u32.to_be_bytes(), 100_000u32.to_be_bytes()].concat());
    let crc = crc32(&png_bytes[12..29]);
    png_bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(d.join("huge.png"), &png_bytes).unwrap();
    std::fs::write(d.join("huge.yaml"), "image: huge.png\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("huge.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("huge.png") && e.contains("100000 x 100000") && e.contains("pixels a map image may have"), "{e}");
    // the same in a PGM header, and in a BMP's
    std::fs::write(d.join("huge.pgm"), b"P5\n100000 100000\n255\n\x00").unwrap();
    std::fs::write(d.join("huge_pgm.yaml"), "image: huge.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("huge_pgm.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("pixels a map image may have"), "{e}");
    let mut bmp = Vec::new();
    image::codecs::bmp::BmpEncoder::new(&mut bmp).encode(&[254, 254, 254], 1, 1, image::ExtendedColorType::Rgb8).unwrap();
    bmp[18..26].copy_from_slice(&[50_000i32.to_le_bytes(), 50_000i32.to_le_bytes()].concat());
    std::fs::write(d.join("huge.bmp"), &bmp).unwrap();
    std::fs::write(d.join("huge_bmp.yaml"), "image: huge.bmp\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
    let e = load_ros_map(d.join("huge_bmp.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
    assert!(e.contains("huge.bmp"), "{e}");
    // an endless device is no image file
    if std::path::Path::new("/dev/zero").exists() {
        std::fs::write(d.join("zero.yaml"), "image: /dev/zero\nresolution: 0.05\norigin: [0, 0, 0]\n").unwrap();
        let e = load_ros_map(d.join("zero.yaml"), &RosMapOptions::default()).unwrap_err().to_string();
        assert!(e.contains("/dev/zero") && e.contains("not a regular file"), "{e}");
    }
}
