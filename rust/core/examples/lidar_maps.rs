//! The planar 1024-column scan on every real map, timed as the least of many rounds: the
//! steadier figure on a shared host, whose speed swings within minutes (criterion's median,
//! `cargo bench -p shieldnav-core --bench lidar`, moves with it). The same scans as that bench:
//! 48 per round, from each map's start, the poses of a robot pacing the 0.75 m in front of it
//! (`benches/common.rs`'s `pacing`), none repeated within 100 rounds. With `--poses cycle16`,
//! the 16 poses the benches cycled through earlier instead: the CPU's branch
//! predictors learn that cycle, and those scans ran 10–30 % faster than a robot's would.
//!
//! The start is the map's most open place (the free cell farthest from any wall), where a scan
//! reads the most walls. With `--places K`, the same is timed at `K` seeded places a robot may
//! stand at anywhere in the start's free region (at least 0.6 m from walls), `--place-rounds`
//! rounds each, and the spread of their least times is printed: what a robot's scans cost
//! over a mission through the whole map. `--csv PATH` writes every time measured (the start's
//! and the places') as `map,range_m,where,x,y,least_us` (`benchmarks/plot_scan_cost.py` draws
//! them on the maps).
//!
//! By default the scans go through the bucket index (`Lidar::scan_indexed_into`). With
//! `--mesh` they walk the triangulation of the walls instead (`Lidar::scan_mesh_into`), after
//! a check that every scan of the start's poses equals the index's bit for bit (the beams that
//! differ, the cells entered and walls swept per scan are printed). `World` takes whichever
//! has lately been faster.
//!
//! `cargo run --release -p shieldnav-core --example lidar_maps -- [--range M] [--rounds N] [--poses pacing|cycle16] [--simplify CELLS] [--mesh] [--places K] [--place-rounds N] [--csv PATH] [--maps DIR] [--only NAME]`
//!
//! Defaults: `--range 20` (the LIDAR's default), `--rounds 400`, `--poses pacing`,
//! `--simplify 1` (the maps' default contour tolerance, in cells: `RosMapOptions::simplify`),
//! `--places 0`, `--place-rounds 40`, `--maps ../shared/maps` from the repository's root.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use shieldnav_core::sensors::{Lidar, LidarConfig, Scan, ScanMesh};
use shieldnav_core::world::{load_ros_map, Cell, Pose2, RosMap, RosMapOptions, SegmentIndex};

#[path = "../benches/common.rs"]
mod common;

const SCANS_PER_ROUND: usize = 48;
/// Poses per map for `--poses pacing`.
const POOL: usize = 4800;
/// Least distance (m) from a place of `--places` to a cell that is not free.
const PLACE_CLEARANCE: f64 = 0.6;
/// The scan time the issue asks for (µs).
const TARGET_US: f64 = 15.0;

struct Args {
    range: f64,
    rounds: usize,
    maps: PathBuf,
    only: Option<String>,
    cycle16: bool,
    simplify: f64,
    places: usize,
    place_rounds: usize,
    csv: Option<PathBuf>,
    mesh: bool,
}

fn parse() -> Result<Args, String> {
    let mut args = Args {
        range: 20.0,
        rounds: 400,
        maps: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps"),
        only: None,
        cycle16: false,
        simplify: RosMapOptions::default().simplify,
        places: 0,
        place_rounds: 40,
        csv: None,
        mesh: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--range" => args.range = value()?.parse().map_err(|e| format!("--range: {e}"))?,
            "--rounds" => args.rounds = value()?.parse().map_err(|e| format!("--rounds: {e}"))?,
            "--maps" => args.maps = PathBuf::from(value()?),
            "--only" => args.only = Some(value()?),
            "--simplify" => args.simplify = value()?.parse().map_err(|e| format!("--simplify: {e}"))?,
            "--csv" => args.csv = Some(PathBuf::from(value()?)),
            "--mesh" => args.mesh = true,
            "--places" => args.places = value()?.parse().map_err(|e| format!("--places: {e}"))?,
            "--place-rounds" => args.place_rounds = value()?.parse().map_err(|e| format!("--place-rounds: {e}"))?,
            "--poses" => {
                args.cycle16 = match value()?.as_str() {
                    "pacing" => false,
                    "cycle16" => true,
                    v => return Err(format!("--poses: expected pacing or cycle16, got {v:?}")),
                }
            }
            _ => return Err(format!("unknown argument {flag:?} (expected --range, --rounds, --poses, --simplify, --mesh, --places, --place-rounds, --csv, --maps or --only)")),
        }
    }
    if args.rounds == 0 || args.place_rounds == 0 {
        return Err("--rounds and --place-rounds must be at least 1".into());
    }
    Ok(args)
}

