use super::*;

#[test]
fn query_returns_every_near_wall_once_and_no_far_bucket() {
    let mut walls = Vec::new();
    for k in 0..100 {
        let x = k as Real * 0.7;
        walls.push(Segment::new([x, -1.0], [x + 0.5, 1.0], 2.0));
    }
    walls.push(Segment::new([-5.0, 3.0], [80.0, 3.0], 2.0)); // long, many buckets
    let mut idx = SegmentIndex::new(walls.clone(), 1.5).unwrap();
    let mut near = Vec::new();
    for c in [[10.0, 0.0], [0.0, 0.0], [69.0, 2.0], [-20.0, -20.0]] {
        idx.query_into(c, 4.0, &mut near);
        let within: Vec<&Segment> = walls.iter().filter(|s| s.distance_to_point(c) <= 4.0).collect();
        for w in &within {
            assert_eq!(near.iter().filter(|s| s == w).count(), 1, "{c:?}");
        }
        assert!(near.iter().all(|s| s.distance_to_point(c) <= 4.0 + 1.5 * 2.0 * std::f64::consts::SQRT_2 + 2.0));
    }
}

#[test]
fn pieces_cover_each_wall_inside_their_buckets() {
    let mut walls = vec![Segment::new([-5.0, 3.0], [80.0, 3.0], 2.0), Segment::new([0.1, 0.2], [7.3, 9.9], 2.0), Segment::new([4.0, 4.0], [4.0, 1.0], 2.0)];
    walls.push(Segment::new([2.9, 2.9], [3.1, 3.1], 1.0)); // a bucket corner
                                                           // on a bucket edge that rounds to above it: -3.9 + 3 * 1.0 = -0.8999999999999999
    let edge = vec![Segment::new([0.0, -3.9], [30.0, -3.9], 2.0), Segment::new([23.8, -0.9], [30.0, -0.9], 2.0)];
    for (walls, cell) in [(walls, 1.5), (edge, 1.0)] {
        check_pieces(&walls, cell);
    }
}

/// A tiny cell or walls far apart are an error naming the cell (the bucket count
/// overflowed and the index panicked).
#[test]
fn too_many_buckets_is_an_error_not_a_panic() {
    for (walls, cell) in
        [(vec![Segment::new([0.0, 0.0], [10.0, 0.0], 2.0)], 1e-300), (vec![Segment::new([-1e20, 0.0], [1e20, 0.0], 2.0)], 1.0), (vec![Segment::new([0.0, 0.0], [1e5, 1e5], 2.0)], 0.01)]
    {
        let e = SegmentIndex::new(walls, cell).unwrap_err().to_string();
        assert!(e.contains("`cell`"), "{e}");
    }
}

#[test]
fn group_order_is_nearest_first() {
    let idx = SegmentIndex::new(vec![Segment::new([0.0, 0.0], [4.0, 4.0], 1.0)], 2.0).unwrap();
    for (point, i, j) in [([0.3, 0.2], 0, 0), ([-5.0, 1.7], 0, 0), ([3.9, 2.1], 1, 1), ([10.0, -3.0], 1, 0), ([1.1, 2.9], 0, 1)] {
        let order = idx.group_order(i, j, point);
        let mut sorted = *order;
        sorted.sort();
        assert_eq!(sorted.to_vec(), (0..GROUPS as u8).collect::<Vec<_>>());
        // the first sub-cell is the nearest to the point
        let sub = 2.0 / SUB as Real;
        let d = |g: u8| {
            let c = [i as Real * 2.0 + ((g as usize % SUB) as Real + 0.5) * sub, j as Real * 2.0 + ((g as usize / SUB) as Real + 0.5) * sub];
            (c[0] - point[0]).hypot(c[1] - point[1])
        };
        assert!((0..GROUPS).all(|k| d(order[0]) <= d(k as u8)), "{point:?}: {order:?}");
    }
}

