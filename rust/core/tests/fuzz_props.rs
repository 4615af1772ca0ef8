//! Property-based fuzzing (proptest) of the core's parsers and of the shield's filter functions:
//! every input, finite or not, gives `Ok` with finite outputs (a feasible outcome meeting its
//! row and box to the row tolerance) or an `Err`; never a panic.
//!
//! `PROPTEST_CASES` sets the cases per test (default 128; the map-image test runs a twentieth of
//! them, each a map load); `scripts/fuzz.sh` runs them with large counts. A failing case's seed
//! is saved to `tests/regressions/fuzz_props.txt` (proptest's failure persistence) and replayed
//! first by every later run. With `SHIELDNAV_FUZZ_COUNT_FILE` set, each test appends the number
//! of cases it ran to that file.

use std::io::Write;
use std::path::{Path, PathBuf};

use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, TestCaseError, TestRunner};
use shieldnav_core::shield::{project_halfspace_box, solve_rows, BodyState, LinearConstraints, Scan, ScanFilter, Shield, ShieldConfig, ShieldMethod};
use shieldnav_core::world::rosmap::parse_ros_yaml;
use shieldnav_core::world::{load_ros_map, RosMapOptions};

/// `ROW_TOLERANCE` of the shield's QP: a row `gᵀu ≥ b` holds to `1e-9 max(|b|, 1)`.
const ROW_TOLERANCE: f64 = 1e-9;

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(128)
}

/// Runs `test` on `cases() / divisor` values of `strategy`; panics (the test fails) with the
/// shrunk input if one fails or panics.
fn run<S: Strategy>(name: &str, divisor: u32, strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>) {
    let n = (cases() / divisor).max(1);
    let config = Config {
        cases: n,
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/regressions/fuzz_props.txt")))),
        source_file: Some(file!()),
        ..Config::default()
    };
    let mut runner = TestRunner::new(config);
    if let Err(e) = runner.run(&strategy, test) {
        panic!("{name}: {e}");
    }
    if let Ok(path) = std::env::var("SHIELDNAV_FUZZ_COUNT_FILE") {
        let mut f = std::fs::OpenOptions::new().create(true).append(true).open(path).unwrap();
        writeln!(f, "{n}").unwrap();
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |s, (x, y)| s + x * y)
}

fn meets(g: &[f64], u: &[f64], b: f64) -> bool {
    dot(g, u) >= b - ROW_TOLERANCE * b.abs().max(1.0)
}

/// Any f64: mostly ordinary magnitudes, often extreme ones, sometimes NaN or an infinity.
fn real() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => -10.0..10.0f64,
        2 => prop::sample::select(vec![0.0, -0.0, 1e-300, -1e-300, 1e16, -1e16, 1e155, -1e155, 1e300, -1e308, f64::MAX, f64::MIN_POSITIVE]),
        1 => any::<f64>(),
        1 => prop::sample::select(vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY]),
    ]
}

fn finite_real() -> impl Strategy<Value = f64> {
    prop_oneof![8 => -10.0..10.0f64, 2 => prop::sample::select(vec![0.0, 1e-300, -1e-300, 1e16, -1e16, 1e155, -1e155, 1e300, -1e300])]
}

// ------------------------------------------------------------------------------------------
// the YAML parser

const MAP_YAML: &str = include_str!("../../../envs/shieldnav/maps/mit_building31/building_31.yaml");

#[rustfmt::skip]
const TOKENS: [&str; 40] = [
    ":", "[", "]", "{", "}", "-", ",", "#", "'", "\"", "\n", " ", "\t", "\0", "é", "nan", "inf", "-inf", "1e400", "-1e308", "0", "1e-320", "image: ", "resolution: ", "origin: ", "negate: ",
    "occupied_thresh: ", "free_thresh: ", "mode: ", "trinary", "/dev/zero", "..", "&a", "*a", "!!str", "---", "...", "%YAML 1.2\n", "- ", "|\n",
];

#[derive(Debug, Clone)]
enum Edit {
    Delete(usize, usize),
    Insert(usize, String),
    Replace(usize, String),
}

