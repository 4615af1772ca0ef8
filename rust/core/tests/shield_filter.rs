//! The filter QP and the `Shield` API: exactness against Clarabel, the paper's doorway, the
//! odometry-jump invariance, fallbacks and input validation.

mod common;

use common::{random_scan, rng, rot_rpy};
use rand::Rng;
use shieldnav_core::shield::{move_points, project_halfspace_box, solve_rows, BodyState, LinearConstraints, Motion, Scan, ScanFilter, Shield, ShieldConfig, ShieldMethod, SimdLevel};

fn shield(method: ShieldMethod) -> Shield {
    Shield::new(ShieldConfig { method, ..ShieldConfig::default() }).unwrap()
}

#[test]
fn closed_form_matches_clarabel_with_and_without_box() {
    let mut g = rng(21);
    let mut active = 0;
    for trial in 0..300 {
        let d = 2 + trial % 2;
        let u_nom: Vec<f64> = (0..d).map(|_| g.random_range(-2.0..2.0)).collect();
        let row: Vec<f64> = (0..d).map(|_| g.random_range(-3.0..3.0)).collect();
        let b = g.random_range(-2.0..4.0);
        let bound: Vec<f64> = (0..d).map(|_| g.random_range(0.3..1.5)).collect();
        for u_max in [None, Some(bound.as_slice())] {
            let fast = project_halfspace_box(&u_nom, &row, b, u_max, 1e-12).unwrap();
            let mut rows = LinearConstraints::new(d);
            rows.push(&row, b).unwrap();
            let slow = solve_rows(&u_nom, &rows, u_max).unwrap();
            assert_eq!(fast.feasible, slow.feasible, "trial {trial}");
            if fast.feasible {
                for j in 0..d {
                    assert!((fast.u[j] - slow.u[j]).abs() < 1e-6, "trial {trial}: {:?} vs {:?}", fast.u, slow.u);
                }
                // KKT: primal feasibility, and u* − u_nom = μ g + box multipliers
                let gu: f64 = (0..d).map(|j| row[j] * fast.u[j]).sum();
                assert!(gu >= b - 1e-9);
                if fast.active {
                    active += 1;
                }
            } else {
                // least violation: u maximises gᵀu over the box
                let m = u_max.unwrap();
                for j in 0..d {
                    assert_eq!(fast.u[j], m[j].copysign(row[j]));
                }
            }
        }
    }
    assert!(active > 100, "most random cases should bind ({active})");
}

fn doorway(width: f64) -> Vec<f64> {
    // a 0.2 m thick wall across x = 0 with a gap of `width` centred on the robot, points
    // every 2 cm on its faces and on the jambs
    let mut pts = Vec::new();
    let half = width / 2.0;
    let mut y = half;
    while y < 3.0 {
        for x in [-0.1, 0.1] {
            pts.extend_from_slice(&[x, y, x, -y]);
        }
        y += 0.02;
    }
    for k in 1..10 {
        let x = -0.1 + 0.02 * k as f64;
        pts.extend_from_slice(&[x, half, x, -half]);
    }
    pts
}

#[test]
fn distance_baseline_is_infeasible_in_a_doorway_the_ellipse_passes_untouched() {
    let pts = doorway(1.3);
    let scan = Scan::new_f64(&pts, 2).unwrap();
    let state = BodyState::planar(0.0, 0.0).unwrap();
    let u_nom = [0.8, 0.0];
    let comp = shield(ShieldMethod::Composite).filter(&scan, &state, &u_nom).unwrap();
    assert!(comp.feasible && !comp.active, "{comp:?}");
    assert_eq!(&comp.u[..2], &u_nom);
    assert!(comp.value > 0.0 && comp.h_min > 0.0);
    let dist = shield(ShieldMethod::Distance).filter(&scan, &state, &u_nom).unwrap();
    assert!(!dist.feasible, "{dist:?}");
    assert!(dist.h_min < 0.0);
    assert!(dist.u[0] < 0.5, "the fallback must not push on through: {:?}", dist.u);
}