#[test]
fn facing_classes_agree_with_faces() {
    let walls = vec![
        Segment::one_sided([0.0, 0.0], [0.0, 2.0], 1.0),
        Segment::one_sided([1.0, 2.0], [1.0, 0.0], 1.0),
        Segment::one_sided([0.0, 3.0], [2.0, 3.0], 1.0),
        Segment::one_sided([2.0, 4.0], [0.0, 4.0], 1.0),
        Segment::one_sided([0.0, 5.0], [1.0, 6.0], 1.0),
        Segment::new([0.0, 7.0], [1.0, 7.0], 1.0),
    ];
    // facing +x, -x, -y, +y, up and to the left, either way
    let want = [0, 4, 6, 2, 7, SECTORS];
    for (w, k) in walls.iter().zip(want) {
        let pc = Piece { a: w.a, b: w.b, p: w.a, q: w.b, height: 1.0, one_sided: w.one_sided };
        assert_eq!(facing_class(&pc), k, "{w:?}");
        if k < SECTORS {
            // seen from the sector's own direction, not from the opposite one
            let mid = [(w.a[0] + w.b[0]) / 2.0, (w.a[1] + w.b[1]) / 2.0];
            let (s, c) = (k as Real * std::f64::consts::FRAC_PI_4).sin_cos();
            assert!(w.faces([mid[0] + 0.1 * c, mid[1] + 0.1 * s]) && !w.faces([mid[0] - 0.1 * c, mid[1] - 0.1 * s]), "{w:?}");
        }
    }
    // sorted by class within each group, with the class ends
    let idx = SegmentIndex::new(walls, 20.0).unwrap();
    let (pieces, _, groups, _) = idx.bucket_pieces(0, 0);
    assert_eq!((groups[0].bx, groups[0].start, groups[0].ends), ([0.0, 0.0, 2.0, 7.0], 0, [1, 1, 2, 2, 3, 3, 4, 5, 6]));
    assert!(groups[1..].iter().all(|g| g.start == 6 && g.ends == [6; CLASSES] && g.bx[0] > g.bx[2]));
    assert!(pieces.windows(2).all(|w| facing_class(&w[0]) <= facing_class(&w[1])));
}

/// A class's `behind` test never skips a wall the point sees: walls at every angle, many
/// to a group, points all around and on the walls' lines.
#[test]
fn behind_a_class_means_behind_each_of_its_walls() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut walls = Vec::new();
    for _ in 0..400 {
        let a = [rng.random_range(0.0..4.0), rng.random_range(0.0..4.0)];
        let (s, c) = rng.random_range(-3.2..3.2f64).sin_cos();
        let l = rng.random_range(0.05..1.0);
        walls.push(Segment::one_sided(a, [a[0] + l * c, a[1] + l * s], 1.0));
    }
    // and walls at exact multiples of 45° and on the sectors' edges (22.5°)
    for k in 0..16 {
        let (s, c) = (k as Real * std::f64::consts::PI / 8.0).sin_cos();
        walls.push(Segment::one_sided([1.0 + 0.1 * k as Real, 2.0], [1.0 + 0.1 * k as Real + c, 2.0 + s], 1.0));
    }
    let idx = SegmentIndex::new(walls, 4.0).unwrap();
    let (pieces, _, groups, _) = idx.bucket_pieces(0, 0);
    let (mut skipped, mut tested) = (0, 0);
    for trial in 0..4000 {
        let p = if trial % 4 == 0 {
            // on a wall's line
            let w = &pieces[rng.random_range(0..pieces.len())];
            let t = rng.random_range(-3.0..3.0);
            [w.a[0] + t * (w.b[0] - w.a[0]), w.a[1] + t * (w.b[1] - w.a[1])]
        } else {
            [rng.random_range(-6.0..10.0), rng.random_range(-6.0..10.0)]
        };
        for g in groups {
            let mut from = g.start as usize;
            for k in 0..SECTORS {
                let to = g.ends[k] as usize;
                if from < to {
                    tested += 1;
                    if is_behind(&idx.behind(g)[k], p[0], p[1]) {
                        skipped += 1;
                        for pc in &pieces[from..to] {
                            let seg = Segment::one_sided(pc.a, pc.b, 1.0);
                            assert!(!seg.faces(p), "{p:?} sees {pc:?}, class {k}");
                        }
                    }
                }
                from = to;
            }
        }
    }
    // and it does skip: most classes face away from a good share of points
    assert!(skipped * 4 > tested, "{skipped} of {tested}");
}

