//! Checking a generated site and repairing it until every waypoint is reached.
//!
//! One footprint search of the furnished site usually settles it. If something is out of
//! reach, a search without furniture tells the rooms out of reach even then (walled up again,
//! until closing rooms cuts off no other) from what the furniture cut off. The pieces near what was cut off are removed and the site
//! searched again; if that is not enough, the most furniture kept in placement order that
//! leaves everything reachable is found by bisection (reachability only grows as pieces go).
//! Every verdict comes from a search of the grid as it is finally left.

use super::{Furniture, GeneratorConfig, Room};
use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::geometry::{Point2, Pose2};
use crate::world::grid::{Cell, OccupancyGrid};
use crate::world::traverse::{footprint_reachability, Reachability};

/// Fills a room and its doorway back in.
pub(super) fn wall_up(grid: &mut OccupancyGrid, r: &Room) {
    grid.fill_rect(r.rect[0], r.rect[1], r.rect[2], r.rect[3], Cell::Occupied);
    grid.fill_rect(r.door[0], r.door[1], r.door[2], r.door[3], Cell::Occupied);
}

/// Sets `grid` to hold the pieces of `furniture` marked in `keep` (the others removed), with
/// the rooms not `open` walled up.
fn furnish(grid: &mut OccupancyGrid, furniture: &[Furniture], keep: &[bool], rooms: &[Room], open: &[bool]) {
    for ((_, _, cells), k) in furniture.iter().zip(keep) {
        let c = if *k { Cell::Occupied } else { Cell::Free };
        for &(i, j) in cells {
            grid.set(i, j, c);
        }
    }
    for (r, _) in rooms.iter().zip(open).filter(|(_, o)| !**o) {
        wall_up(grid, r);
    }
}

/// Checks the site and repairs it (see the module docs). Returns which rooms stay open and
/// which pieces of furniture stay.
pub(super) fn repair(grid: &mut OccupancyGrid, cfg: &GeneratorConfig, seed: u64, start: Pose2, waypoints: &[Point2], rooms: &[Room], furniture: &[Furniture]) -> Result<(Vec<bool>, Vec<bool>)> {
    let n = furniture.len();
    let search = |grid: &OccupancyGrid| footprint_reachability(grid, cfg.footprint, cfg.margin, start);
    let all_reached = |reach: &Reachability, open: &[bool]| waypoints.iter().all(|p| reach.reaches(*p)) && rooms.iter().zip(open).all(|(r, o)| !o || reach.reaches(r.centre));
    let check = |grid: &mut OccupancyGrid, keep: &[bool], open: &[bool]| -> Result<(bool, Reachability)> {
        furnish(grid, furniture, keep, rooms, open);
        let reach = search(grid)?;
        Ok((all_reached(&reach, open), reach))
    };
    let mut open = vec![true; rooms.len()];
    let all = vec![true; n];
    let (fine, full) = check(grid, &all, &open)?;
    if fine {
        return Ok((open, all));
    }
    // without furniture: a room still out of reach is closed (and closing one can narrow the
    // way to another, so again); the corridors must be reachable
    let none = vec![false; n];
    let mut bare = check(grid, &none, &open)?.1;
    loop {
        if !waypoints.iter().all(|p| bare.reaches(*p)) {
            return Err(Error::invalid("seed", format!("site {seed}: a corridor waypoint is unreachable even without furniture")));
        }
        let mut closed = false;
        for (o, r) in open.iter_mut().zip(rooms) {
            if *o && !bare.reaches(r.centre) {
                *o = false;
                closed = true;
            }
        }
        if !closed {
            break; // `bare` reaches everything: keeping no furniture passes
        }
        if check(grid, &all, &open)?.0 {
            return Ok((open, all));
        }
        bare = check(grid, &none, &open)?.1;
    }
    // what the furniture cut off: the places reached without it, not with it, and the
    // configurations joined to them with it. A piece that cuts them off blocks a footprint
    // (discs and all, within `reach` of its centre) next to them: drop the pieces near them.
    let cut_off: Vec<Point2> = waypoints.iter().chain(rooms.iter().zip(&open).filter(|(_, o)| **o).map(|(r, _)| &r.centre)).filter(|p| !full.reaches(**p)).copied().collect();
    let mut components = Vec::new();
    let mut places = Vec::new();
    for p in &cut_off {
        let before = components.len();
        full.components_at(*p, &mut components);
        if components.len() == before {
            places.push(*p); // not even free with the furniture: the place itself
        }
    }
    let res = grid.resolution;
    let reach = 0.5 * cfg.footprint.length.hypot(cfg.footprint.width) + cfg.margin + 0.4;
    let cells = |x: Real| (x / res).floor() as i32;
    let keep: Vec<bool> = furniture
        .iter()
        .map(|(r, _, _)| {
            let near_place = places.iter().any(|p| p[0] > r[0] - reach && p[0] < r[2] + reach && p[1] > r[1] - reach && p[1] < r[3] + reach);
            !near_place && !full.components_in_box(&components, (cells(r[0] - reach), cells(r[1] - reach), cells(r[2] + reach), cells(r[3] + reach)))
        })
        .collect();
    if keep.iter().any(|k| !k) && check(grid, &keep, &open)?.0 {
        return Ok((open, keep));
    }
    // keeping all `n` pieces fails, none passes: every count below `lo` passes, every count
    // from `hi` fails
    let prefix = |kept: usize| -> Vec<bool> { (0..n).map(|k| k < kept).collect() };
    let (mut lo, mut hi) = (1, n);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if check(grid, &prefix(mid), &open)?.0 {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    furnish(grid, furniture, &prefix(lo - 1), rooms, &open);
    Ok((open, prefix(lo - 1)))
}
