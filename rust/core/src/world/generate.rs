//! A seeded procedural generator of inspection sites.
//!
//! Two kinds: an *office* (a main corridor with perpendicular branches, junction pads, rooms
//! behind doorways) and a *tunnel* (one long, self-similar corridor with identical side rooms
//! at a fixed pitch). Corridors are 1.0–3.0 m wide (tunnels 2.0–3.0 m), doorways 0.8–1.4 m,
//! and misplaced furniture narrows the corridors. Everything is carved into a 5 cm occupancy
//! grid; walls are its merged cell edges, furniture boxes are polygons of their own height.
//!
//! Every site is checked, not assumed, traversable: the footprint search of
//! [`super::traverse`] must reach every waypoint (corridor ends, room centres, goal) from the
//! start. Two cheap predictions keep that to one search for almost every site (none of 1,000
//! sampled needed more): a room behind a doorway narrower than the footprint is long, or off
//! a corridor too narrow to turn in easily, is opened only if a search of a small window
//! around the doorway gets the footprint in; and furniture keeps a footprint's length more
//! from doorways (room to turn in). A room the site-wide search cannot reach even without
//! furniture is walled up again; the pieces of furniture next to what they cut off are
//! removed (and, should that not be enough, the fewest pieces, last placed first). The
//! verdict always comes from a search of the grid as finally left, and the grid is exactly the
//! map: walls are its cell edges and each furniture box is drawn as the cells it fills
//! (details in `generate/repair.rs`).
//!
//! ```
//! use shieldnav_core::world::generate::{generate, GeneratorConfig};
//! let a = generate(7, &GeneratorConfig::default()).unwrap();
//! let b = generate(7, &GeneratorConfig::default()).unwrap();
//! assert_eq!(a.scenario, b.scenario); // same seed, same site
//! ```

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::geometry::{Point2, Polygon, Pose2};
use super::grid::{Cell, OccupancyGrid};
use super::map::StaticMap;
use super::scenario::Scenario;
use super::traverse::{footprint_reachability, Footprint};
use crate::error::{Error, Result};
use crate::math::Real;

pub(crate) mod repair;
use repair::{repair, wall_up};

/// How far in from a corridor's closed end its waypoint sits (m): the conservative disc
/// cover of the footprint search needs about a metre in front of the robot's centre.
const END_INSET: Real = 1.4;

/// What kind of site to generate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SiteKind {
    /// Corridors, junctions and rooms.
    Office,
    /// A long self-similar corridor with identical side rooms.
    Tunnel,
}

/// Generator parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneratorConfig {
    /// Office or tunnel.
    pub kind: SiteKind,
    /// The robot footprint every site must admit.
    pub footprint: Footprint,
    /// Clearance margin around the footprint (m).
    pub margin: Real,
    /// Grid cell (m).
    pub resolution: Real,
    /// Wall height (m).
    pub wall_height: Real,
    /// How many pieces of furniture to try to place.
    pub furniture: usize,
}

impl Default for GeneratorConfig {
    fn default() -> Self {
        Self { kind: SiteKind::Office, footprint: Footprint::default(), margin: 0.05, resolution: 0.05, wall_height: 2.5, furniture: 8 }
    }
}

/// A generated site: the scenario plus the checked waypoints and the grid it was carved in.
#[derive(Debug, Clone)]
pub struct GeneratedSite {
    /// Map, start and goal.
    pub scenario: Scenario,
    /// Places the footprint search reached from the start.
    pub waypoints: Vec<Point2>,
    /// The carved grid, furniture included.
    pub grid: OccupancyGrid,
}

/// An axis-aligned corridor (grid-frame metres).
#[derive(Debug, Clone, Copy)]
struct Corridor {
    x0: Real,
    y0: Real,
    x1: Real,
    y1: Real,
}

impl Corridor {
    fn horizontal(&self) -> bool {
        self.x1 - self.x0 >= self.y1 - self.y0
    }
    fn width(&self) -> Real {
        (self.x1 - self.x0).min(self.y1 - self.y0)
    }
}

