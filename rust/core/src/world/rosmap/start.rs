//! The start of a loaded map: a cell inside the building, found from the [`known_area`] and
//! the [`enclosure`] test.

use crate::math::Real;
use crate::world::geometry::Pose2;
use crate::world::grid::{Cell, OccupancyGrid};

/// The minimum clearance (m) an interior start must have: the robot's circumscribed radius.
pub const START_CLEARANCE: Real = 0.6;

/// Share of [`ENCLOSURE_RAYS`] rays from a start that must end on a non-free (occupied or
/// unknown) cell inside the known area (see [`known_area`]), rather than leave it through free
/// cells.
pub const ENCLOSURE: Real = 0.9;

/// Rays of the enclosure test.
pub const ENCLOSURE_RAYS: usize = 64;

/// The known area of a map: the smallest box of cells `[i0, i1] × [j0, j1]` holding every
/// occupied and free cell (none if every cell is unknown). An image is often framed by
/// unknown cells; free space that reaches the edge of this box is as open as free space
/// that reaches the image's border.
pub fn known_area(grid: &OccupancyGrid) -> Option<[usize; 4]> {
    let w = grid.width;
    let known = |k: &usize| grid.cells[*k] != Cell::Unknown;
    let first = (0..grid.cells.len()).find(known)?;
    let last = (0..grid.cells.len()).rev().find(known)?;
    let columns = |i: usize| (first / w..=last / w).any(|j| grid.cells[j * w + i] != Cell::Unknown);
    let i0 = (0..w).find(|&i| columns(i))?;
    let i1 = (i0..w).rev().find(|&i| columns(i))?;
    Some([i0, i1, first / w, last / w])
}

/// Share of rays from cell `(i, j)` that stop on a non-free cell before leaving the known
/// area.
pub fn enclosure(grid: &OccupancyGrid, i: usize, j: usize) -> Real {
    known_area(grid).map_or(0.0, |area| enclosure_in(grid, area, i, j))
}

/// [`enclosure`] with the known area given.
fn enclosure_in(grid: &OccupancyGrid, area: [usize; 4], i: usize, j: usize) -> Real {
    (ENCLOSURE_RAYS - escaped_rays(grid, area, i, j, ENCLOSURE_RAYS)) as Real / ENCLOSURE_RAYS as Real
}

/// How many of the [`ENCLOSURE_RAYS`] rays from cell `(i, j)` leave the known area `area`
/// without ending on a non-free cell, counted until more than `limit` have.
fn escaped_rays(grid: &OccupancyGrid, [i0, i1, j0, j1]: [usize; 4], i: usize, j: usize, limit: usize) -> usize {
    let (x0, x1, y0, y1) = (i0 as Real, (i1 + 1) as Real, j0 as Real, (j1 + 1) as Real);
    let mut escaped = 0;
    for k in 0..ENCLOSURE_RAYS {
        let (s, c) = (k as Real * std::f64::consts::TAU / ENCLOSURE_RAYS as Real).sin_cos();
        let (mut x, mut y) = (i as Real + 0.5, j as Real + 0.5);
        loop {
            x += 0.5 * c;
            y += 0.5 * s;
            if x < x0 || y < y0 || x >= x1 || y >= y1 {
                escaped += 1;
                break;
            }
            if grid.get(x as usize, y as usize) != Cell::Free {
                break;
            }
        }
        if escaped > limit {
            break;
        }
    }
    escaped
}

/// Whether cell `(i, j)` passes the [`enclosure`] test (`enclosure_in(..) >= ENCLOSURE`), its
/// rays cast until too many have escaped to pass: a map of open floor refuses each candidate
/// after a few rays rather than all of them.
fn enclosed_in(grid: &OccupancyGrid, area: [usize; 4], i: usize, j: usize) -> bool {
    // the most rays that may escape: the largest `e` with (RAYS − e) / RAYS ≥ ENCLOSURE
    (0..=ENCLOSURE_RAYS).rev().find(|&e| (ENCLOSURE_RAYS - e) as Real / ENCLOSURE_RAYS as Real >= ENCLOSURE).is_some_and(|allowed| escaped_rays(grid, area, i, j, allowed) <= allowed)
}

/// The start cell: in the largest free 4-connected region that does not reach the edge of the
/// [`known_area`] (the image's border or the unknown frame around the map), the cell of
/// greatest clearance, if that is at least [`START_CLEARANCE`] and it passes the [`enclosure`]
/// test. Maps whose building is open to a free exterior (gaps in the outer wall) have no such
/// region; then the greatest-clearance cell (on a 10-cell lattice) that passes the enclosure
/// test is used.
///
/// A known area without a non-free cell is refused at once (see [`holds_non_free`]).
pub(super) fn interior_start(grid: &OccupancyGrid) -> Option<(Pose2, Real)> {
    let area = known_area(grid)?;
    if !holds_non_free(grid, area) {
        return None;
    }
    search_start(grid, area)
}

/// Whether the known area `area` holds a non-free cell. Without one no cell passes the
/// [`enclosure`] test: a ray stops only on a non-free cell inside the area, so every ray from
/// every cell escapes, and [`search_start`] would find no start after casting the rays of
/// every candidate.
fn holds_non_free(grid: &OccupancyGrid, [i0, i1, j0, j1]: [usize; 4]) -> bool {
    (j0..=j1).any(|j| grid.row(j)[i0..=i1].iter().any(|&c| c != Cell::Free))
}

