//! Procedural sites: deterministic per seed, within the stated dimensions, traversable.

use shieldnav_core::world::generate::{generate, GeneratorConfig, SiteKind};
use shieldnav_core::world::{footprint_reachability, Cell, Footprint, OccupancyGrid, Pose2};

fn bits(site: &shieldnav_core::world::generate::GeneratedSite) -> Vec<u64> {
    site.scenario.map.segments.iter().flat_map(|s| [s.a[0], s.a[1], s.b[0], s.b[1], s.height]).map(f64::to_bits).collect()
}

#[test]
fn same_seed_is_bit_identical_and_another_seed_differs() {
    for kind in [SiteKind::Office, SiteKind::Tunnel] {
        let cfg = GeneratorConfig { kind, ..Default::default() };
        let a = generate(11, &cfg).unwrap();
        let b = generate(11, &cfg).unwrap();
        let c = generate(12, &cfg).unwrap();
        assert_eq!(bits(&a), bits(&b));
        assert_eq!(a.scenario, b.scenario);
        assert_ne!(bits(&a), bits(&c));
    }
}

/// Independent of the generator's own grid: rasterise the output walls and furniture into a
/// fresh grid (inside = everything the start's flood fill cannot leave) and search again.
fn check_traversable(site: &shieldnav_core::world::generate::GeneratedSite) {
    let map = &site.scenario.map;
    let (lo, hi) = map.bounds().unwrap();
    let res = 0.05;
    let origin = Pose2::new(lo[0] - 0.5, lo[1] - 0.5, 0.0);
    let (w, h) = (((hi[0] - lo[0] + 1.0) / res).ceil() as usize, ((hi[1] - lo[1] + 1.0) / res).ceil() as usize);
    let mut g = OccupancyGrid::new(w, h, res, origin, Cell::Free).unwrap();
    g.rasterize_segments(&map.segments);
    // the outside of the building: flood from the border corner and mark it occupied
    let mut stack = vec![(0usize, 0usize)];
    while let Some((i, j)) = stack.pop() {
        if g.get(i, j) != Cell::Free {
            continue;
        }
        g.set(i, j, Cell::Occupied);
        if i > 0 { stack.push((i - 1, j)); }
        if j > 0 { stack.push((i, j - 1)); }
        if i + 1 < w { stack.push((i + 1, j)); }
        if j + 1 < h { stack.push((i, j + 1)); }
    }
    for p in &map.polygons {
        for j in 0..h {
            for i in 0..w {
                if p.contains(g.cell_center(i, j)) {
                    g.set(i, j, Cell::Occupied);
                }
            }
        }
    }
    let reach = footprint_reachability(&g, Footprint::default(), 0.0, site.scenario.start).unwrap();
    for p in &site.waypoints {
        assert!(reach.reaches(*p), "{}: waypoint {p:?} unreachable", site.scenario.name);
    }
    assert!(reach.reaches([site.scenario.goal.unwrap().x, site.scenario.goal.unwrap().y]));
}

#[test]
fn office_sites_are_traversable_and_have_rooms_and_furniture() {
    let mut rooms = 0;
    let mut furniture = 0;
    for seed in 0..6 {
        let site = generate(seed, &GeneratorConfig::default()).unwrap();
        check_traversable(&site);
        rooms += site.waypoints.len();
        furniture += site.scenario.map.polygons.len();
    }
    assert!(rooms > 6 * 3, "{rooms} waypoints");
    assert!(furniture >= 6, "{furniture} pieces of furniture");
}

#[test]
fn tunnel_sites_are_long_self_similar_and_traversable() {
    for seed in 0..3 {
        let site = generate(seed, &GeneratorConfig { kind: SiteKind::Tunnel, ..Default::default() }).unwrap();
        let (lo, hi) = site.scenario.map.bounds().unwrap();
        assert!(hi[0] - lo[0] >= 100.0);
        assert!(site.waypoints.len() >= 6, "rooms along the tunnel");
        check_traversable(&site);
    }
}

#[test]
fn corridor_widths_are_within_one_to_three_metres() {
    for seed in 0..5 {
        let site = generate(seed, &GeneratorConfig::default()).unwrap();
        // clearance at the start (on the main corridor's centre line) is half the width
        let d = site.grid.distance_field(|c| c == Cell::Occupied);
        let (i, j) = site.grid.world_to_cell([site.scenario.start.x, site.scenario.start.y]).unwrap();
        let half = d[j * site.grid.width + i];
        assert!((0.45..=1.55).contains(&half), "seed {seed}: half width {half}");
    }
}