#[test]
fn odometry_jump_moving_robot_and_points_together_changes_nothing() {
    let mut g = rng(3);
    for (dim, axes) in [(2usize, vec![0.9, 0.45]), (3, vec![0.9, 0.45, 0.3])] {
        let cfg = ShieldConfig { semi_axes: axes, u_max: Some(vec![1.0; dim]), ..ShieldConfig::default() };
        let mut s = Shield::new(cfg).unwrap();
        let body = random_scan(&mut g, 400, dim, 2.0);
        let (state, r) = if dim == 2 {
            (BodyState::planar(0.9, 0.3).unwrap(), shieldnav_core::math::rot_z(0.9))
        } else {
            let r = rot_rpy(0.1, -0.1, 0.9);
            (BodyState::spatial(r, [0.1, 0.0, 0.3]).unwrap(), r)
        };
        let u_nom = vec![0.7; dim];
        let mut outs = Vec::new();
        for offset in [0.0, 137.5, -2500.0] {
            let pos = [3.0 + offset, -4.0 - offset, if dim == 3 { 0.5 } else { 0.0 }];
            let world: Vec<f64> = body
                .chunks(dim)
                .flat_map(|c| {
                    let p = [c[0], c[1], if dim == 3 { c[2] } else { 0.0 }];
                    let w = shieldnav_core::math::mat_vec(&r, &p);
                    (0..dim).map(move |k| w[k] + pos[k]).collect::<Vec<_>>()
                })
                .collect();
            outs.push(s.filter_world(&Scan::new_f64(&world, dim).unwrap(), &pos, &state, &u_nom, None).unwrap());
        }
        assert!(outs[0].active, "the scan should constrain the command");
        for o in &outs[1..] {
            for j in 0..dim {
                assert!((o.u[j] - outs[0].u[j]).abs() < 1e-9, "{:?} vs {:?}", o.u, outs[0].u);
            }
            assert!((o.value - outs[0].value).abs() < 1e-9);
        }
    }
}

#[test]
fn hardmin_uses_the_nearest_point_only() {
    let pts = [2.0, 0.0, 0.0, 0.6, -1.5, -1.5];
    let scan = Scan::new_f64(&pts, 2).unwrap();
    let state = BodyState::planar(0.0, 0.0).unwrap();
    let o = shield(ShieldMethod::HardMin).filter(&scan, &state, &[0.0, 1.0]).unwrap();
    let h_near = 0.36 / 0.2025 - 1.0;
    assert!((o.value - h_near).abs() < 1e-12);
    // row: ∂h/∂p = (0, −2·0.6/0.2025); u_y ≤ α h / (2·0.6/0.2025)
    let limit = 2.0 * h_near / (1.2 / 0.2025);
    assert!((o.u[1] - limit).abs() < 1e-12 && o.active);
}

#[test]
fn unfiltered_reports_but_never_changes_the_command() {
    let pts = doorway(0.6);
    let o = shield(ShieldMethod::Unfiltered).filter(&Scan::new_f64(&pts, 2).unwrap(), &BodyState::planar(0.0, 0.0).unwrap(), &[0.0, 3.0]).unwrap();
    assert_eq!(&o.u[..2], &[0.0, 3.0]);
    assert!(o.value < 0.0 && !o.active);
}

#[test]
fn extra_rows_are_honoured_through_clarabel() {
    let mut s = Shield::new(ShieldConfig { u_max: Some(vec![1.0, 1.0]), ..ShieldConfig::default() }).unwrap();
    let pts = [0.0, 0.7];
    let scan = Scan::new_f64(&pts, 2).unwrap();
    let state = BodyState::planar(0.0, 0.0).unwrap();
    let extra = LinearConstraints::from_rows(2, &[-1.0, 0.0], &[-0.3]).unwrap(); // u_x ≤ 0.3
    let o = s.filter_with(&scan, &state, &[1.0, 1.0], Some(&extra)).unwrap();
    assert!(o.feasible && o.active);
    assert!(o.u[0] <= 0.3 + 1e-7);
    let plain = s.filter(&scan, &state, &[1.0, 1.0]).unwrap();
    assert!((o.u[1] - plain.u[1]).abs() < 1e-5, "the CBF row still binds u_y: {:?} vs {:?}", o.u, plain.u);
}

