//! Wall contours of a grid map simplified: the cell-edge staircases of a wall that the
//! image drew at an angle become the straight wall it was (Douglas–Peucker, within a tolerance).

use std::collections::HashMap;

use super::geometry::Segment;
use super::grid::OccupancyGrid;
use crate::error::{Error, Result};
use crate::math::Real;

/// A grid vertex: the corner `(i, j)` at `origin ∘ (i·res, j·res)`.
type Vertex = (i64, i64);

/// `walls`, one-sided cell-edge walls of `grid` (as [`OccupancyGrid::wall_segments`] gives
/// them), joined end to start into chains and each chain simplified by Douglas–Peucker with
/// `tolerance` cells: a vertex is dropped while every dropped vertex lies within `tolerance`
/// cells of the straight wall that replaces it. Chains break (their vertices are kept) where
/// `fixed` holds and wherever walls meet other than one in, one out, so the solid side stays
/// on each wall's left, closed contours stay closed and no two contours are joined. A closed
/// contour is anchored at its least vertex and at the vertex farthest from it (a loop through a
/// kept vertex at that vertex and the farthest), so the result depends only on the contour,
/// not on the order of `walls`.
///
/// Every wall keeps its height; a point of a simplified wall lies within `tolerance` cells of
/// the staircase it replaces.
pub fn simplify_walls(grid: &OccupancyGrid, walls: &[Segment], tolerance: Real, fixed: impl Fn(Vertex) -> bool) -> Result<Vec<Segment>> {
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(Error::invalid("simplify", format!("must be finite and >= 0 cells, got {tolerance}")));
    }
    if tolerance == 0.0 || walls.is_empty() {
        return Ok(walls.to_vec());
    }
    let r = grid.resolution;
    let vertex = |p: [Real; 2]| {
        let g = grid.origin.inverse_transform_point(p);
        ((g[0] / r).round() as i64, (g[1] / r).round() as i64)
    };
    let ends: Vec<(Vertex, Vertex)> = walls.iter().map(|s| (vertex(s.a), vertex(s.b))).collect();
    // per vertex: the walls leaving it, and how many arrive
    let mut out: HashMap<Vertex, (u32, u32, usize)> = HashMap::with_capacity(walls.len());
    for (k, &(a, b)) in ends.iter().enumerate() {
        let e = out.entry(a).or_insert((0, 0, k));
        e.0 += 1;
        e.2 = k;
        out.entry(b).or_insert((0, 0, usize::MAX)).1 += 1;
    }
    let pass_through = |v: Vertex| matches!(out.get(&v), Some(&(1, 1, _))) && !fixed(v);
    let next = |v: Vertex| out[&v].2;
    let mut used = vec![false; walls.len()];
    let mut simplified = Vec::with_capacity(walls.len() / 2);
    let mut chain: Vec<usize> = Vec::new();
    let emit = |chain: &[usize], closed: bool, simplified: &mut Vec<Segment>| {
        let mut pts: Vec<Vertex> = chain.iter().map(|&k| ends[k].0).collect();
        pts.push(ends[*chain.last().unwrap()].1);
        if closed {
            // anchored at the least vertex
            let m = (0..pts.len() - 1).min_by_key(|&i| pts[i]).unwrap();
            pts.pop();
            pts.rotate_left(m);
            pts.push(pts[0]);
        }
        let last = pts.len() - 1;
        let spans: Vec<(usize, usize)> = if pts[0] == pts[last] {
            // a loop (closed, or open at a vertex it passes twice): also anchored at the
            // vertex farthest from its start
            let far = (1..last).max_by_key(|&i| ((pts[i].0 - pts[0].0).pow(2) + (pts[i].1 - pts[0].1).pow(2), std::cmp::Reverse(i))).unwrap_or(1);
            vec![(0, far), (far, last)]
        } else {
            vec![(0, last)]
        };
        let mut keep = vec![false; pts.len()];
        for (i, j) in spans {
            keep[i] = true;
            keep[j] = true;
            douglas_peucker(&pts, i, j, tolerance, &mut keep);
        }
        let kept: Vec<Vertex> = pts.iter().zip(&keep).filter(|(_, &k)| k).map(|(p, _)| *p).collect();
        let h = walls[chain[0]].height;
        let world = |v: Vertex| grid.grid_to_world([v.0 as Real * r, v.1 as Real * r]);
        for w in kept.windows(2) {
            simplified.push(Segment::one_sided(world(w[0]), world(w[1]), h));
        }
    };
    // open chains: from each wall leaving a vertex that is not passed through
    for k in 0..walls.len() {
        if used[k] || pass_through(ends[k].0) {
            continue;
        }
        chain.clear();
        let mut w = k;
        loop {
            used[w] = true;
            chain.push(w);
            let v = ends[w].1;
            if !pass_through(v) || used[next(v)] {
                break;
            }
            w = next(v);
        }
        emit(&chain, false, &mut simplified);
    }
    // what is left are closed contours
    for k in 0..walls.len() {
        if used[k] {
            continue;
        }
        chain.clear();
        let mut w = k;
        while !used[w] {
            used[w] = true;
            chain.push(w);
            w = next(ends[w].1);
        }
        emit(&chain, true, &mut simplified);
    }
    Ok(simplified)
}