fn main() {
    let args = parse().unwrap_or_else(|e| fail(e));
    let mut dirs: Vec<PathBuf> = match std::fs::read_dir(&args.maps) {
        Ok(d) => d.flatten().map(|e| e.path()).filter(|p| p.is_dir()).collect(),
        Err(e) => fail(format!("cannot read {}: {e}", args.maps.display())),
    };
    dirs.sort();
    let mut csv = args.csv.as_ref().map(|path| {
        let open = || -> std::io::Result<std::io::BufWriter<std::fs::File>> {
            let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
            writeln!(w, "map,range_m,where,x,y,least_us")?;
            Ok(w)
        };
        (open().unwrap_or_else(|e| fail(format!("cannot write {}: {e}", path.display()))), path.clone())
    });
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let poses = if args.cycle16 { "the 16 poses of the benches earlier, cycled" } else { "a robot pacing" };
    println!("range {} m, contours simplified within {} cells, least and median of {} rounds of {SCANS_PER_ROUND} scans, {poses}", args.range, args.simplify, args.rounds);
    println!("{:<22} {:>6} {:>9} {:>9}  what the last scan did", "map", "walls", "least µs", "median µs");
    for dir in dirs {
        let name = dir.file_name().unwrap_or_default().to_string_lossy().into_owned();
        if args.only.as_ref().is_some_and(|o| !name.contains(o.as_str())) {
            continue;
        }
        let Some(yaml) = std::fs::read_dir(&dir).into_iter().flatten().flatten().map(|f| f.path()).find(|p| p.extension().is_some_and(|x| x == "yaml")) else {
            continue;
        };
        let m = match load_ros_map(&yaml, &RosMapOptions { simplify: args.simplify, ..RosMapOptions::default() }) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("lidar_maps: {}: {e}", yaml.display());
                continue;
            }
        };
        let config = LidarConfig { range_noise_std: 0.0, max_range: args.range, ..LidarConfig::default() };
        let mut lidar = Lidar::new(config).unwrap_or_else(|e| fail(e.to_string()));
        let index = SegmentIndex::new(m.scenario.map.segments.clone(), 2.0).expect("a loaded map's walls are finite");
        let start = m.scenario.start;
        let pool: Vec<Pose2> = if args.cycle16 {
            (0..SCANS_PER_ROUND).map(|k| (k + 1) % 16).map(|k| Pose2::new(start.x + 0.05 * k as f64, start.y, 0.3 * k as f64)).collect()
        } else {
            common::pacing([start.x, start.y], [start.x + 0.75, start.y], 0.02, POOL, 1).into_iter().map(|[x, y, yaw]| Pose2::new(x, y, yaw)).collect()
        };
        let mesh = if args.mesh {
            let t = Instant::now();
            let mesh = ScanMesh::new(&m.scenario.map.segments).unwrap_or_else(|e| fail(format!("{name}: no mesh: {e:?}")));
            eprintln!("{name}: mesh of {} cells in {:.1} ms", mesh.cells(), t.elapsed().as_secs_f64() * 1e3);
            let (mut a, mut b) = (Scan::default(), Scan::default());
            let (mut bad, mut cells, mut rec, mut sw) = (0, 0, 0, 0);
            for &p in &pool {
                lidar.scan_indexed_into(&index, &[], p, 0.0, &mut rng, &mut a).unwrap();
                lidar.scan_mesh_into(&mesh, &index, &[], p, 0.0, &mut rng, &mut b).unwrap();
                bad += a.ranges.iter().zip(&b.ranges).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
                cells += lidar.last_mesh_stats().cells;
                rec += lidar.last_mesh_stats().beams_recast;
                sw += lidar.last_mesh_stats().walls_swept;
            }
            eprintln!("{name}: {bad} beams differ over {} scans; {:.0} cells entered, {:.0} walls swept, {rec} recast", pool.len(), cells as f64 / pool.len() as f64, sw as f64 / pool.len() as f64);
            Some(mesh)
        } else {
            None
        };
        let (least, median) = time_scans(&mut lidar, &index, mesh.as_ref(), &pool, args.rounds, &mut rng);
        let mut record = |place: &str, x: f64, y: f64, us: f64| {
            if let Some((w, path)) = csv.as_mut() {
                if let Err(e) = writeln!(w, "{name},{},{place},{x:.3},{y:.3},{us:.3}", args.range) {
                    fail(format!("cannot write {}: {e}", path.display()));
                }
            }
        };
        record("start", start.x, start.y, least);
        let s = lidar.last_indexed_stats();
        println!(
            "{name:<22} {:>6} {:>9.2} {:>9.2}  {} buckets ({} culled), {} pieces read, {} swept, {} culled one by one",
            m.scenario.map.segments.len(),
            least,
            median,
            s.buckets,
            s.buckets_occluded,
            s.walls_visited,
            s.walls_swept,
            s.walls_occluded
        );
        let spots = if args.places > 0 { places(&m, args.places, 7) } else { Vec::new() };
        if args.places > 0 && spots.is_empty() {
            println!("{:<22} no place at least {PLACE_CLEARANCE} m from walls", "");
        }
        if !spots.is_empty() {
            let mut times: Vec<(f64, [f64; 2])> = spots
                .iter()
                .map(|&[x, y]| {
                    let pool: Vec<Pose2> = common::pacing([x - 0.375, y], [x + 0.375, y], 0.02, args.place_rounds * SCANS_PER_ROUND, 1).into_iter().map(|[x, y, yaw]| Pose2::new(x, y, yaw)).collect();
                    (time_scans(&mut lidar, &index, mesh.as_ref(), &pool, args.place_rounds, &mut rng).0, [x, y])
                })
                .collect();
            for &(us, [x, y]) in &times {
                record("place", x, y, us);
            }
            times.sort_by(|a, b| a.0.total_cmp(&b.0));
            let q = |f: f64| times[((times.len() - 1) as f64 * f).round() as usize].0;
            let (worst, at) = times[times.len() - 1];
            println!(
                "{:<22} {} places: least µs median {:.2}, 90th percentile {:.2}, max {:.2} (at {:.1}, {:.1}); {} of {} at most {TARGET_US} µs",
                "",
                times.len(),
                q(0.5),
                q(0.9),
                worst,
                at[0],
                at[1],
                times.iter().filter(|t| t.0 <= TARGET_US).count(),
                times.len()
            );
        }
    }
    if let Some((mut w, path)) = csv {
        if let Err(e) = w.flush() {
            fail(format!("cannot write {}: {e}", path.display()));
        }
        println!("wrote {}", path.display());
    }
}