#[test]
fn crop_band_and_downsampling_count_points() {
    let mut g = rng(17);
    let pts = random_scan(&mut g, 50_000, 3, 5.0);
    let scan = Scan::new_f64(&pts, 3).unwrap();
    let state = BodyState::planar(0.0, 0.0).unwrap();
    let expect = pts.chunks(3).filter(|c| c[0].hypot(c[1]) <= 3.5 && c[2] >= -0.4 && c[2] <= 1.5).count();
    let o = shield(ShieldMethod::Composite).filter(&scan, &state, &[0.0, 0.0]).unwrap();
    assert_eq!(o.num_points, expect);
    let mut coarse = Shield::new(ShieldConfig { scan: ScanFilter { angular_bins: Some(360), ..ScanFilter::default() }, ..ShieldConfig::default() }).unwrap();
    let oc = coarse.filter(&scan, &state, &[0.0, 0.0]).unwrap();
    assert!(oc.num_points <= 360 && oc.num_points > 300);
    // the nearest point of each bin is kept, so h_min is unchanged
    assert_eq!(oc.h_min, o.h_min);
    let mut vox = Shield::new(ShieldConfig { scan: ScanFilter { voxel_size: Some(0.5), ..ScanFilter::default() }, ..ShieldConfig::default() }).unwrap();
    let ov = vox.filter(&scan, &state, &[0.0, 0.0]).unwrap();
    assert!(ov.num_points < o.num_points && ov.h_min == o.h_min);
}

/// A scan moved by a [`Motion`] filters exactly as its points moved beforehand: in the
/// composite kernel (each SIMD level, f32 and f64, strides 2 and 3), through down-sampling, and
/// for the baselines. The moved points differ from the raw ones, so the motion is not ignored.
#[test]
fn a_moved_scan_filters_as_its_moved_points() {
    let mut g = rng(23);
    let raw = random_scan(&mut g, 3_001, 3, 4.0);
    let m = Motion::planar(0.31, -0.12, 0.07);
    let state = BodyState::planar(0.0, 0.4).unwrap();
    let u_nom = [1.2, -0.3];
    let mut levels = vec![SimdLevel::Portable];
    levels.extend([SimdLevel::Avx2, SimdLevel::Avx512].into_iter().filter(|l| l.is_supported()));
    let configs = [
        ShieldConfig::default(),
        ShieldConfig { scan: ScanFilter { angular_bins: Some(360), ..ScanFilter::default() }, ..ShieldConfig::default() },
        ShieldConfig { method: ShieldMethod::Distance, ..ShieldConfig::default() },
        ShieldConfig { method: ShieldMethod::HardMin, ..ShieldConfig::default() },
    ];
    for stride in [2, 3] {
        let pts64: Vec<f64> = raw.chunks(3).flat_map(|c| c[..stride].to_vec()).collect();
        let pts32: Vec<f32> = pts64.iter().map(|&v| v as f32).collect();
        let (mut moved64, mut moved32) = (Vec::new(), Vec::new());
        move_points(&pts64, stride, &m, &mut moved64);
        move_points(&pts32, stride, &m, &mut moved32);
        for cfg in &configs {
            for &level in &levels {
                let mut s = Shield::new(cfg.clone()).unwrap().with_simd_level(level).unwrap();
                let a = s.filter(&Scan::new_f64(&pts64, stride).unwrap().moved(m), &state, &u_nom).unwrap();
                let b = s.filter(&Scan::new_f64(&moved64, stride).unwrap(), &state, &u_nom).unwrap();
                let raw_h = s.filter(&Scan::new_f64(&pts64, stride).unwrap(), &state, &u_nom).unwrap().h_min;
                assert_eq!((a.value, a.h_min, a.u, a.num_points), (b.value, b.h_min, b.u, b.num_points), "f64 {stride} {:?} {level:?}", cfg.method);
                assert_ne!(a.h_min, raw_h);
                let a = s.filter(&Scan::new_f32(&pts32, stride).unwrap().moved(m), &state, &u_nom).unwrap();
                let b = s.filter(&Scan::new_f32(&moved32, stride).unwrap(), &state, &u_nom).unwrap();
                assert_eq!((a.value, a.h_min, a.u, a.num_points), (b.value, b.h_min, b.u, b.num_points), "f32 {stride} {:?} {level:?}", cfg.method);
            }
        }
    }
    let bad = Motion { tx: f64::NAN, ..m };
    let e = Shield::new(ShieldConfig::default()).unwrap().filter(&Scan::new_f64(&raw, 3).unwrap().moved(bad), &state, &u_nom).unwrap_err();
    assert!(e.to_string().contains("motion"), "{e}");
}