/// Marks in `keep` the vertices of `pts[i..=j]` that Douglas–Peucker keeps at `tolerance`.
fn douglas_peucker(pts: &[Vertex], i: usize, j: usize, tolerance: Real, keep: &mut [bool]) {
    let mut stack = vec![(i, j)];
    while let Some((i, j)) = stack.pop() {
        if j <= i + 1 {
            continue;
        }
        let (a, b) = (pts[i], pts[j]);
        let (dx, dy) = ((b.0 - a.0) as Real, (b.1 - a.1) as Real);
        let len2 = dx * dx + dy * dy;
        let (mut worst, mut at) = (-1.0, i);
        for (m, p) in pts.iter().enumerate().take(j).skip(i + 1) {
            let (px, py) = ((p.0 - a.0) as Real, (p.1 - a.1) as Real);
            let t = if len2 > 0.0 { ((px * dx + py * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let d = (px - t * dx).hypot(py - t * dy);
            if d > worst {
                (worst, at) = (d, m);
            }
        }
        if worst > tolerance {
            keep[at] = true;
            stack.push((i, at));
            stack.push((at, j));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{Cell, Pose2};

    /// A 45° staircase (the cells below the diagonal of a square) and a block.
    fn grid() -> OccupancyGrid {
        let mut g = OccupancyGrid::new(24, 24, 0.1, Pose2::new(1.0, -2.0, 0.3), Cell::Free).unwrap();
        for j in 0..20 {
            for i in j..20 {
                g.set(i + 2, j + 2, Cell::Occupied);
            }
        }
        for j in 18..21 {
            for i in 3..7 {
                g.set(i, j, Cell::Occupied);
            }
        }
        g
    }

    #[test]
    fn a_staircase_becomes_one_wall_and_a_block_keeps_its_corners() {
        let g = grid();
        let raw = g.wall_segments(2.0, |c| c == Cell::Occupied);
        // the triangle: 20 + 20 staircase edges plus its two legs; the block: 4
        assert_eq!(raw.len(), 20 + 20 + 2 + 4);
        let simple = simplify_walls(&g, &raw, 1.0, |_| false).unwrap();
        // the triangle: hypotenuse and two legs; the block: 4 (its corners are 1 cell off any chord)
        assert_eq!(simple.len(), 3 + 4, "{simple:?}");
        let world = |i: Real, j: Real| g.grid_to_world([i * 0.1, j * 0.1]);
        let hyp = simple.iter().find(|s| s.length() > 2.5).expect("the hypotenuse");
        // from the top of the staircase down to its foot, solid on the left
        for (p, q) in [(hyp.a, world(22.0, 22.0)), (hyp.b, world(2.0, 2.0))] {
            assert!((p[0] - q[0]).hypot(p[1] - q[1]) < 1e-9, "{hyp:?}");
        }
        assert!(simple.iter().all(|s| s.one_sided && s.height == 2.0));
        // every contour closed: each end is another wall's start
        for s in &simple {
            assert_eq!(simple.iter().filter(|t| (t.a[0] - s.b[0]).abs() < 1e-9 && (t.a[1] - s.b[1]).abs() < 1e-9).count(), 1, "{s:?}");
        }
        // a tolerance well below the staircase's corners (0.707 cells off its chord) keeps them all
        let same = simplify_walls(&g, &raw, 0.3, |_| false).unwrap();
        let close = |p: [Real; 2], q: [Real; 2]| (p[0] - q[0]).hypot(p[1] - q[1]) < 1e-9;
        assert!(same.len() == raw.len() && raw.iter().all(|s| same.iter().any(|t| close(s.a, t.a) && close(s.b, t.b))));
        // kept vertices: the staircase breaks where told
        let mid = simplify_walls(&g, &raw, 1.0, |v| v == (12, 11) || v == (12, 12)).unwrap();
        assert!(mid.len() > simple.len());
    }

    #[test]
    fn loops_through_a_shared_corner_keep_their_length() {
        // two cells touching at a corner: each outline leaves and returns to that corner
        let mut g = OccupancyGrid::new(12, 12, 0.1, Pose2::new(0.0, 0.0, 0.0), Cell::Free).unwrap();
        g.set(5, 5, Cell::Occupied);
        g.set(6, 6, Cell::Occupied);
        let raw = g.wall_segments(2.0, |c| c == Cell::Occupied);
        assert_eq!(raw.len(), 8);
        for tolerance in [1.0, 5.0] {
            let simple = simplify_walls(&g, &raw, tolerance, |v| v == (6, 6)).unwrap();
            assert_eq!(simple.len(), 4, "{simple:?}");
            assert!(simple.iter().all(|s| s.length() > 0.1), "{simple:?}");
        }
    }

    #[test]
    fn the_result_does_not_depend_on_the_order_of_the_walls() {
        let g = grid();
        let raw = g.wall_segments(2.0, |c| c == Cell::Occupied);
        let key = |v: &Vec<Segment>| {
            let mut k: Vec<_> = v.iter().map(|s| [s.a[0], s.a[1], s.b[0], s.b[1]].map(Real::to_bits)).collect();
            k.sort();
            k
        };
        let want = key(&simplify_walls(&g, &raw, 1.0, |_| false).unwrap());
        let mut shuffled = raw.clone();
        shuffled.reverse();
        shuffled.rotate_left(7);
        assert_eq!(key(&simplify_walls(&g, &shuffled, 1.0, |_| false).unwrap()), want);
    }

    #[test]
    fn zero_keeps_every_wall_and_a_bad_tolerance_is_an_error() {
        let g = grid();
        let raw = g.wall_segments(2.0, |c| c == Cell::Occupied);
        assert_eq!(simplify_walls(&g, &raw, 0.0, |_| false).unwrap(), raw);
        for bad in [-1.0, Real::NAN, Real::INFINITY] {
            let e = simplify_walls(&g, &raw, bad, |_| false).unwrap_err().to_string();
            assert!(e.contains("simplify"), "{e}");
        }
    }
}