fn edit() -> impl Strategy<Value = Edit> {
    let text = prop_oneof![prop::sample::select(TOKENS.to_vec()).prop_map(str::to_string), ".{0,6}", prop::collection::vec(any::<u8>(), 0..6).prop_map(|b| String::from_utf8_lossy(&b).into_owned())];
    prop_oneof![
        (0..200usize, 0..40usize).prop_map(|(i, n)| Edit::Delete(i, n)),
        (0..200usize, text.clone()).prop_map(|(i, t)| Edit::Insert(i, t)),
        (0..200usize, text).prop_map(|(i, t)| Edit::Replace(i, t))
    ]
}

fn apply(text: &str, edits: &[Edit]) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for e in edits {
        match e {
            Edit::Delete(i, n) => {
                let i = i % (chars.len() + 1);
                let j = (i + n).min(chars.len());
                chars.drain(i..j);
            }
            Edit::Insert(i, t) => {
                let i = i % (chars.len() + 1);
                chars.splice(i..i, t.chars());
            }
            Edit::Replace(i, t) => {
                let i = i % (chars.len() + 1);
                let j = (i + t.chars().count()).min(chars.len());
                chars.splice(i..j, t.chars());
            }
        }
    }
    chars.into_iter().collect()
}

fn check_yaml(text: &str) -> Result<(), TestCaseError> {
    if let Ok(meta) = parse_ros_yaml(text, Path::new("/maps/map.yaml")) {
        prop_assert!(meta.resolution.is_finite() && meta.resolution > 0.0, "{meta:?}");
        prop_assert!(meta.origin.iter().all(|v| v.is_finite()), "{meta:?}");
        prop_assert!(meta.occupied_thresh.is_finite() && meta.free_thresh.is_finite(), "{meta:?}");
    }
    Ok(())
}

#[test]
fn parse_ros_yaml_on_arbitrary_text() {
    let text = prop_oneof![".{0,200}", prop::collection::vec(any::<u8>(), 0..300).prop_map(|b| String::from_utf8_lossy(&b).into_owned())];
    run("parse_ros_yaml_on_arbitrary_text", 1, text, |t| check_yaml(&t));
}

#[test]
fn parse_ros_yaml_on_mutated_map_text() {
    run("parse_ros_yaml_on_mutated_map_text", 1, prop::collection::vec(edit(), 1..6), |edits| check_yaml(&apply(MAP_YAML, &edits)));
}

// ------------------------------------------------------------------------------------------
// the map loader on mutated image bytes

const MAP_PNG: &[u8] = include_bytes!("../../../envs/shieldnav/maps/mit_building31/building_31.png");

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// The PNG's chunks re-written with their lengths and CRCs recomputed (so that a mutation gets
/// past the decoder's checksum test).
fn fix_png(data: &[u8]) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut i = 8;
    while i + 8 <= data.len() {
        let n = u32::from_be_bytes([data[i], data[i + 1], data[i + 2], data[i + 3]]) as usize;
        let end = (i + 8).saturating_add(n).min(data.len());
        let (kind, body) = (&data[i + 4..i + 8], &data[i + 8..end]);
        out.extend_from_slice(&(body.len() as u32).to_be_bytes());
        out.extend_from_slice(kind);
        out.extend_from_slice(body);
        let mut crc_in = kind.to_vec();
        crc_in.extend_from_slice(body);
        out.extend_from_slice(&crc32(&crc_in).to_be_bytes());
        i = end + 4;
    }
    out
}

#[derive(Debug, Clone)]
enum ByteEdit {
    Set(usize, u8),
    Cut(usize, usize),
    Insert(usize, Vec<u8>),
    Size(u32, u32),
}

fn byte_edit() -> impl Strategy<Value = ByteEdit> {
    let len = MAP_PNG.len();
    prop_oneof![
        (0..len, any::<u8>()).prop_map(|(i, b)| ByteEdit::Set(i, b)),
        (16..33usize, prop::sample::select(vec![0u8, 1, 2, 3, 4, 6, 8, 16, 0x7F, 0xFF])).prop_map(|(i, b)| ByteEdit::Set(i, b)),
        (0..len, 1..4000usize).prop_map(|(i, n)| ByteEdit::Cut(i, n)),
        (0..len, prop::collection::vec(any::<u8>(), 1..16)).prop_map(|(i, b)| ByteEdit::Insert(i, b)),
        (any::<u32>(), any::<u32>()).prop_map(|(w, h)| ByteEdit::Size(w, h)),
        (0..3000u32, 0..3000u32).prop_map(|(w, h)| ByteEdit::Size(w, h)),
    ]
}

