use super::super::numeric::fast_atan2;
use super::build::ScanMesh;
#[cfg(target_arch = "x86_64")]
use super::kernels::{atan2_rcp14, small_sweeps_avx512, SMALL};
use super::tables::*;
use crate::math::Real;
use crate::simd::SimdLevel;
use crate::world::generate::{generate, GeneratorConfig};
use crate::world::{cross2, sub2, Segment};

/// The table check the walk's unchecked reads rely on passes on built meshes and names
/// each kind of index out of bounds.
#[test]
fn table_check_finds_indices_out_of_bounds() {
    let walls = generate(5, &GeneratorConfig::default()).unwrap().scenario.map.segments;
    let mesh = ScanMesh::new(&walls).unwrap();
    assert_eq!(mesh.check_tables(), Ok(()));
    let cells = mesh.cells() as u32;
    let g = mesh.link.iter().position(|&l| l & LINK_CELL != 0).unwrap();
    let wall = mesh.link.iter().position(|&l| l & LINK_WALL != 0).unwrap();
    let mut broken: Vec<(&str, ScanMesh)> = Vec::new();
    let mut m = mesh.clone();
    m.link[g] = (m.link[g] & !LINK_CELL) | (cells + 1);
    broken.push(("link", m));
    let mut m = mesh.clone();
    m.link[g] |= 15 << LINK_BACK;
    broken.push(("link", m));
    let mut m = mesh.clone();
    *m.start.last_mut().unwrap() += 1;
    broken.push(("start", m));
    let mut m = mesh.clone();
    m.edge_wall[wall] = m.edge_walls.len() as u32;
    broken.push(("edge_wall", m));
    let mut m = mesh.clone();
    m.wall_ids[0] = walls.len() as u32;
    broken.push(("wall_ids", m));
    let mut m = mesh.clone();
    m.grid[0] = cells + 1;
    broken.push(("grid", m));
    let mut m = mesh.clone();
    m.across[g] += 1;
    broken.push(("across", m));
    for (what, m) in broken {
        let err = m.check_tables().unwrap_err();
        assert!(err.0.contains(what), "{what}: {err}");
    }
}

/// Every cell is strictly convex and counter-clockwise, and every link leads to the
/// neighbour's copy of the same edge, walked the other way; wall edges lie on their walls.
#[test]
fn cells_are_convex_and_linked_both_ways() {
    let walls = generate(3, &GeneratorConfig::default()).unwrap().scenario.map.segments;
    let mesh = ScanMesh::new(&walls).unwrap();
    assert!(mesh.cells() > 10);
    let (mut merged, mut kinds) = (0, [0; 4]);
    for c in 1..=mesh.cells() {
        let (cs, at) = mesh.corners(c);
        let k = cs.len();
        assert!((3..=MAX_CORNERS).contains(&k));
        merged += (k > 3) as usize;
        for i in 0..k {
            let (p, q, r) = (cs[i], cs[(i + 1) % k], cs[(i + 2) % k]);
            assert!(cross2(sub2(q, p), sub2(r, q)) > 0.0, "cell {c} corner {i}");
            let link = mesh.link[at + i];
            let nb = (link & LINK_CELL) as usize;
            if nb != 0 {
                let (ns, _) = mesh.corners(nb);
                let b = ((link >> LINK_BACK) & 15) as usize;
                assert_eq!((ns[b], ns[(b + 1) % ns.len()]), (q, p), "cell {c} edge {i}");
            }
            if link & LINK_WALL != 0 {
                let [w0, w1] = mesh.edge_walls[mesh.edge_wall[at + i] as usize];
                for &w in &mesh.wall_ids[w0 as usize..w1 as usize] {
                    let s = &walls[w as usize];
                    assert!(s.distance_to_point(p) < 1e-9 && s.distance_to_point(q) < 1e-9);
                }
                // a kind: walls that are the whole edge, of which those facing the cell
                // (on its left) all run p → q, or all q → p, or there are none
                let kind = (link >> LINK_KIND) & 3;
                kinds[kind as usize] += 1;
                if kind != 0 {
                    let on: Vec<&Segment> = mesh.wall_ids[w0 as usize..w1 as usize].iter().map(|&w| &walls[w as usize]).collect();
                    assert!(on.iter().all(|s| (s.a, s.b) == (p, q) || (s.a, s.b) == (q, p)), "cell {c} edge {i}");
                    let facing: Vec<_> = on.iter().filter(|s| !s.one_sided || (s.a, s.b) == (q, p)).map(|s| (s.a, s.b)).collect();
                    match kind {
                        WHOLE => assert!(!facing.is_empty() && facing.iter().all(|&e| e == (p, q))),
                        WHOLE_BACK => assert!(!facing.is_empty() && facing.iter().all(|&e| e == (q, p))),
                        _ => assert!(facing.is_empty()),
                    }
                }
            }
        }
    }
    assert!(merged > 0, "no triangles merged");
    // walls seen from their front and from their back (one-sided)
    assert!(kinds[WHOLE_BACK as usize] > 0 && kinds[BEHIND as usize] > 0, "{kinds:?}");
}

