//! Wall contours of a grid map simplified: the cell-edge staircases of a wall that the
//! image drew at an angle become the straight wall it was (Douglas–Peucker within a tolerance;
//! a wall one cell thick keeps at least half of it).

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
/// the staircase it replaces, and within `MAX_CUT` (¼) cells on the solid side where `thin`
/// marks a vertex at a corner of a solid cell one cell thick.
pub fn simplify_walls(grid: &OccupancyGrid, walls: &[Segment], tolerance: Real, fixed: impl Fn(Vertex) -> bool, thin: impl Fn(Vertex) -> bool) -> Result<Vec<Segment>> {
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
    // each chain: its vertices, which of them are kept, its height
    let mut chains: Vec<(Vec<Vertex>, Vec<bool>, Real)> = Vec::new();
    let mut chain: Vec<usize> = Vec::new();
    let emit = |chain: &[usize], closed: bool, chains: &mut Vec<(Vec<Vertex>, Vec<bool>, Real)>| {
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
            douglas_peucker(&pts, i, j, tolerance, &thin, &mut keep);
        }
        chains.push((pts, keep, walls[chain[0]].height));
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
        emit(&chain, false, &mut chains);
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
        emit(&chain, true, &mut chains);
    }
    // a chord that runs over another wall or crosses it (a solid grown onto a neighbour, a
    // thin spur folded flat) gets the vertices it replaced back: cell edges never overlap or
    // cross
    let kept = |keep: &[bool]| (0..keep.len()).filter(|&i| keep[i]).collect::<Vec<usize>>();
    for _ in 0..8 {
        let ends: Vec<Vec<usize>> = chains.iter().map(|c| kept(&c.1)).collect();
        let polylines: Vec<Vec<Vertex>> = chains.iter().zip(&ends).map(|(c, e)| e.iter().map(|&i| c.0[i]).collect()).collect();
        let bad = overlapping(&polylines.iter().map(Vec::as_slice).collect::<Vec<_>>());
        if bad.is_empty() {
            break;
        }
        for (c, k) in bad {
            chains[c].1[ends[c][k]..=ends[c][k + 1]].fill(true);
        }
    }
    let world = |v: Vertex| grid.grid_to_world([v.0 as Real * r, v.1 as Real * r]);
    let mut simplified = Vec::with_capacity(walls.len() / 2);
    for (pts, keep, h) in &chains {
        let kept: Vec<Vertex> = pts.iter().zip(keep).filter(|(_, &k)| k).map(|(p, _)| *p).collect();
        for w in kept.windows(2) {
            simplified.push(Segment::one_sided(world(w[0]), world(w[1]), *h));
        }
    }
    Ok(simplified)
}

/// The segments `(polyline, k)` (from vertex `k` to `k + 1`) of `chains` that meet another
/// segment anywhere but at a shared end: crossing it, touching its interior, or running along
/// it, in order. Exact: the vertices are integers.
fn overlapping(chains: &[&[Vertex]]) -> Vec<(usize, usize)> {
    const BUCKET: i64 = 16;
    // per bucket of the grid of vertices: the segments (index, ends) whose box meets it
    type Bucket = Vec<(usize, Vertex, Vertex)>;
    let mut buckets: HashMap<(i64, i64), Bucket> = HashMap::new();
    let mut ids = Vec::new();
    for (c, pts) in chains.iter().enumerate() {
        for (k, w) in pts.windows(2).enumerate() {
            let (a, b) = (w[0], w[1]);
            let id = ids.len();
            ids.push((c, k));
            for bx in a.0.min(b.0).div_euclid(BUCKET)..=a.0.max(b.0).div_euclid(BUCKET) {
                for by in a.1.min(b.1).div_euclid(BUCKET)..=a.1.max(b.1).div_euclid(BUCKET) {
                    buckets.entry((bx, by)).or_default().push((id, a, b));
                }
            }
        }
    }
    let orient = |a: Vertex, b: Vertex, c: Vertex| ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).signum();
    // `p` strictly inside the segment `a b`
    let inside = |p: Vertex, a: Vertex, b: Vertex| orient(a, b, p) == 0 && p != a && p != b && (a.0.min(b.0)..=a.0.max(b.0)).contains(&p.0) && (a.1.min(b.1)..=a.1.max(b.1)).contains(&p.1);
    let mut bad = vec![false; ids.len()];
    for list in buckets.values() {
        for (k, &(i, a, b)) in list.iter().enumerate() {
            for &(j, p, q) in &list[k + 1..] {
                if bad[i] && bad[j] {
                    continue;
                }
                let same = (a == p && b == q) || (a == q && b == p);
                let cross = orient(a, b, p) * orient(a, b, q) < 0 && orient(p, q, a) * orient(p, q, b) < 0;
                if same || cross || inside(p, a, b) || inside(q, a, b) || inside(a, p, q) || inside(b, p, q) {
                    bad[i] = true;
                    bad[j] = true;
                }
            }
        }
    }
    (0..ids.len()).filter(|&i| bad[i]).map(|i| ids[i]).collect()
}