#[test]
fn bad_inputs_are_errors_naming_the_argument() {
    let bad = |cfg: ShieldConfig, name: &str| {
        let e = Shield::new(cfg).unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
    };
    bad(ShieldConfig { gamma: 0.0, ..ShieldConfig::default() }, "gamma");
    bad(ShieldConfig { kappa: -1.0, ..ShieldConfig::default() }, "kappa");
    bad(ShieldConfig { alpha: f64::NAN, ..ShieldConfig::default() }, "alpha");
    bad(ShieldConfig { semi_axes: vec![0.9, 0.0], ..ShieldConfig::default() }, "semi_axes");
    bad(ShieldConfig { u_max: Some(vec![1.0]), ..ShieldConfig::default() }, "u_max");
    bad(ShieldConfig { scan: ScanFilter { crop_radius: Some(-1.0), ..ScanFilter::default() }, ..ShieldConfig::default() }, "crop_radius");
    // (a tiny semi-axis made 1/a² infinite and every h NaN, blamed on the points)
    bad(ShieldConfig { semi_axes: vec![1e-300, 1e-300], ..ShieldConfig::default() }, "semi_axes");
    bad(ShieldConfig { semi_axes: vec![0.9, 0.45, 2e3], ..ShieldConfig::default() }, "semi_axes");
    // (κ = 1e100 returned a NaN command marked feasible)
    bad(ShieldConfig { kappa: 1e100, ..ShieldConfig::default() }, "kappa");
    bad(ShieldConfig { kappa: 1e-300, ..ShieldConfig::default() }, "kappa");
    bad(ShieldConfig { gamma: 1e300, ..ShieldConfig::default() }, "gamma");
    let mut sharp = Shield::new(ShieldConfig { kappa: 1e6, ..ShieldConfig::default() }).unwrap();
    let wall: Vec<f64> = (0..81).flat_map(|k| [1.0, -2.0 + 0.05 * k as f64]).collect();
    let o = sharp.filter(&Scan::new_f64(&wall, 2).unwrap(), &BodyState::planar(0.0, 0.0).unwrap(), &[1.0, 1.0]).unwrap();
    assert!(o.u.iter().all(|v| v.is_finite()) && o.u[0] < 1.0, "{o:?}");
    // (10^12 bins asked for 16 TB and aborted the process)
    bad(ShieldConfig { scan: ScanFilter { angular_bins: Some(1_000_000_000_000), ..ScanFilter::default() }, ..ShieldConfig::default() }, "angular_bins");
    bad(ShieldConfig { scan: ScanFilter { angular_bins: Some(8193), ..ScanFilter::default() }, ..ShieldConfig::default() }, "angular_bins");
    let mut s = shield(ShieldMethod::Composite);
    let st = BodyState::planar(0.0, 0.0).unwrap();
    let pts = [1.0, 1.0];
    let scan = Scan::new_f64(&pts, 2).unwrap();
    assert!(s.filter(&scan, &st, &[1.0]).unwrap_err().to_string().contains("u_nom"));
    assert!(s.filter(&scan, &st, &[1.0, f64::NAN]).unwrap_err().to_string().contains("u_nom"));
    let nan = [1.0, f64::NAN];
    assert!(s.filter(&Scan::new_f64(&nan, 2).unwrap(), &st, &[1.0, 0.0]).unwrap_err().to_string().contains("points"));
    let mut s3 = Shield::new(ShieldConfig { semi_axes: vec![0.9, 0.45, 0.3], ..ShieldConfig::default() }).unwrap();
    assert!(s3.filter(&scan, &st, &[1.0, 0.0, 0.0]).unwrap_err().to_string().contains("points"));
    assert!(BodyState::spatial([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]).is_err());
    assert!(Scan::new_f64(&[1.0, 2.0, 3.0], 2).is_err());
}