/// An edge's kind as each of its two cells sees it: a thin wall outlined both ways (two
/// one-sided walls) blocks from either side as the wall facing it; a two-sided wall given
/// twice is one wall; a one-sided wall seen from behind blocks nothing; a two-sided wall
/// and a one-sided one facing the same cell are tested one by one.
#[test]
fn edge_kinds_as_each_side_sees_them() {
    let (a, b) = ([1.0, 1.0], [3.0, 1.5]);
    let kinds_of = |walls: &[Segment]| {
        let mut all = walls.to_vec();
        all.extend([Segment::new([0.0, 0.0], [4.0, 0.0], 1.0), Segment::new([4.0, 0.0], [4.0, 3.0], 1.0), Segment::new([4.0, 3.0], [0.0, 3.0], 1.0), Segment::new([0.0, 3.0], [0.0, 0.0], 1.0)]);
        let mesh = ScanMesh::new(&all).unwrap();
        // (the kind from the cell on the left of a → b, then from the one on its right)
        let mut seen = [None, None];
        for c in 1..=mesh.cells() {
            let (cs, at) = mesh.corners(c);
            for i in 0..cs.len() {
                let (p, q) = (cs[i], cs[(i + 1) % cs.len()]);
                let kind = (mesh.link[at + i] >> LINK_KIND) & 3;
                if (p, q) == (a, b) {
                    seen[0] = Some(kind);
                } else if (p, q) == (b, a) {
                    seen[1] = Some(kind);
                }
            }
        }
        [seen[0].unwrap(), seen[1].unwrap()]
    };
    assert_eq!(kinds_of(&[Segment::new(a, b, 1.0)]), [WHOLE, WHOLE_BACK]);
    assert_eq!(kinds_of(&[Segment::one_sided(a, b, 1.0)]), [BEHIND, WHOLE_BACK]);
    assert_eq!(kinds_of(&[Segment::one_sided(a, b, 1.0), Segment::one_sided(b, a, 1.0)]), [WHOLE_BACK, WHOLE_BACK]);
    assert_eq!(kinds_of(&[Segment::new(b, a, 1.0), Segment::new(b, a, 1.0)]), [WHOLE_BACK, WHOLE]);
    assert_eq!(kinds_of(&[Segment::one_sided(a, b, 1.0), Segment::one_sided(a, b, 2.0)]), [BEHIND, WHOLE_BACK]);
    assert_eq!(kinds_of(&[Segment::new(a, b, 1.0), Segment::one_sided(b, a, 1.0)]), [0, WHOLE_BACK]);
}

/// Whether this CPU runs AVX-512 (else the test says it is skipped).
#[cfg(target_arch = "x86_64")]
fn runs_avx512() -> bool {
    let yes = SimdLevel::detect() == SimdLevel::Avx512;
    if !yes {
        eprintln!("SKIPPED: no AVX-512 on this CPU");
    }
    yes
}

