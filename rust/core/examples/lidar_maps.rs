//! The planar 1024-column scan on every real map, timed as the least of many rounds: the
//! steadier figure on a shared host, whose speed swings within minutes (criterion's median,
//! `cargo bench -p shieldnav-core --bench lidar`, moves with it). The same scans as that bench:
//! 48 per round, from each map's start, with the bench's 16 poses.
//!
//! `cargo run --release -p shieldnav-core --example lidar_maps -- [--range M] [--rounds N] [--maps DIR] [--only NAME]`
//!
//! Defaults: `--range 20` (the LIDAR's default), `--rounds 400`, `--maps ../shared/maps` from
//! the repository's root.

use std::path::PathBuf;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use shieldnav_core::sensors::{Lidar, LidarConfig, Scan};
use shieldnav_core::world::{load_ros_map, Pose2, RosMapOptions, SegmentIndex};

const SCANS_PER_ROUND: usize = 48;

struct Args {
    range: f64,
    rounds: usize,
    maps: PathBuf,
    only: Option<String>,
}

fn parse() -> Result<Args, String> {
    let mut args = Args { range: 20.0, rounds: 400, maps: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps"), only: None };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--range" => args.range = value()?.parse().map_err(|e| format!("--range: {e}"))?,
            "--rounds" => args.rounds = value()?.parse().map_err(|e| format!("--rounds: {e}"))?,
            "--maps" => args.maps = PathBuf::from(value()?),
            "--only" => args.only = Some(value()?),
            _ => return Err(format!("unknown argument {flag:?} (expected --range, --rounds, --maps or --only)")),
        }
    }
    if args.rounds == 0 {
        return Err("--rounds must be at least 1".into());
    }
    Ok(args)
}

fn main() {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("lidar_maps: {e}");
            std::process::exit(2);
        }
    };
    let mut dirs: Vec<PathBuf> = match std::fs::read_dir(&args.maps) {
        Ok(d) => d.flatten().map(|e| e.path()).filter(|p| p.is_dir()).collect(),
        Err(e) => {
            eprintln!("lidar_maps: cannot read {}: {e}", args.maps.display());
            std::process::exit(2);
        }
    };
    dirs.sort();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    println!("range {} m, least and median of {} rounds of {SCANS_PER_ROUND} scans", args.range, args.rounds);
    println!("{:<22} {:>6} {:>9} {:>9}  what the last scan did", "map", "walls", "least µs", "median µs");
    for dir in dirs {
        let name = dir.file_name().unwrap_or_default().to_string_lossy().into_owned();
        if args.only.as_ref().is_some_and(|o| !name.contains(o.as_str())) {
            continue;
        }
        let Some(yaml) = std::fs::read_dir(&dir).into_iter().flatten().flatten().map(|f| f.path()).find(|p| p.extension().is_some_and(|x| x == "yaml")) else {
            continue;
        };
        let m = match load_ros_map(&yaml, &RosMapOptions::default()) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("lidar_maps: {}: {e}", yaml.display());
                continue;
            }
        };
        let config = LidarConfig { range_noise_std: 0.0, max_range: args.range, ..LidarConfig::default() };
        let mut lidar = match Lidar::new(config) {
            Ok(l) => l,
            Err(e) => {
                eprintln!("lidar_maps: {e}");
                std::process::exit(2);
            }
        };
        let index = SegmentIndex::new(m.scenario.map.segments.clone(), 2.0).expect("a loaded map's walls are finite");
        let start = m.scenario.start;
        let mut scan = Scan::default();
        let mut rounds = Vec::with_capacity(args.rounds);
        for _ in 0..args.rounds {
            let t = Instant::now();
            for k in 0..SCANS_PER_ROUND {
                // the bench's poses
                let k = (k + 1) % 16;
                let p = Pose2::new(start.x + 0.05 * k as f64, start.y, 0.3 * k as f64);
                lidar.scan_indexed_into(&index, &[], p, 0.0, &mut rng, &mut scan).expect("a valid pose");
                std::hint::black_box(&scan.ranges);
            }
            rounds.push(t.elapsed().as_secs_f64() * 1e6 / SCANS_PER_ROUND as f64);
        }
        rounds.sort_by(f64::total_cmp);
        let s = lidar.last_indexed_stats();
        println!(
            "{name:<22} {:>6} {:>9.2} {:>9.2}  {} buckets ({} culled), {} pieces read, {} swept, {} culled one by one",
            m.scenario.map.segments.len(),
            rounds[0],
            rounds[rounds.len() / 2],
            s.buckets,
            s.buckets_occluded,
            s.walls_visited,
            s.walls_swept,
            s.walls_occluded
        );
    }
}