/// The most bins in 3D (8 192 × 4 096, binned in a hash map rather than an array) keep the
/// point of least `h` of each occupied bin, as a direct count finds them.
#[test]
fn the_most_angular_bins_in_3d_keep_the_nearest_point_of_each_bin() {
    let mut g = rng(29);
    let pts = random_scan(&mut g, 20_000, 3, 3.0);
    let cfg = ShieldConfig { semi_axes: vec![0.9, 0.45, 0.3], scan: ScanFilter { angular_bins: Some(8192), ..ScanFilter::default() }, ..ShieldConfig::default() };
    let mut s = Shield::new(cfg).unwrap();
    let st = BodyState::spatial([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]).unwrap();
    let o = s.filter(&Scan::new_f64(&pts, 3).unwrap(), &st, &[0.5, 0.0, 0.0]).unwrap();
    let (bins, el_bins) = (8192.0, 4096.0);
    let mut occupied = std::collections::HashSet::new();
    for c in pts.chunks(3).filter(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt() <= 3.5) {
        let az = (c[1].atan2(c[0]) + std::f64::consts::PI) / std::f64::consts::TAU;
        let el = c[2].atan2(c[0].hypot(c[1])) / std::f64::consts::PI + 0.5;
        occupied.insert((((az * bins) as usize).min(8191), ((el * el_bins) as usize).min(4095)));
    }
    assert_eq!(o.num_points, occupied.len());
    let all = Shield::new(ShieldConfig { semi_axes: vec![0.9, 0.45, 0.3], ..ShieldConfig::default() }).unwrap().filter(&Scan::new_f64(&pts, 3).unwrap(), &st, &[0.5, 0.0, 0.0]).unwrap();
    assert!(o.num_points < all.num_points && o.h_min == all.h_min, "{} of {}", o.num_points, all.num_points);
}

/// A point at the robot's centre violates the distance row with no direction to help: the
/// baseline stops, as the composite does with a vanishing gradient (it drove on at full speed).
#[test]
fn distance_baseline_stops_for_a_point_at_the_centre() {
    let st = BodyState::planar(0.0, 0.0).unwrap();
    for pts in [vec![0.0, 0.0], vec![0.0, 0.0, 2.0, 0.0]] {
        let o = shield(ShieldMethod::Distance).filter(&Scan::new_f64(&pts, 2).unwrap(), &st, &[1.0, 0.0]).unwrap();
        assert_eq!((o.u, o.feasible, o.active), ([0.0; 3], false, true), "{pts:?}");
    }
    // a point just off the centre has a direction to help: the command moves away from it
    let o = shield(ShieldMethod::Distance).filter(&Scan::new_f64(&[0.1, 0.0], 2).unwrap(), &st, &[1.0, 0.0]).unwrap();
    assert!(o.active && o.u[0] < 0.0, "{o:?}");
}