/// How far (cells) a simplified wall may cut into a solid one cell thick. Plain Douglas–Peucker
/// cuts a lone cell, or a one-cell-wide line drawn at 45°, along its diagonal from both sides
/// into walls of zero thickness: the robot's body collides with them, a LIDAR beam seen end-on
/// passes them. A vertex at a corner of such a cell (`thin` in [`simplify_walls`]) on the free
/// side of a chord (the chord cuts into the cell) is kept beyond this rather than beyond the
/// tolerance, so a lone cell stays a square and a one-cell line keeps at least half its
/// thickness; thicker walls simplify as before. (The limit on every vertex doubles the walls of
/// a map drawn at many angles.)
pub const MAX_CUT: Real = 0.25;

/// Whether the grid vertex `(i, j)` (the lower-left corner of cell `(i, j)`) is a corner of a
/// solid cell one cell thick: free on its left and right, or below and above (`solid` says
/// which cells are solid; cells off the grid are the caller's to answer).
pub fn thin_corner(solid: impl Fn(i64, i64) -> bool, (i, j): Vertex) -> bool {
    let thin = |i: i64, j: i64| solid(i, j) && ((!solid(i - 1, j) && !solid(i + 1, j)) || (!solid(i, j - 1) && !solid(i, j + 1)));
    thin(i - 1, j - 1) || thin(i, j - 1) || thin(i - 1, j) || thin(i, j)
}