/// Prints `lidar_maps: {message}` and exits with status 2.
fn fail(message: String) -> ! {
    eprintln!("lidar_maps: {message}");
    std::process::exit(2);
}

/// The least and the median time (µs) per scan over `rounds` rounds of [`SCANS_PER_ROUND`]
/// scans from `pool`'s poses in order (wrapping).
fn time_scans(lidar: &mut Lidar, index: &SegmentIndex, mesh: Option<&ScanMesh>, pool: &[Pose2], rounds: usize, rng: &mut ChaCha8Rng) -> (f64, f64) {
    let mut scan = Scan::default();
    let mut times = Vec::with_capacity(rounds);
    for r in 0..rounds {
        let from = r * SCANS_PER_ROUND % pool.len();
        let t = Instant::now();
        for &p in &pool[from..from + SCANS_PER_ROUND] {
            match mesh {
                Some(mesh) => lidar.scan_mesh_into(mesh, index, &[], p, 0.0, rng, &mut scan),
                None => lidar.scan_indexed_into(index, &[], p, 0.0, rng, &mut scan),
            }
            .expect("a valid pose");
            std::hint::black_box(&scan.ranges);
        }
        times.push(t.elapsed().as_secs_f64() * 1e6 / SCANS_PER_ROUND as f64);
    }
    times.sort_by(f64::total_cmp);
    (times[0], times[times.len() / 2])
}

/// `n` places (seeded, distinct cells) in the free region of `m`'s start (its free cells
/// 4-connected to the start's) at least [`PLACE_CLEARANCE`] from every cell that is not free.
fn places(m: &RosMap, n: usize, seed: u64) -> Vec<[f64; 2]> {
    use rand::seq::SliceRandom;
    let g = &m.grid;
    let clearance = g.distance_field(|c| c != Cell::Free);
    let (w, h) = (g.width, g.height);
    let start = g.world_to_cell([m.scenario.start.x, m.scenario.start.y]).expect("the start lies on the map");
    let mut seen = vec![false; w * h];
    let mut stack = vec![start.1 * w + start.0];
    seen[stack[0]] = true;
    let mut eligible = Vec::new();
    while let Some(c) = stack.pop() {
        if clearance[c] >= PLACE_CLEARANCE {
            eligible.push(c);
        }
        let (i, j) = (c % w, c / w);
        for (ok, nb) in [(i > 0, c.wrapping_sub(1)), (i + 1 < w, c + 1), (j > 0, c.wrapping_sub(w)), (j + 1 < h, c + w)] {
            if ok && !seen[nb] && g.cells[nb] == Cell::Free {
                seen[nb] = true;
                stack.push(nb);
            }
        }
    }
    eligible.sort_unstable();
    eligible.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    eligible.into_iter().take(n).map(|c| g.cell_center(c % w, c / w)).collect()
}