fn check_pieces(walls: &[Segment], cell: Real) {
    let idx = SegmentIndex::new(walls.to_vec(), cell).unwrap();
    let (nx, ny) = idx.dims();
    // the groups split each bucket's pieces by the sub-cell of their middles, and hold them
    for j in 0..ny {
        for i in 0..nx {
            let (pieces, _, groups, start) = idx.bucket_pieces(i, j);
            // (the index's lanes run on into the next bucket's; a bucket's own end in padding)
            let (l, r) = (idx.lanes(), start..start + pieces.len() + LANES);
            let cut = |v: &Vec<Real>| v[r.clone()].to_vec();
            let lanes = PieceLanes {
                px: cut(&l.px),
                py: cut(&l.py),
                qx: cut(&l.qx),
                qy: cut(&l.qy),
                ax: cut(&l.ax),
                ay: cut(&l.ay),
                ex: cut(&l.ex),
                ey: cut(&l.ey),
                height: cut(&l.height),
                one_sided: l.one_sided[r.clone()].to_vec(),
            };
            let own = PieceLanes::of(pieces);
            let n = pieces.len();
            assert_eq!((&lanes.px[..n], &lanes.py[..n], &lanes.qx[..n], &lanes.qy[..n]), (&own.px[..n], &own.py[..n], &own.qx[..n], &own.qy[..n]));
            assert_eq!((&lanes.ax[..n], &lanes.ay[..n], &lanes.ex[..n], &lanes.ey[..n]), (&own.ax[..n], &own.ay[..n], &own.ex[..n], &own.ey[..n]));
            assert_eq!((&lanes.height[..n], &lanes.one_sided[..n]), (&own.height[..n], &own.one_sided[..n]));
            assert_eq!(own.px.len(), n + LANES);
            assert!(pieces.iter().zip(&lanes.ex).all(|(pc, &ex)| ex == pc.b[0] - pc.a[0]));
            let mut from = 0;
            for (g, grp) in groups.iter().enumerate() {
                assert_eq!(grp.start as usize, from);
                assert!(grp.ends.windows(2).all(|e| e[0] <= e[1]));
                for (k, pc) in pieces.iter().enumerate().take(grp.ends[CLASSES - 1] as usize).skip(from) {
                    let c = grp.ends.iter().position(|&e| k < e as usize).unwrap();
                    assert_eq!(facing_class(pc), c);
                    let sub = cell / SUB as Real;
                    let m = [(pc.p[0] + pc.q[0]) / 2.0, (pc.p[1] + pc.q[1]) / 2.0];
                    let (sx, sy) = (idx.origin()[0] + i as Real * cell + (g % SUB) as Real * sub, idx.origin()[1] + j as Real * cell + (g / SUB) as Real * sub);
                    assert!(m[0] >= sx - 1e-6 && m[0] <= sx + sub + 1e-6 && m[1] >= sy - 1e-6 && m[1] <= sy + sub + 1e-6, "{m:?} off group {g} of ({i}, {j})");
                    assert!(pc.p[0].min(pc.q[0]) >= grp.bx[0] && pc.p[0].max(pc.q[0]) <= grp.bx[2] && pc.p[1].min(pc.q[1]) >= grp.bx[1] && pc.p[1].max(pc.q[1]) <= grp.bx[3]);
                }
                from = grp.ends[CLASSES - 1] as usize;
            }
            assert_eq!(from, pieces.len());
        }
    }
    for (k, w) in walls.iter().enumerate() {
        let mut covered = 0.0;
        for j in 0..ny {
            for i in 0..nx {
                let (pieces, bx, _, _) = idx.bucket_pieces(i, j);
                let (x0, y0) = (idx.origin()[0] + i as Real * cell, idx.origin()[1] + j as Real * cell);
                for pc in pieces.iter().filter(|pc| pc.a == w.a && pc.b == w.b) {
                    for v in [pc.p, pc.q] {
                        assert!(v[0] >= x0 - 1e-6 && v[0] <= x0 + cell + 1e-6 && v[1] >= y0 - 1e-6 && v[1] <= y0 + cell + 1e-6, "wall {k}");
                        assert!(v[0] >= bx[0] && v[0] <= bx[2] && v[1] >= bx[1] && v[1] <= bx[3]);
                        assert!(w.distance_to_point(v) < 1e-12, "wall {k}: {v:?} off the wall");
                    }
                    // same direction as the wall
                    let (e, f) = ([w.b[0] - w.a[0], w.b[1] - w.a[1]], [pc.q[0] - pc.p[0], pc.q[1] - pc.p[1]]);
                    assert!(e[0] * f[0] + e[1] * f[1] >= 0.0);
                    covered += f[0].hypot(f[1]);
                }
            }
        }
        // (neighbouring pieces overlap by the clip's rounding allowance, ~1e-7 m)
        assert!(covered >= w.length() - 1e-9 && covered <= w.length() + 1e-4, "wall {k}: pieces cover {covered} of {}", w.length());
    }
}