/// Marks in `keep` the vertices of `pts[i..=j]` that Douglas–Peucker keeps at `tolerance`
/// (cells), a `thin` vertex on the free side of the chord (right of it: the solid is on the
/// left) beyond [`MAX_CUT`].
fn douglas_peucker(pts: &[Vertex], i: usize, j: usize, tolerance: Real, thin: impl Fn(Vertex) -> bool, keep: &mut [bool]) {
    let cut = MAX_CUT.min(tolerance);
    let mut stack = vec![(i, j)];
    while let Some((i, j)) = stack.pop() {
        if j <= i + 1 {
            continue;
        }
        let (a, b) = (pts[i], pts[j]);
        let (ex, ey) = (b.0 - a.0, b.1 - a.1);
        let (dx, dy) = (ex as Real, ey as Real);
        let len2 = dx * dx + dy * dy;
        // each vertex's excess over what its side allows; the largest splits
        let (mut worst, mut at) = (0.0, i);
        for (m, p) in pts.iter().enumerate().take(j).skip(i + 1) {
            let (qx, qy) = (p.0 - a.0, p.1 - a.1);
            let free_side = ex * qy - ey * qx < 0; // exact: vertices are integers
            let (px, py) = (qx as Real, qy as Real);
            let t = if len2 > 0.0 { ((px * dx + py * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let d = (px - t * dx).hypot(py - t * dy);
            let excess = d - if free_side && thin(*p) { cut } else { tolerance };
            if excess > worst {
                (worst, at) = (excess, m);
            }
        }
        if worst > 0.0 {
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
        let simple = simplify_walls(&g, &raw, 1.0, |_| false, |_| false).unwrap();
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
        let same = simplify_walls(&g, &raw, 0.3, |_| false, |_| false).unwrap();
        let close = |p: [Real; 2], q: [Real; 2]| (p[0] - q[0]).hypot(p[1] - q[1]) < 1e-9;
        assert!(same.len() == raw.len() && raw.iter().all(|s| same.iter().any(|t| close(s.a, t.a) && close(s.b, t.b))));
        // kept vertices: the staircase breaks where told
        let mid = simplify_walls(&g, &raw, 1.0, |v| v == (12, 11) || v == (12, 12), |_| false).unwrap();
        assert!(mid.len() > simple.len());
    }

    /// Whether `p` (world) lies inside the solid the closed one-sided `walls` bound (solid on
    /// their left): the winding number of the walls around it.
    fn inside(walls: &[Segment], p: [Real; 2]) -> bool {
        let mut winding = 0;
        for s in walls {
            let (a, b) = (s.a, s.b);
            let side = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
            if a[1] <= p[1] && b[1] > p[1] && side > 0.0 {
                winding += 1;
            } else if a[1] > p[1] && b[1] <= p[1] && side < 0.0 {
                winding -= 1;
            }
        }
        winding != 0
    }

    #[test]
    fn lone_cells_and_thin_diagonals_keep_their_thickness() {
        // two cells touching at a corner, a lone cell and a one-cell-wide diagonal line: plain
        // Douglas–Peucker collapses each to walls of zero thickness
        let mut g = OccupancyGrid::new(40, 40, 0.1, Pose2::new(0.0, 0.0, 0.0), Cell::Free).unwrap();
        g.set(5, 5, Cell::Occupied);
        g.set(6, 6, Cell::Occupied);
        g.set(20, 5, Cell::Occupied);
        for k in 0..15 {
            g.set(10 + k, 15 + k, Cell::Occupied);
        }
        let raw = g.wall_segments(2.0, |c| c == Cell::Occupied);
        let solid = |i: i64, j: i64| i >= 0 && j >= 0 && i < 40 && j < 40 && g.get(i as usize, j as usize) == Cell::Occupied;
        for tolerance in [1.0, 5.0] {
            let simple = simplify_walls(&g, &raw, tolerance, |v| v == (6, 6), |v| thin_corner(solid, v)).unwrap();
            assert!(simple.iter().all(|s| s.length() >= 0.1 - 1e-9), "{simple:?}");
            // every solid cell stays inside the solid, its centre at least a quarter cell from a
            // wall (half a cell less the most a wall cuts in)
            for (i, j) in (0..40).flat_map(|i| (0..40).map(move |j| (i, j))).filter(|&(i, j)| g.get(i, j) == Cell::Occupied) {
                let c = g.grid_to_world([(i as Real + 0.5) * 0.1, (j as Real + 0.5) * 0.1]);
                assert!(inside(&simple, c), "cell ({i}, {j}) left out at tolerance {tolerance}: {simple:?}");
                let near = simple.iter().map(|s| s.distance_to_point(c)).fold(Real::INFINITY, Real::min);
                assert!(near >= 0.1 * (0.5 - MAX_CUT) - 1e-9, "cell ({i}, {j}): a wall {near} m from its centre");
            }
            // no wall has a twin running back over it
            for s in &simple {
                assert!(!simple.iter().any(|t| t.a == s.b && t.b == s.a), "{s:?} has a twin");
            }
        }
    }

    #[test]
    fn walls_meeting_anywhere_but_at_shared_ends_are_found() {
        let ok: [&[Vertex]; 2] = [&[(0, 0), (4, 0), (4, 4)], &[(4, 4), (0, 4), (0, 0)]];
        assert!(overlapping(&ok).is_empty());
        // a twin, a fold back along itself, a T, a crossing, a collinear overlap
        let twin: [&[Vertex]; 3] = [&[(0, 0), (4, 4)], &[(4, 4), (0, 0)], &[(9, 9), (12, 9)]];
        assert_eq!(overlapping(&twin), [(0, 0), (1, 0)]);
        assert_eq!(overlapping(&[&[(0, 0), (5, 0), (3, 0)]]), [(0, 0), (0, 1)]);
        assert_eq!(overlapping(&[&[(0, 0), (4, 0)], &[(7, 7), (2, 0), (2, 3)]]), [(0, 0), (1, 0), (1, 1)]);
        assert_eq!(overlapping(&[&[(0, 0), (4, 4)], &[(0, 4), (4, 0)]]), [(0, 0), (1, 0)]);
        assert_eq!(overlapping(&[&[(0, 0), (40, 0)], &[(50, 0), (30, 0)]]), [(0, 0), (1, 0)]);
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
        let want = key(&simplify_walls(&g, &raw, 1.0, |_| false, |_| false).unwrap());
        let mut shuffled = raw.clone();
        shuffled.reverse();
        shuffled.rotate_left(7);
        assert_eq!(key(&simplify_walls(&g, &shuffled, 1.0, |_| false, |_| false).unwrap()), want);
    }

    #[test]
    fn zero_keeps_every_wall_and_a_bad_tolerance_is_an_error() {
        let g = grid();
        let raw = g.wall_segments(2.0, |c| c == Cell::Occupied);
        assert_eq!(simplify_walls(&g, &raw, 0.0, |_| false, |_| false).unwrap(), raw);
        for bad in [-1.0, Real::NAN, Real::INFINITY] {
            let e = simplify_walls(&g, &raw, bad, |_| false, |_| false).unwrap_err().to_string();
            assert!(e.contains("simplify"), "{e}");
        }
    }
}