/// The public QP functions check their arguments' lengths and values (they indexed out of
/// bounds, clamped with min > max, or returned NaN marked feasible).
#[test]
fn public_qp_functions_name_bad_arguments() {
    let err = |r: shieldnav_core::Result<_>| r.map(|_: shieldnav_core::shield::QpSolution| ()).unwrap_err().to_string();
    assert!(err(project_halfspace_box(&[1.0; 7], &[1.0; 7], 0.0, None, 1e-9)).contains("u_nom"));
    assert!(err(project_halfspace_box(&[1.0, 0.0], &[1.0], 0.0, None, 1e-9)).contains("`g`"));
    assert!(err(project_halfspace_box(&[1.0, 0.0], &[1.0, 0.0], 0.0, Some(&[1.0]), 1e-9)).contains("u_max"));
    assert!(err(project_halfspace_box(&[1.0, 0.0], &[1.0, 0.0], 0.0, Some(&[-1.0, 1.0]), 1e-9)).contains("u_max"));
    assert!(err(project_halfspace_box(&[1.0, 0.0], &[1.0, 0.0], f64::NAN, None, 1e-9)).contains("`g`"));
    let mut rows = LinearConstraints::new(2);
    assert!(rows.push(&[1.0, 2.0, 3.0], 0.0).unwrap_err().to_string().contains("extra_A"));
    assert!(rows.push(&[1.0, f64::NAN], 0.0).is_err() && rows.is_empty());
    rows.push(&[1.0, 0.0], 0.5).unwrap();
    assert!(rows.extend(&LinearConstraints::new(3)).is_err());
    assert!(err(solve_rows(&[1.0; 7], &rows, None)).contains("u_nom"));
    assert!(err(solve_rows(&[f64::NAN, 0.0], &rows, None)).contains("u_nom"));
    assert!(err(solve_rows(&[1.0, 0.0], &rows, Some(&[1.0]))).contains("u_max"));
    let u = solve_rows(&[0.0, 0.0], &rows, None).unwrap().u;
    assert!((u[0] - 0.5).abs() < 1e-6 && u[1].abs() < 1e-6, "{u:?}");
}

/// `evaluate_composite` checks its parameters as the shield does (κ = 0 gave −inf, a NaN crop
/// dropped every point).
#[test]
fn composite_parameters_are_checked() {
    use shieldnav_core::shield::{evaluate_composite, CompositeParams, Envelope};
    let ok = CompositeParams { envelope: Envelope::new(&[0.9, 0.45]).unwrap(), gamma: 0.9, kappa: 8.0, crop_radius: Some(3.5), height_band: None, omega: [0.0; 3] };
    let pts = [1.0f64, 0.2];
    assert!(evaluate_composite(&pts, 2, &ok, SimdLevel::Portable).is_ok());
    for (bad, name) in [
        (CompositeParams { kappa: 0.0, ..ok }, "kappa"),
        (CompositeParams { kappa: f64::NAN, ..ok }, "kappa"),
        (CompositeParams { gamma: 0.0, ..ok }, "gamma"),
        (CompositeParams { omega: [0.0, 0.0, f64::NAN], ..ok }, "omega"),
        (CompositeParams { crop_radius: Some(f64::NAN), ..ok }, "crop_radius"),
        (CompositeParams { height_band: Some((f64::NAN, 1.0)), ..ok }, "height_band"),
    ] {
        let e = evaluate_composite(&pts, 2, &bad, SimdLevel::Portable).unwrap_err().to_string();
        assert!(e.contains(&format!("`{name}`")), "{e}");
    }
}