fn mutate_png(edits: &[ByteEdit], fix: bool) -> Vec<u8> {
    let mut d = MAP_PNG.to_vec();
    for e in edits {
        match e {
            ByteEdit::Set(i, b) => {
                if *i < d.len() {
                    d[*i] = *b;
                }
            }
            ByteEdit::Cut(i, n) => {
                let i = (*i).min(d.len());
                let j = (i + n).min(d.len());
                d.drain(i..j);
            }
            ByteEdit::Insert(i, b) => {
                let i = (*i).min(d.len());
                d.splice(i..i, b.iter().copied());
            }
            ByteEdit::Size(w, h) => {
                if d.len() >= 24 {
                    d[16..20].copy_from_slice(&w.to_be_bytes());
                    d[20..24].copy_from_slice(&h.to_be_bytes());
                }
            }
        }
    }
    if fix {
        fix_png(&d)
    } else {
        d
    }
}

fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shieldnav-proptest-{}-{:?}", std::process::id(), std::thread::current().id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn load_ros_map_on_mutated_image_bytes() {
    let dir = scratch();
    let yaml = dir.join("map.yaml");
    std::fs::write(&yaml, MAP_YAML).unwrap();
    run("load_ros_map_on_mutated_image_bytes", 20, (prop::collection::vec(byte_edit(), 1..5), any::<bool>()), |(edits, fix)| {
        std::fs::write(dir.join("building_31.png"), mutate_png(&edits, fix)).unwrap();
        if let Ok(m) = load_ros_map(&yaml, &RosMapOptions::default()) {
            prop_assert!(m.grid.width > 0 && m.grid.height > 0);
            prop_assert!(m.start_clearance.is_finite());
        }
        Ok(())
    });
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn load_ros_map_on_pgm_headers() {
    let dir = scratch();
    let yaml = dir.join("map.yaml");
    std::fs::write(&yaml, MAP_YAML.replace("building_31.png", "map.pgm")).unwrap();
    let header = (
        prop::sample::select(vec!["P5", "P2", "P6", "P4", "P1", "P7", ""]),
        prop_oneof![0..200u64, prop::sample::select(vec![100_000u64, 1 << 32, u64::MAX])],
        prop_oneof![0..200u64, prop::sample::select(vec![100_000u64, 1 << 32, u64::MAX])],
        prop::sample::select(vec![255u64, 65535, 0, 1, 65536, 99_999_999_999]),
        prop::sample::select(vec!["\n", " ", "\n# c\n", "\t"]),
    );
    run("load_ros_map_on_pgm_headers", 4, (header, any::<u8>(), -40..40i64), |((magic, w, h, maxval, sep), fill, extra)| {
        let mut bytes = format!("{magic}{sep}{w} {h}{sep}{maxval}\n").into_bytes();
        let n = (w.min(200) * h.min(200)) as i64 + extra;
        bytes.extend(std::iter::repeat_n(fill, n.max(0) as usize));
        std::fs::write(dir.join("map.pgm"), bytes).unwrap();
        if let Ok(m) = load_ros_map(&yaml, &RosMapOptions::default()) {
            prop_assert!(m.grid.width > 0 && m.start_clearance.is_finite());
        }
        Ok(())
    });
    std::fs::remove_dir_all(dir).ok();
}

// ------------------------------------------------------------------------------------------
// the shield

fn method() -> impl Strategy<Value = ShieldMethod> {
    prop::sample::select(vec![ShieldMethod::Braking, ShieldMethod::Composite, ShieldMethod::Distance, ShieldMethod::HardMin, ShieldMethod::Unfiltered])
}

#[derive(Debug, Clone)]
struct Spec {
    method: ShieldMethod,
    dim: usize,
    u_max: Option<Vec<f64>>,
    crop: Option<f64>,
    voxel: Option<f64>,
    bins: Option<usize>,
    alpha: f64,
}

