//! Inputs the fuzzing (`fuzz_props.rs`) found the shield mishandling, one test each: a clear
//! error naming the argument, or a finite answer meeting its rows.

use shieldnav_core::shield::{project_halfspace_box, solve_rows, BodyState, LinearConstraints, Scan, ScanFilter, Shield, ShieldConfig, ShieldMethod};
use shieldnav_core::Error;

fn named(err: Error) -> &'static str {
    match err {
        Error::InvalidArgument { name, .. } => name,
        other => panic!("expected an invalid-argument error, got {other}"),
    }
}

#[test]
fn a_point_too_far_to_square_is_an_error_naming_points_for_every_method() {
    // (the ellipse's h divides by a² = 0.2: 4e153 m overflows it; the distance row's ‖p‖² holds
    // up to about 1.3e154 m)
    let (near, far) = ([-4.1e153, -5.9e153], [1e155, -1e155]);
    for (method, pts) in [(ShieldMethod::HardMin, near), (ShieldMethod::Composite, near), (ShieldMethod::HardMin, far), (ShieldMethod::Distance, far)] {
        let scan_filter = ScanFilter { crop_radius: None, ..ScanFilter::default() };
        let mut shield = Shield::new(ShieldConfig { method, u_max: Some(vec![1.6, 1e-300]), scan: scan_filter, ..ShieldConfig::default() }).unwrap();
        let err = shield.filter(&Scan::new_f64(&pts, 2).unwrap(), &BodyState::planar(0.0, 0.0).unwrap(), &[0.0, 0.0]).unwrap_err();
        assert_eq!(named(err), "points", "{method:?}");
    }
}

#[test]
fn a_row_no_finite_command_meets_is_an_error_naming_b() {
    let err = project_halfspace_box(&[0.0, 0.0], &[-7.5, -4.37], f64::MAX, None, 1e-9).unwrap_err();
    assert_eq!(named(err), "b");
    // with a box the least-violating command is finite, and infeasible
    let sol = project_halfspace_box(&[0.0, 0.0], &[-7.5, -4.37], f64::MAX, Some(&[1.0, 1.0]), 1e-9).unwrap();
    assert!(!sol.feasible && sol.u.iter().all(|v| v.is_finite()));
}

#[test]
fn clarabel_solves_rows_against_a_nominal_command_of_1e10() {
    for u_nom in [[0.0, 1.04e10], [-3e12, 5e11], [1e16, -1e16]] {
        let rows = LinearConstraints::from_rows(2, &[0.0, -1.0, 1.0, 1.0], &[0.0, -0.5]).unwrap();
        let sol = solve_rows(&u_nom, &rows, Some(&[1.6, 0.8])).unwrap();
        let u = &sol.u[..2];
        assert!(sol.feasible, "{u_nom:?}: {sol:?}");
        assert!(u[0].abs() <= 1.6 && u[1].abs() <= 0.8);
        assert!(-u[1] >= -1e-9 && u[0] + u[1] >= -0.5 - 1e-9, "{u:?}");
    }
}

#[test]
fn rows_that_overflow_at_the_nominal_command_are_an_error_naming_u_nom() {
    // −2.13 · 1.8e308 and −1e155 · −1e155 overflow in opposite directions: the row's value is NaN
    let rows = LinearConstraints::from_rows(3, &[-2.13, 0.0, -1e155], &[0.0]).unwrap();
    assert!(rows.max_violation(&[f64::MAX, 0.0, -1e155]).is_nan());
    let err = solve_rows(&[f64::MAX, 0.0, -1e155], &rows, None).unwrap_err();
    assert_eq!(named(err), "u_nom");
}