/// A placed box: its rectangle (grid metres), height, and the cells it filled.
type Furniture = ([Real; 4], Real, Vec<(usize, usize)>);

struct Room {
    rect: [Real; 4],
    door: [Real; 4],
    centre: Point2,
}

/// Generates the site of `seed`. Same seed and config, bit-identical site.
pub fn generate(seed: u64, cfg: &GeneratorConfig) -> Result<GeneratedSite> {
    if !(cfg.resolution.is_finite() && cfg.resolution > 0.0 && cfg.resolution <= 0.1) {
        return Err(Error::invalid("resolution", format!("must be in (0, 0.1] m, got {}", cfg.resolution)));
    }
    if cfg.furniture > 1000 {
        return Err(Error::invalid("furniture", format!("at most 1000 pieces, got {}", cfg.furniture)));
    }
    if !(cfg.margin.is_finite() && (0.0..=0.3).contains(&cfg.margin)) {
        return Err(Error::invalid("margin", format!("must be in [0, 0.3] m, got {}", cfg.margin)));
    }
    if !(cfg.footprint.width.is_finite()
        && cfg.footprint.length.is_finite()
        && cfg.footprint.width > 0.0
        && cfg.footprint.length >= cfg.footprint.width
        && cfg.footprint.width <= 0.8
        && cfg.footprint.length <= 1.6)
    {
        return Err(Error::invalid("footprint", format!("needs 0 < width <= length, width <= 0.8 m, length <= 1.6 m (corridors are 1.0-3.0 m), got {:?}", cfg.footprint)));
    }
    if !(cfg.wall_height.is_finite() && cfg.wall_height > 0.0) {
        return Err(Error::invalid("wall_height", format!("must be finite and > 0, got {}", cfg.wall_height)));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let res = cfg.resolution;
    let (size, corridors, pads) = match cfg.kind {
        SiteKind::Office => office_layout(&mut rng),
        SiteKind::Tunnel => tunnel_layout(&mut rng),
    };
    let mut grid = OccupancyGrid::new((size[0] / res).round() as usize, (size[1] / res).round() as usize, res, Pose2::default(), Cell::Occupied)?;
    for c in corridors.iter().chain(pads.iter()) {
        grid.fill_rect(c.x0, c.y0, c.x1, c.y1, Cell::Free);
    }
    let (rooms, sealed) = carve_rooms(&mut rng, &mut grid, &corridors, cfg);
    let main = corridors[0];
    let yc = 0.5 * (main.y0 + main.y1);
    let start = Pose2::new(main.x0 + END_INSET, yc, 0.0);
    let goal = Pose2::new(main.x1 - END_INSET, yc, 0.0);
    let mut waypoints = vec![[goal.x, goal.y]];
    for c in &corridors[1..] {
        // the branch's far end, END_INSET in from its tip
        let far = if c.horizontal() {
            [if c.x0 < main.x0 { c.x0 + END_INSET } else { c.x1 - END_INSET }, 0.5 * (c.y0 + c.y1)]
        } else if c.y0 < yc {
            [0.5 * (c.x0 + c.x1), c.y0 + END_INSET]
        } else {
            [0.5 * (c.x0 + c.x1), c.y1 - END_INSET]
        };
        waypoints.push(far);
    }
    let mut furniture: Vec<Furniture> = Vec::new();
    let corridor_count = corridors.len();
    for _ in 0..cfg.furniture {
        let c = corridors[rng.random_range(0..corridor_count)];
        let w = c.width();
        let need = cfg.footprint.width + 2.0 * cfg.margin + 3.0 * res + 0.2;
        let depth_max = (w - need).min(0.8);
        let depth = rng.random_range(0.2..0.8);
        let length = rng.random_range(0.4..1.2);
        let height = rng.random_range(0.5..1.5);
        let side = rng.random_bool(0.5);
        if depth > depth_max {
            continue;
        }
        let rect = if c.horizontal() {
            let x = rng.random_range(c.x0 + 2.0..(c.x1 - 2.0 - length).max(c.x0 + 2.5));
            if side {
                [x, c.y1 - depth, x + length, c.y1]
            } else {
                [x, c.y0, x + length, c.y0 + depth]
            }
        } else {
            let y = rng.random_range(c.y0 + 2.0..(c.y1 - 2.0 - length).max(c.y0 + 2.5));
            if side {
                [c.x1 - depth, y, c.x1, y + length]
            } else {
                [c.x0, y, c.x0 + depth, y + length]
            }
        };
        if !grid.rect_is(rect[0], rect[1], rect[2], rect[3], Cell::Free) {
            continue;
        }
        // a piece narrows its corridor but leaves a footprint's width (`need`) to every
        // junction and other piece, and room to turn (`need` plus the footprint's length) to
        // every doorway: otherwise it would block a way and the repair below (one more
        // site-wide search per attempt) would have to take it out again
        let near = |o: &[Real; 4], need: Real| rect[0] - need < o[2] && o[0] < rect[2] + need && rect[1] - need < o[3] && o[1] < rect[3] + need;
        let pad_rects = pads.iter().map(|p| [p.x0, p.y0, p.x1, p.y1]);
        let turn = need + cfg.footprint.length;
        if rooms.iter().any(|r| near(&r.door, turn)) || sealed.iter().copied().chain(pad_rects).any(|o| near(&o, need)) || furniture.iter().any(|(o, _, _)| near(o, need)) {
            continue;
        }
        let cells = cells_in(&grid, rect);
        for &(i, j) in &cells {
            grid.set(i, j, Cell::Occupied);
        }
        // the box as drawn is exactly the cells it fills, so the grid searched is the map
        let snapped = [cells[0].0 as Real * res, cells[0].1 as Real * res, (cells[cells.len() - 1].0 + 1) as Real * res, (cells[cells.len() - 1].1 + 1) as Real * res];
        furniture.push((snapped, height, cells));
    }
    let (open_rooms, kept) = repair(&mut grid, cfg, seed, start, &waypoints, &rooms, &furniture)?;
    let mut keep = kept.iter();
    furniture.retain(|_| *keep.next().unwrap());
    for (r, open) in rooms.iter().zip(&open_rooms) {
        if *open {
            waypoints.push(r.centre);
        }
    }
    // walls come from the grid without furniture (the rooms closed again filled back in);
    // furniture is separate polygons
    set_cells(&mut grid, &furniture, Cell::Free);
    for (r, _) in rooms.iter().zip(&open_rooms).filter(|(_, o)| !**o) {
        wall_up(&mut grid, r);
    }
    let mut map = StaticMap::new();
    map.segments = grid.wall_segments(cfg.wall_height, |c| c == Cell::Occupied);
    set_cells(&mut grid, &furniture, Cell::Occupied);
    for (rect, height, _) in &furniture {
        map.add_polygon(Polygon::rect(rect[0], rect[1], rect[2], rect[3], *height))?;
    }
    let kind = match cfg.kind {
        SiteKind::Office => "office",
        SiteKind::Tunnel => "tunnel",
    };
    let mut scenario = Scenario::new(format!("procedural_{kind}_{seed}"), map, start);
    scenario.goal = Some(goal);
    Ok(GeneratedSite { scenario, waypoints, grid })
}

/// Sets the cells of every piece of `furniture` to `c`.
fn set_cells(grid: &mut OccupancyGrid, furniture: &[Furniture], c: Cell) {
    for (_, _, cells) in furniture {
        for &(i, j) in cells {
            grid.set(i, j, c);
        }
    }
}

fn cells_in(grid: &OccupancyGrid, r: [Real; 4]) -> Vec<(usize, usize)> {
    let res = grid.resolution;
    let (i0, j0) = ((r[0] / res - 0.5).ceil() as usize, (r[1] / res - 0.5).ceil() as usize);
    let (i1, j1) = ((r[2] / res - 0.5).floor() as usize, (r[3] / res - 0.5).floor() as usize);
    (j0..=j1).flat_map(|j| (i0..=i1).map(move |i| (i, j))).collect()
}

/// Main corridor along x through the middle, 2–4 perpendicular branches with junction pads.
fn office_layout(rng: &mut ChaCha8Rng) -> ([Real; 2], Vec<Corridor>, Vec<Corridor>) {
    let size = [64.0, 44.0];
    let yc = 22.0;
    let len = rng.random_range(30.0..54.0);
    let w0 = rng.random_range(1.0..3.0);
    let mut corridors = vec![Corridor { x0: 4.0, y0: yc - 0.5 * w0, x1: 4.0 + len, y1: yc + 0.5 * w0 }];
    let mut pads = Vec::new();
    let n_branch = rng.random_range(2..=4);
    let mut xs: Vec<Real> = Vec::new();
    for _ in 0..40 {
        if xs.len() == n_branch {
            break;
        }
        let x = rng.random_range(10.0..(4.0 + len - 4.0));
        if xs.iter().all(|o| (o - x).abs() >= 8.0) {
            xs.push(x);
        }
    }
    for x in xs {
        let wb = rng.random_range(1.0..3.0);
        let l = rng.random_range(6.0..16.0);
        let up = rng.random_bool(0.5);
        let (y0, y1) = if up { (yc, yc + 0.5 * w0 + l) } else { (yc - 0.5 * w0 - l, yc) };
        corridors.push(Corridor { x0: x - 0.5 * wb, y0, x1: x + 0.5 * wb, y1 });
        let s = w0.max(wb).max(1.8);
        pads.push(Corridor { x0: x - 0.5 * s, y0: yc - 0.5 * s, x1: x + 0.5 * s, y1: yc + 0.5 * s });
    }
    (size, corridors, pads)
}

/// One long corridor, 100–180 m, 2–3 m wide.
fn tunnel_layout(rng: &mut ChaCha8Rng) -> ([Real; 2], Vec<Corridor>, Vec<Corridor>) {
    let len = rng.random_range(100.0..180.0);
    let w = rng.random_range(2.0..3.0);
    let size = [len + 8.0, 16.0];
    (size, vec![Corridor { x0: 4.0, y0: 8.0 - 0.5 * w, x1: 4.0 + len, y1: 8.0 + 0.5 * w }], Vec::new())
}

/// Corridor width beyond the footprint's length from which a doorway at least that long is
/// taken as enterable without [`enterable`]'s search (m).
const ENTRY_TURN: Real = 0.4;
/// How far [`enterable`] looks along the corridor beyond the doorway (m).
const ENTRY_ALONG: Real = 1.5;
/// How far into the room the footprint's centre must get for [`enterable`] (m); its window
/// reaches `ENTRY_DEPTH + ENTRY_ALONG` in.
const ENTRY_DEPTH: Real = 1.0;

/// Whether the footprint, on the centre line of corridor `c` at the doorway (`along`) and
/// heading along the corridor, can get through the doorway `ENTRY_DEPTH` into `room`: a
/// search of the small window of `grid` around the doorway (everything outside it blocked).
///
/// A cheap local prediction of the site-wide search: a room it rejects is never carved, so
/// the site-wide check rarely has to wall one up again (each repair is another site-wide
/// search of the whole grid). The verdict on the site stays with that search.
fn enterable(grid: &OccupancyGrid, cfg: &GeneratorConfig, c: &Corridor, along: Real, side: bool, room: &Room) -> bool {
    let (res, d) = (grid.resolution, room.door);
    let reach = ENTRY_DEPTH + ENTRY_ALONG;
    // the window and the target in (along, across) of the corridor, then in grid metres
    let (window, target) = if c.horizontal() {
        let (y0, y1) = if side { (c.y0, d[3] + reach) } else { (d[1] - reach, c.y1) };
        ([d[0] - ENTRY_ALONG, y0, d[2] + ENTRY_ALONG, y1], [along, if side { d[3] + ENTRY_DEPTH } else { d[1] - ENTRY_DEPTH }])
    } else {
        let (x0, x1) = if side { (c.x0, d[2] + reach) } else { (d[0] - reach, c.x1) };
        ([x0, d[1] - ENTRY_ALONG, x1, d[3] + ENTRY_ALONG], [if side { d[2] + ENTRY_DEPTH } else { d[0] - ENTRY_DEPTH }, along])
    };
    let cell = |v: Real, n: usize| ((v / res).floor().max(0.0) as usize).min(n);
    let (i0, j0) = (cell(window[0], grid.width), cell(window[1], grid.height));
    let (i1, j1) = (cell(window[2], grid.width), cell(window[3], grid.height));
    let Ok(mut sub) = OccupancyGrid::new(i1 - i0, j1 - j0, res, Pose2::new(i0 as Real * res, j0 as Real * res, 0.0), Cell::Occupied) else {
        return true;
    };
    let w = i1 - i0;
    for j in j0..j1 {
        sub.cells[(j - j0) * w..(j - j0 + 1) * w].copy_from_slice(&grid.row(j)[i0..i1]);
    }
    let start = if c.horizontal() { Pose2::new(along, 0.5 * (c.y0 + c.y1), 0.0) } else { Pose2::new(0.5 * (c.x0 + c.x1), along, std::f64::consts::FRAC_PI_2) };
    // a start the footprint does not fit: no prediction, the site-wide search decides
    footprint_reachability(&sub, cfg.footprint, cfg.margin, start).map_or(true, |r| r.reaches(target))
}

/// Rooms behind doorways in the corridor walls. Tunnels get identical rooms at a fixed pitch
/// on alternating sides (self-similar); offices get rooms at random places where they fit.
/// A room the footprint cannot enter ([`enterable`]) is filled in again at once; its doorway
/// is returned in the second list, kept clear of furniture like the open ones.
fn carve_rooms(rng: &mut ChaCha8Rng, grid: &mut OccupancyGrid, corridors: &[Corridor], cfg: &GeneratorConfig) -> (Vec<Room>, Vec<[Real; 4]>) {
    let wall = 0.2;
    let mut rooms = Vec::new();
    let mut sealed = Vec::new();
    let mut try_room = |grid: &mut OccupancyGrid, c: &Corridor, along: Real, side: bool, door: Real, rw: Real, rd: Real| {
        // rectangles in grid metres; `along` is the door centre along the corridor
        let (rect, door_rect) = if c.horizontal() {
            if side {
                ([along - 0.5 * rw, c.y1 + wall, along + 0.5 * rw, c.y1 + wall + rd], [along - 0.5 * door, c.y1 - 0.01, along + 0.5 * door, c.y1 + wall + 0.01])
            } else {
                ([along - 0.5 * rw, c.y0 - wall - rd, along + 0.5 * rw, c.y0 - wall], [along - 0.5 * door, c.y0 - wall - 0.01, along + 0.5 * door, c.y0 + 0.01])
            }
        } else if side {
            ([c.x1 + wall, along - 0.5 * rw, c.x1 + wall + rd, along + 0.5 * rw], [c.x1 - 0.01, along - 0.5 * door, c.x1 + wall + 0.01, along + 0.5 * door])
        } else {
            ([c.x0 - wall - rd, along - 0.5 * rw, c.x0 - wall, along + 0.5 * rw], [c.x0 - wall - 0.01, along - 0.5 * door, c.x0 + 0.01, along + 0.5 * door])
        };
        let keep_out = [rect[0] - wall, rect[1] - wall, rect[2] + wall, rect[3] + wall];
        if !grid.rect_is(keep_out[0], keep_out[1], keep_out[2], keep_out[3], Cell::Occupied) {
            return None;
        }
        grid.fill_rect(rect[0], rect[1], rect[2], rect[3], Cell::Free);
        grid.fill_rect(door_rect[0], door_rect[1], door_rect[2], door_rect[3], Cell::Free);
        let room = Room { rect, door: door_rect, centre: [0.5 * (rect[0] + rect[2]), 0.5 * (rect[1] + rect[3])] };
        // a doorway at least a footprint long off a corridor with room to turn is entered
        // (the site-wide search still checks); the others are searched first
        let roomy = door >= cfg.footprint.length && c.width() >= cfg.footprint.length + ENTRY_TURN;
        if roomy || enterable(grid, cfg, c, along, side, &room) {
            Some(room)
        } else {
            wall_up(grid, &room);
            sealed.push(door_rect);
            None
        }
    };
    match cfg.kind {
        SiteKind::Tunnel => {
            let c = corridors[0];
            let pitch = rng.random_range(8.0..14.0);
            let door = rng.random_range(0.8..1.4);
            let (rw, rd) = (rng.random_range(3.0..5.0), rng.random_range(2.5..3.5));
            let mut along = c.x0 + 0.5 * pitch;
            let mut side = true;
            while along + 0.5 * rw < c.x1 - 2.0 {
                if let Some(r) = try_room(grid, &c, along, side, door, rw, rd) {
                    rooms.push(r);
                }
                side = !side;
                along += pitch;
            }
        }
        SiteKind::Office => {
            let attempts = rng.random_range(6..12);
            for _ in 0..attempts {
                let c = corridors[rng.random_range(0..corridors.len())];
                let (lo, hi) = if c.horizontal() { (c.x0, c.x1) } else { (c.y0, c.y1) };
                if hi - lo < 6.0 {
                    continue;
                }
                let along = rng.random_range(lo + 3.0..hi - 3.0);
                let side = rng.random_bool(0.5);
                let door = rng.random_range(0.8..1.4);
                let (rw, rd) = (rng.random_range(3.0..6.0), rng.random_range(3.0..5.0));
                if let Some(r) = try_room(grid, &c, along, side, door, rw, rd) {
                    rooms.push(r);
                }
            }
        }
    }
    (rooms, sealed)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 12 m corridor of `width` along x at y ∈ [2, 2 + width], with a 4 × 3 m room above it
    /// behind a doorway of `door` in a 0.2 m wall, carved into a fresh grid.
    fn site(width: Real, door: Real) -> (OccupancyGrid, Corridor, Room) {
        let mut g = OccupancyGrid::new(280, 200, 0.05, Pose2::default(), Cell::Occupied).unwrap();
        let c = Corridor { x0: 1.0, y0: 2.0, x1: 13.0, y1: 2.0 + width };
        g.fill_rect(c.x0, c.y0, c.x1, c.y1, Cell::Free);
        let rect = [5.0, c.y1 + 0.2, 9.0, c.y1 + 3.2];
        let door_rect = [7.0 - 0.5 * door, c.y1 - 0.01, 7.0 + 0.5 * door, c.y1 + 0.21];
        g.fill_rect(rect[0], rect[1], rect[2], rect[3], Cell::Free);
        g.fill_rect(door_rect[0], door_rect[1], door_rect[2], door_rect[3], Cell::Free);
        (g, c, Room { rect, door: door_rect, centre: [7.0, c.y1 + 1.7] })
    }

    #[test]
    fn enterable_agrees_with_the_site_wide_search() {
        let cfg = GeneratorConfig::default();
        for (width, door) in [(1.0, 0.8), (1.0, 1.0), (1.2, 0.9), (1.5, 0.8), (2.0, 0.9), (2.5, 0.8), (2.5, 1.4), (3.0, 1.2)] {
            let (g, c, room) = site(width, door);
            let local = enterable(&g, &cfg, &c, 7.0, true, &room);
            let whole = footprint_reachability(&g, cfg.footprint, cfg.margin, Pose2::new(2.0, 0.5 * (c.y0 + c.y1), 0.0)).unwrap().reaches(room.centre);
            assert_eq!(local, whole, "corridor {width} m, doorway {door} m");
        }
        // both verdicts occur: a 0.8 m doorway off a 1 m corridor cannot be turned into
        let (g, c, room) = site(1.0, 0.8);
        assert!(!enterable(&g, &cfg, &c, 7.0, true, &room));
        let (g, c, room) = site(2.5, 1.4);
        assert!(enterable(&g, &cfg, &c, 7.0, true, &room));
    }
}