fn spec() -> impl Strategy<Value = Spec> {
    (
        method(),
        prop_oneof![3 => Just(2usize), 1 => Just(3usize)],
        prop::option::of(prop::collection::vec(prop::sample::select(vec![1e-300, 1e-3, 0.5, 1.0, 1.6, 1e6]), 3)),
        prop::option::of(prop_oneof![Just(3.5), 1e-3..1e4f64]),
        prop::option::of(1e-4..10.0f64),
        prop::option::of(4..5000usize),
        prop_oneof![Just(2.0), 1e-6..1e6f64],
    )
        .prop_map(|(method, dim, u_max, crop, voxel, bins, alpha)| Spec { method, dim, u_max: u_max.map(|m| m[..dim].to_vec()), crop, voxel, bins, alpha })
}

fn make(s: &Spec) -> Option<Shield> {
    let semi_axes = if s.dim == 2 { vec![0.9, 0.45] } else { vec![0.9, 0.45, 0.6] };
    let scan = ScanFilter { crop_radius: s.crop, height_band: None, voxel_size: s.voxel, angular_bins: s.bins };
    Shield::new(ShieldConfig { semi_axes, method: s.method, u_max: s.u_max.clone(), alpha: s.alpha, scan, ..ShieldConfig::default() }).ok()
}

#[derive(Debug, Clone)]
struct Call {
    points: Vec<f64>,
    u_nom: Vec<f64>,
    yaw: f64,
    omega: f64,
    velocity: Option<[f64; 3]>,
    extra: Option<(Vec<f64>, Vec<f64>)>,
    position: Option<[f64; 3]>,
}

fn call(dim: usize) -> impl Strategy<Value = Call> {
    let scale = prop::sample::select(vec![1.0, 1.0, 1.0, 0.1, 10.0, 1e3, 1e16, 1e155, 1e-300]);
    let points = (prop::collection::vec(prop_oneof![9 => -5.0..5.0f64, 1 => real()], 0..40), scale).prop_map(move |(mut p, s)| {
        p.truncate(p.len() / dim * dim);
        p.iter_mut().for_each(|v| *v *= s);
        p
    });
    let rows = (0..4usize).prop_flat_map(move |k| (prop::collection::vec(real(), k * dim), prop::collection::vec(real(), k)));
    (
        points,
        prop::collection::vec(prop_oneof![4 => -3.0..3.0f64, 1 => real()], dim),
        prop_oneof![4 => -4.0..4.0f64, 1 => real()],
        prop_oneof![4 => -2.0..2.0f64, 1 => real(), 1 => -2e4..2e4f64],
        prop::option::of((-2.0..2.0f64, -2.0..2.0f64, prop_oneof![4 => -2.0..2.0f64, 1 => real()]).prop_map(|(a, b, c)| [a, b, c])),
        prop::option::of(rows),
        prop::option::of([real(), real(), real()]),
    )
        .prop_map(|(points, u_nom, yaw, omega, velocity, extra, position)| Call { points, u_nom, yaw, omega, velocity, extra, position })
}

fn check_filter(s: &Spec, c: &Call) -> Result<(), TestCaseError> {
    let Some(mut shield) = make(s) else { return Ok(()) };
    let dim = s.dim;
    let Ok(scan) = Scan::new_f64(&c.points, dim) else { return Ok(()) };
    let state = if dim == 2 { BodyState::planar(c.yaw, c.omega) } else { BodyState::spatial(shieldnav_core::math::rot_z(c.yaw), [0.0, 0.0, c.omega]) };
    let Ok(mut state) = state else { return Ok(()) };
    if let Some(v) = c.velocity {
        let Ok(with) = state.with_velocity(v) else { return Ok(()) };
        state = with;
    }
    let extra = match &c.extra {
        Some((a, b)) => match LinearConstraints::from_rows(dim, a, b) {
            Ok(rows) => Some(rows),
            Err(_) => return Ok(()),
        },
        None => None,
    };
    let out = match c.position {
        Some(p) => shield.filter_world(&scan, &p, &state, &c.u_nom, extra.as_ref()),
        None => shield.filter_with(&scan, &state, &c.u_nom, extra.as_ref()),
    };
    let Ok(out) = out else { return Ok(()) };
    let u = &out.u[..dim];
    prop_assert!(u.iter().chain(&out.omega).chain(&out.grad_p).all(|v| v.is_finite()), "{out:?}");
    prop_assert!(out.value.is_finite() && out.h_min.is_finite() && out.dh_dt.is_finite(), "{out:?}");
    if s.method == ShieldMethod::Unfiltered {
        prop_assert_eq!(u, &c.u_nom[..]);
        return Ok(());
    }
    let bx: Vec<f64> = match (&s.u_max, s.method) {
        (Some(m), _) => m.clone(),
        (None, ShieldMethod::Braking) => vec![1.6, 0.8, 0.0],
        (None, _) => vec![f64::INFINITY; 3],
    };
    prop_assert!(u.iter().zip(&bx).all(|(v, m)| v.abs() <= *m), "u = {u:?} outside the box {bx:?}");
    if !out.feasible || s.method == ShieldMethod::Braking {
        return Ok(());
    }
    let b = -s.alpha * out.value - out.dh_dt;
    if b.is_finite() && out.num_points > 0 {
        prop_assert!(meets(&out.grad_p[..dim], u, b), "feasible, yet gᵀu = {} < b = {b}: {out:?}", dot(&out.grad_p[..dim], u));
    }
    if let Some(rows) = &extra {
        for k in 0..rows.len() {
            let (a, ck) = rows.row(k);
            prop_assert!(meets(a, u, ck), "feasible, yet extra row {k} misses: {} < {ck}", dot(a, u));
        }
    }
    Ok(())
}

