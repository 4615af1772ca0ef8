//! The row-wise footprint search reaches exactly the cells a brute-force breadth-first search
//! over single configurations reaches (same rules, written independently in
//! `common/footprint.rs`), on random grids of rooms, corridors, slots and clutter.

#[path = "common/footprint.rs"]
mod footprint;

use footprint::reference_search;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shieldnav_core::world::{footprint_reachability, Cell, Footprint, OccupancyGrid, Pose2};

/// Rooms joined by corridors of random widths, with blocks and speckle, start in room 0.
fn random_grid(seed: u64, res: f64, origin: Pose2) -> (OccupancyGrid, Pose2) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (w, h) = (rng.random_range(60..260), rng.random_range(60..200));
    let mut g = OccupancyGrid::new(w, h, res, origin, Cell::Occupied).unwrap();
    let (wm, hm) = (w as f64 * res, h as f64 * res);
    let mut centres = Vec::new();
    for _ in 0..rng.random_range(2..6) {
        let (cx, cy) = (rng.random_range(0.15 * wm..0.85 * wm), rng.random_range(0.15 * hm..0.85 * hm));
        let (rx, ry) = (rng.random_range(0.5..1.6), rng.random_range(0.5..1.6));
        g.fill_rect(cx - rx, cy - ry, cx + rx, cy + ry, Cell::Free);
        centres.push((cx, cy));
    }
    for p in centres.windows(2) {
        let cw = rng.random_range(0.3..1.4);
        let ((x0, y0), (x1, y1)) = (p[0], p[1]);
        g.fill_rect(x0.min(x1), y0 - 0.5 * cw, x0.max(x1), y0 + 0.5 * cw, Cell::Free);
        g.fill_rect(x1 - 0.5 * cw, y0.min(y1), x1 + 0.5 * cw, y0.max(y1), Cell::Free);
    }
    for _ in 0..rng.random_range(0..12) {
        let (x, y) = (rng.random_range(0.0..wm), rng.random_range(0.0..hm));
        let (a, b) = (rng.random_range(0.05..0.6), rng.random_range(0.05..0.6));
        let c = if rng.random_bool(0.8) { Cell::Occupied } else { Cell::Unknown };
        g.fill_rect(x, y, x + a, y + b, c);
    }
    for _ in 0..rng.random_range(0..40) {
        let (i, j) = (rng.random_range(0..w), rng.random_range(0..h));
        g.set(i, j, Cell::Occupied);
    }
    if rng.random_bool(0.3) {
        // free cells on the border: off-grid space must still count as blocked
        for i in 0..w {
            g.set(i, h - 1, Cell::Free);
        }
    }
    let (cx, cy) = centres[0];
    let start = Pose2::new(cx, cy, rng.random_range(-4.0..4.0));
    (g, origin.compose(&start))
}

fn compare(g: &OccupancyGrid, fp: Footprint, margin: f64, start: Pose2, tag: &str) -> usize {
    let fast = footprint_reachability(g, fp, margin, start);
    let slow = reference_search(g, fp, margin, start);
    let (Ok(fast), Some(slow)) = (&fast, &slow) else {
        assert!(fast.is_err() && slow.is_none(), "{tag}: one search fits the start, the other does not");
        return 0;
    };
    let mut n = 0;
    for j in 0..g.height {
        for i in 0..g.width {
            let want = slow.reached(i, j);
            assert_eq!(fast.reaches(g.cell_center(i, j)), want, "{tag}: cell ({i}, {j})");
            n += want as usize;
        }
    }
    assert_eq!(fast.count(), n, "{tag}: count");
    n
}

#[test]
fn row_search_matches_brute_force_on_random_grids() {
    let mut reached = 0;
    let mut fits = 0;
    for seed in 0..150 {
        let origin = if seed % 3 == 0 { Pose2::new(-3.0, 7.5, 0.4 * seed as f64) } else { Pose2::default() };
        let res = [0.05, 0.05, 0.04, 0.1][seed as usize % 4];
        let (g, start) = random_grid(seed, res, origin);
        let (fp, margin) = match seed % 5 {
            0 => (Footprint { length: 0.6, width: 0.4 }, 0.0),
            1 => (Footprint { length: 0.9, width: 0.3 }, 0.1),
            _ => (Footprint::default(), 0.05),
        };
        let n = compare(&g, fp, margin, start, &format!("seed {seed}"));
        reached += n;
        fits += (n > 0) as usize;
    }
    // the grids are not all trivial: most starts fit and the searches go places
    assert!(fits >= 75 && reached > 100_000, "{fits} fitting starts, {reached} cells");
}

#[test]
fn row_search_matches_brute_force_on_a_generated_site() {
    use shieldnav_core::world::generate::{generate, GeneratorConfig, SiteKind};
    for kind in [SiteKind::Office, SiteKind::Tunnel] {
        let site = generate(1, &GeneratorConfig { kind, ..Default::default() }).unwrap();
        let n = compare(&site.grid, Footprint::default(), 0.05, site.scenario.start, &format!("{kind:?}"));
        assert!(n > 10_000);
    }
}

#[test]
fn row_search_matches_brute_force_on_wide_and_fine_grids() {
    // rows of more than 64 words (a multi-word change mask) and disc offsets of 64 cells or more
    for (w, h, res, fp) in [(4500, 50, 0.05, Footprint::default()), (1400, 200, 0.005, Footprint { length: 0.7, width: 0.3 })] {
        let mut g = OccupancyGrid::new(w, h, res, Pose2::default(), Cell::Occupied).unwrap();
        let (wm, hm) = (w as f64 * res, h as f64 * res);
        g.fill_rect(0.02 * wm, 0.15 * hm, 0.98 * wm, 0.85 * hm, Cell::Free);
        let mut rng = ChaCha8Rng::seed_from_u64(w as u64);
        for _ in 0..w / 150 {
            let x = rng.random_range(0.2 * wm..0.9 * wm);
            let (y0, y1) = if rng.random_bool(0.5) { (0.0, rng.random_range(0.3..0.6) * hm) } else { (rng.random_range(0.4..0.7) * hm, hm) };
            g.fill_rect(x, y0, x + rng.random_range(0.01..0.05) * wm, y1, Cell::Occupied);
        }
        let start = Pose2::new(0.1 * wm, 0.5 * hm, 0.0);
        let n = compare(&g, fp, 0.0, start, &format!("{w} x {h} at {res}"));
        assert!(n > 1000, "{w} x {h}: {n}");
    }
}