#[test]
fn empty_scan_is_valid_and_leaves_the_command() {
    for m in [ShieldMethod::Composite, ShieldMethod::Distance, ShieldMethod::HardMin, ShieldMethod::Unfiltered] {
        let o = shield(m).filter(&Scan::new_f64(&[], 2).unwrap(), &BodyState::planar(0.0, 0.0).unwrap(), &[0.4, -0.2]).unwrap();
        assert_eq!(&o.u[..2], &[0.4, -0.2], "{m:?}");
        assert!(o.feasible && !o.active && o.num_points == 0);
        assert!(o.value.is_finite() && o.h_min.is_finite());
    }
}

/// The closed form in 3 and 6 variables (the planar and 3D velocity with the rotation): the
/// KKT point `u = clamp(u_nom + μ g)`, `μ ≥ 0`, on the row when active, and Clarabel's optimum.
#[test]
fn closed_form_is_the_kkt_point_in_three_and_six_variables() {
    let mut g = rng(33);
    let mut checked = 0;
    for trial in 0..400 {
        let d = if trial % 2 == 0 { 3 } else { 6 };
        let u_nom: Vec<f64> = (0..d).map(|_| g.random_range(-2.0..2.0)).collect();
        let row: Vec<f64> = (0..d).map(|_| g.random_range(-3.0..3.0)).collect();
        let b = g.random_range(-2.0..4.0);
        let m: Vec<f64> = (0..d).map(|_| g.random_range(0.3..1.5)).collect();
        let fast = project_halfspace_box(&u_nom, &row, b, Some(&m), 1e-12).unwrap();
        let mut rows = LinearConstraints::new(d);
        rows.push(&row, b).unwrap();
        let slow = solve_rows(&u_nom, &rows, Some(&m)).unwrap();
        assert_eq!(fast.feasible, slow.feasible, "trial {trial}");
        if !fast.feasible {
            continue;
        }
        for (j, limit) in m.iter().enumerate().take(d) {
            assert!((fast.u[j] - slow.u[j]).abs() < 1e-6, "trial {trial}: {:?} vs {:?}", &fast.u[..d], &slow.u[..d]);
            assert!(fast.u[j].abs() <= limit + 1e-12);
        }
        let gu: f64 = (0..d).map(|j| row[j] * fast.u[j]).sum();
        if !fast.active {
            assert!(gu >= b && (0..d).all(|j| fast.u[j] == u_nom[j].clamp(-m[j], m[j])));
            continue;
        }
        assert!((gu - b).abs() < 1e-9, "trial {trial}: an active row holds with equality ({gu} vs {b})");
        // μ from a component strictly inside its box, then every component must follow it
        let free = (0..d).find(|&j| fast.u[j].abs() < m[j] - 1e-9 && row[j].abs() > 1e-6);
        let Some(j) = free else { continue };
        let mu = (fast.u[j] - u_nom[j]) / row[j];
        assert!(mu >= -1e-9, "trial {trial}: μ = {mu}");
        for k in 0..d {
            let want = (u_nom[k] + mu * row[k]).clamp(-m[k], m[k]);
            assert!((fast.u[k] - want).abs() < 1e-9, "trial {trial}: component {k}: {} vs {want}", fast.u[k]);
        }
        checked += 1;
    }
    assert!(checked > 100, "{checked}");
}