#[test]
fn shield_filter_on_arbitrary_input() {
    run(
        "shield_filter_on_arbitrary_input",
        1,
        spec().prop_flat_map(|s| {
            let d = s.dim;
            (Just(s), call(d))
        }),
        |(s, c)| check_filter(&s, &c),
    );
}

#[test]
fn project_halfspace_box_on_arbitrary_input() {
    let input = (2..4usize).prop_flat_map(|d| {
        (prop::collection::vec(real(), d), prop::collection::vec(real(), d), real(), prop::option::of(prop::collection::vec(prop_oneof![1e-300..1e6f64, real()], d)), prop_oneof![Just(1e-9), real()])
    });
    run("project_halfspace_box_on_arbitrary_input", 1, input, |(u_nom, g, b, u_max, eps)| {
        if let Ok(sol) = project_halfspace_box(&u_nom, &g, b, u_max.as_deref(), eps) {
            let u = &sol.u[..u_nom.len()];
            prop_assert!(u.iter().all(|v| v.is_finite()), "{sol:?}");
            if let Some(m) = &u_max {
                prop_assert!(u.iter().zip(m).all(|(v, m)| v.abs() <= *m), "{sol:?} outside {m:?}");
            }
            if sol.feasible && b.is_finite() {
                prop_assert!(meets(&g, u, b), "feasible, yet gᵀu = {} < {b}", dot(&g, u));
            }
        }
        Ok(())
    });
}

#[test]
fn solve_rows_on_arbitrary_input() {
    let input = (2..4usize).prop_flat_map(|d| {
        (
            prop::collection::vec(prop_oneof![3 => finite_real(), 1 => real()], d),
            (0..5usize).prop_flat_map(move |k| (prop::collection::vec(prop_oneof![4 => -3.0..3.0f64, 1 => real()], k * d), prop::collection::vec(prop_oneof![4 => -3.0..3.0f64, 1 => real()], k))),
            prop::option::of(prop::collection::vec(prop_oneof![0.1..3.0f64, real()], d)),
        )
    });
    run("solve_rows_on_arbitrary_input", 1, input, |(u_nom, (a, c), u_max)| {
        let d = u_nom.len();
        let Ok(rows) = LinearConstraints::from_rows(d, &a, &c) else { return Ok(()) };
        if let Ok(sol) = solve_rows(&u_nom, &rows, u_max.as_deref()) {
            let u = &sol.u[..d];
            prop_assert!(u.iter().all(|v| v.is_finite()), "{sol:?}");
            if let Some(m) = &u_max {
                prop_assert!(u.iter().zip(m).all(|(v, m)| v.abs() <= *m), "{sol:?} outside {m:?}");
            }
            if sol.feasible {
                for k in 0..rows.len() {
                    let (row, ck) = rows.row(k);
                    prop_assert!(meets(row, u, ck), "feasible, yet row {k} misses: {} < {ck}", dot(row, u));
                }
            }
        }
        Ok(())
    });
}