/// [`interior_start`] with the known area `area` given, its candidates tested one by one.
fn search_start(grid: &OccupancyGrid, area: [usize; 4]) -> Option<(Pose2, Real)> {
    let (w, h) = (grid.width, grid.height);
    let [i0, i1, j0, j1] = area;
    let clearance = grid.distance_field(|c| c != Cell::Free);
    let mut label = vec![u32::MAX; w * h];
    let mut regions: Vec<(usize, usize)> = Vec::new(); // (size, best cell) of interior regions
    let mut next = 0u32;
    let mut stack = Vec::new();
    for s in 0..w * h {
        if grid.cells[s] != Cell::Free || label[s] != u32::MAX {
            continue;
        }
        let (mut size, mut border, mut best) = (0usize, false, s);
        label[s] = next;
        stack.push(s);
        while let Some(c) = stack.pop() {
            size += 1;
            if clearance[c] > clearance[best] || (clearance[c] == clearance[best] && c < best) {
                best = c;
            }
            let (i, j) = (c % w, c / w);
            // free cells lie in the known area: on its edge they touch the image's border or
            // the unknown beyond the map
            border |= i == i0 || j == j0 || i == i1 || j == j1;
            let mut visit = |n: usize| {
                if grid.cells[n] == Cell::Free && label[n] == u32::MAX {
                    label[n] = next;
                    stack.push(n);
                }
            };
            if i > 0 {
                visit(c - 1);
            }
            if i + 1 < w {
                visit(c + 1);
            }
            if j > 0 {
                visit(c - w);
            }
            if j + 1 < h {
                visit(c + w);
            }
        }
        next += 1;
        if !border && clearance[best] >= START_CLEARANCE {
            regions.push((size, best));
        }
    }
    regions.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let enclosed = |c: usize| enclosed_in(grid, area, c % w, c / w);
    let chosen = regions.iter().map(|r| r.1).find(|&c| enclosed(c)).or_else(|| {
        let mut lattice: Vec<usize> = (0..h).step_by(10).flat_map(|j| (0..w).step_by(10).map(move |i| j * w + i)).filter(|&c| grid.cells[c] == Cell::Free && clearance[c] >= START_CLEARANCE).collect();
        lattice.sort_by(|a, b| clearance[*b].total_cmp(&clearance[*a]).then(a.cmp(b)));
        lattice.into_iter().find(|&c| enclosed(c))
    })?;
    let p = grid.cell_center(chosen % w, chosen / w);
    Some((Pose2::new(p[0], p[1], grid.origin.yaw), clearance[chosen]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_enclosure_test_stops_early_with_the_same_verdict() {
        // a room with a door, open floor around: cells inside, in the door and outside
        let mut g = OccupancyGrid::new(120, 100, 0.05, Pose2::new(0.0, 0.0, 0.0), Cell::Free).unwrap();
        for i in 30..90 {
            for j in [30, 70] {
                g.set(i, j, Cell::Occupied);
            }
        }
        for j in 30..71 {
            g.set(30, j, Cell::Occupied);
            if !(45..55).contains(&j) {
                g.set(89, j, Cell::Occupied);
            }
        }
        let area = [0, 119, 0, 99];
        for (i, j) in [(60, 50), (35, 35), (85, 50), (95, 50), (5, 5), (60, 80), (88, 50)] {
            assert_eq!(enclosed_in(&g, area, i, j), enclosure_in(&g, area, i, j) >= ENCLOSURE, "cell ({i}, {j})");
        }
    }

    /// The quick refusal gives the search's verdict: on maps whose known area is all free
    /// (open floor, framed by unknown or not) both find no start; on maps with a non-free cell
    /// in it the search runs.
    #[test]
    fn a_known_area_without_non_free_cells_is_refused_as_the_search_refuses_it() {
        let open = |w: usize, h: usize| OccupancyGrid::new(w, h, 0.05, Pose2::new(0.0, 0.0, 0.0), Cell::Free).unwrap();
        let mut framed = OccupancyGrid::new(90, 70, 0.05, Pose2::new(0.0, 0.0, 0.0), Cell::Unknown).unwrap();
        for j in 5..60 {
            for i in 3..80 {
                framed.set(i, j, Cell::Free);
            }
        }
        // a room of unknown walls inside open floor: no occupied cell, yet an enclosed start
        let mut unknown_room = open(120, 100);
        for i in 30..90 {
            for j in [30, 70] {
                unknown_room.set(i, j, Cell::Unknown);
            }
        }
        for j in 30..71 {
            unknown_room.set(30, j, Cell::Unknown);
            unknown_room.set(89, j, Cell::Unknown);
        }
        // one occupied cell in open floor
        let mut speck = open(100, 80);
        speck.set(50, 40, Cell::Occupied);
        for (name, g, refused) in [("open", open(200, 150), true), ("open, one row", open(300, 1), true), ("framed", framed, true), ("unknown room", unknown_room, false), ("speck", speck, false)] {
            let area = known_area(&g).unwrap();
            assert_eq!(!holds_non_free(&g, area), refused, "{name}");
            let full = search_start(&g, area);
            assert_eq!(interior_start(&g), full, "{name}");
            if refused {
                assert_eq!(full, None, "{name}");
            }
        }
    }
}