/// The sweeps of a few beams taken eight beams at once give each sweep's own ranges (and
/// whether a beam is left without one), bit for bit: walls across their beams, walls some
/// beams miss, walls along beam 0 (parallel to it, the beam on or beside the wall's line),
/// runs across column 0, ranges already partly filled; the longer sweeps and those of
/// several walls are left listed, in order.
#[cfg(target_arch = "x86_64")]
#[test]
fn small_sweeps_equal_each_sweep_alone() {
    use rand::{Rng, SeedableRng};
    if !runs_avx512() {
        return;
    }
    let lidar = super::super::beams::Beams::new(crate::sensors::LidarConfig { columns: 1024, range_noise_std: 0.0, ..Default::default() }).unwrap();
    let n = 1024i32;
    let step = std::f64::consts::TAU / n as Real;
    let at = |j: Real, d: Real| [d * (j * step).cos(), d * (j * step).sin()];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let (mut parallel, mut missing, mut hit) = (0, 0, 0);
    for round in 0..200 {
        let mut sweeps = Vec::new();
        let mut j = rng.random_range(-3..1);
        while j < n - 12 {
            let count = if sweeps.is_empty() { rng.random_range(1 - j..=4) } else { rng.random_range(1..=6) };
            let (j0, j1) = (j as Real, (j + count - 1) as Real);
            let (a, b) = match if sweeps.is_empty() && round % 2 == 0 { 2 } else { rng.random_range(0..4) } {
                // across the run's beams, or short of its ends
                0 => (at(j0 - 0.4, rng.random_range(0.5..15.0)), at(j1 + 0.4, rng.random_range(0.5..15.0))),
                1 => (at(j0 + 0.3, rng.random_range(0.5..15.0)), at(j1 - 0.3, rng.random_range(0.5..15.0))),
                // along beam 0 (on its line, or beside it), for runs over it
                2 if j <= 0 && j + count > 0 => {
                    let y = if rng.random_bool(0.5) { 0.0 } else { 0.5 };
                    if rng.random_bool(0.5) {
                        ([1.0, y], [4.0, y])
                    } else {
                        ([4.0, y], [1.0, y])
                    }
                }
                _ => (at(rng.random_range(0.0..n as Real), rng.random_range(0.5..15.0)), at(rng.random_range(0.0..n as Real), rng.random_range(0.5..15.0))),
            };
            let edge = if rng.random_bool(0.1) { 7 } else { NONE };
            sweeps.push(Sweep { a, b, j0: j, j1: j + count, edge });
            j += count + rng.random_range(0..3);
        }
        let start: Vec<Real> = (0..n).map(|_| if rng.random_bool(0.2) { rng.random_range(0.5..15.0) } else { Real::INFINITY }).collect();
        let (mut want, mut want_missed, mut want_big) = (start.clone(), false, Vec::new());
        for (i, sw) in sweeps.iter().enumerate() {
            let count = (sw.j1 - sw.j0) as usize;
            if sw.edge == NONE && count <= SMALL {
                want_missed |= lidar.sweep_flat(sw.a, sw.b, sw.j0 as i64, count, &mut want);
                let e = sub2(sw.b, sw.a);
                parallel += (sw.j0..sw.j1).any(|j| j == 0 && e[1] == 0.0) as usize;
            } else {
                want_big.push(i as u32);
            }
        }
        let (mut got, mut jobs, mut big) = (start.clone(), Vec::new(), Vec::new());
        // SAFETY: this CPU runs AVX-512
        let got_missed = unsafe { small_sweeps_avx512(&sweeps, &mut jobs, &mut big, (n - 1) as i64, &lidar.az_cos, &lidar.az_sin, &mut got) };
        let diff: Vec<_> = (0..n as usize).filter(|&i| want[i].to_bits() != got[i].to_bits()).map(|i| (i, want[i], got[i])).collect();
        assert!(diff.is_empty(), "round {round}: {diff:?}");
        assert_eq!((got_missed, big), (want_missed, want_big), "round {round}");
        missing += want_missed as usize;
        hit += (0..n as usize).filter(|&i| want[i] < start[i]).count();
    }
    assert!(parallel >= 100 && missing > 100 && hit > 20_000, "parallel {parallel}, missing {missing}, hit {hit}");
}

/// The angle from AVX-512's reciprocal is within its bound (7.3e-5 rad) of `atan2`, all
/// round and at any distance, and the division's within its own (2e-5).
#[cfg(target_arch = "x86_64")]
#[test]
fn reciprocal_angle_is_within_its_bound() {
    if !runs_avx512() {
        return;
    }
    let (mut worst, mut worst_div): (Real, Real) = (0.0, 0.0);
    for k in 0..200_000 {
        let a = k as Real * std::f64::consts::TAU / 200_000.0 - std::f64::consts::PI;
        let d = [1e-3, 0.37, 1.0, 7.9, 150.0][k % 5];
        let (y, x) = (a.sin() * d, a.cos() * d);
        worst = worst.max((atan2_rcp14(y, x) - y.atan2(x)).abs());
        worst_div = worst_div.max((fast_atan2(y, x) - y.atan2(x)).abs());
    }
    // (7.3e-5 rad: 2^-14 from the reciprocal plus the polynomial's 1.1e-5; a beam step at
    // 2 048 columns is 3.07e-3 rad)
    assert!(worst < 7.3e-5 && worst > worst_div && worst_div < 2e-5, "worst {worst}, with the division {worst_div}");
}