/// The braking shield's rotation row: a point ahead and to the left, the robot asked to turn
/// left (its nose toward the point) is slowed; asked to turn right, it is left alone. The
/// coefficient of ω is the derivative of `H` under the turn, by central differences.
#[test]
fn the_rotation_row_has_the_turns_sign() {
    let pts = [0.65, 0.36];
    let mut sh = Shield::new(ShieldConfig { method: ShieldMethod::Braking, ..ShieldConfig::default() }).unwrap();
    let scan = Scan::new_f64(&pts, 2).unwrap();
    let st = |w: f64| BodyState::planar(0.0, w).unwrap().with_velocity([0.0; 3]).unwrap();
    let left = sh.filter(&scan, &st(1.5), &[0.0, 0.0]).unwrap();
    let right = sh.filter(&scan, &st(-1.5), &[0.0, 0.0]).unwrap();
    assert!(left.active && left.omega[2] < 1.5, "{left:?}");
    assert!(!right.active && right.omega[2] == -1.5, "{right:?}");
    // dH/dt = coefficient · ω: compare with H of the scan turned by ∓δ (the body turned by ±δ)
    let mut paper = shield(ShieldMethod::Composite);
    let mut h = |yaw: f64| {
        let (s, c) = (-yaw).sin_cos();
        let p = [c * pts[0] - s * pts[1], s * pts[0] + c * pts[1]];
        paper.barrier(&Scan::new_f64(&p, 2).unwrap(), &st(0.0)).unwrap().value
    };
    let d = 1e-6;
    let fd = (h(d) - h(-d)) / (2.0 * d);
    let coef = paper.barrier(&scan, &st(0.0)).unwrap().grad_omega[2];
    assert!(fd < 0.0 && (coef - fd).abs() < 1e-6 * fd.abs().max(1.0), "{coef} vs {fd}");
}

/// Bad inputs of the braking shield name what was wrong.
#[test]
fn braking_inputs_name_the_argument() {
    use shieldnav_core::shield::BrakingModel;
    let bad = |b: BrakingModel| Shield::new(ShieldConfig { method: ShieldMethod::Braking, braking: b, ..ShieldConfig::default() }).unwrap_err().to_string();
    let d = BrakingModel::default();
    assert!(bad(BrakingModel { dt: 0.0, ..d }).contains("dt"));
    assert!(bad(BrakingModel { dt: f64::NAN, ..d }).contains("dt"));
    assert!(bad(BrakingModel { brake_margin: -0.1, ..d }).contains("`brake_margin`"));
    let mut t = d.tracker;
    t.alpha_max = 0.0;
    assert!(bad(BrakingModel { tracker: t, ..d }).contains("yaw_accel_max"));
    let mut sh = Shield::new(ShieldConfig { method: ShieldMethod::Braking, ..ShieldConfig::default() }).unwrap();
    let scan = Scan::new_f64(&[1.0, 0.5], 2).unwrap();
    let err = sh.filter(&scan, &BodyState::planar(0.0, 0.0).unwrap(), &[0.5, 0.0]).unwrap_err().to_string();
    assert!(err.contains("velocity"), "{err}");
    assert!(BodyState::planar(0.0, 0.0).unwrap().with_velocity([f64::NAN, 0.0, 0.0]).unwrap_err().to_string().contains("velocity"));
}

/// A point so far away that its `h` overflows to infinity is down-sampled like any other: the
/// voxel or bin keeps it (an empty cell would index past the scan), and the shield answers as
/// it does without down-sampling.
#[test]
fn a_point_whose_h_overflows_is_kept_by_its_cell() {
    let pts = [0.0, 1e155, 1.0, 0.0];
    let state = BodyState::planar(0.0, 0.0).unwrap();
    let plain =
        Shield::new(ShieldConfig { scan: ScanFilter { crop_radius: None, ..ScanFilter::default() }, ..ShieldConfig::default() }).unwrap().filter(&Scan::new_f64(&pts, 2).unwrap(), &state, &[1.0, 0.0]);
    for scan in [ScanFilter { crop_radius: None, voxel_size: Some(1.0), ..ScanFilter::default() }, ScanFilter { crop_radius: None, angular_bins: Some(16), ..ScanFilter::default() }] {
        let mut shield = Shield::new(ShieldConfig { scan, ..ShieldConfig::default() }).unwrap();
        let got = shield.filter(&Scan::new_f64(&pts, 2).unwrap(), &state, &[1.0, 0.0]);
        match (&got, &plain) {
            (Ok(a), Ok(b)) => assert_eq!((a.u, a.num_points), (b.u, b.num_points), "{scan:?}"),
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{scan:?}"),
            _ => panic!("{scan:?}: {got:?} against {plain:?} without down-sampling"),
        }
    }
}
