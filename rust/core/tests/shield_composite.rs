//! The composite barrier against the paper's equations: gradients, frames, inclusion, numerics.

mod common;

use common::{advance, composite_world, random_scan, rng, rot_rpy};
use shieldnav_core::math::{mat_t_vec, mat_vec, rot_z, Mat3, Vec3};
use shieldnav_core::shield::{composite_reference, evaluate_composite, CompositeParams, Envelope, SimdLevel};

fn params(axes: &[f64], omega: Vec3, crop: Option<f64>) -> CompositeParams {
    CompositeParams { envelope: Envelope::new(axes).unwrap(), gamma: 0.9, kappa: 8.0, crop_radius: crop, height_band: None, omega }
}

/// `H` of static world points seen from a robot at `p_r` with rotation `r`.
fn h_at(p: &CompositeParams, pts_w: &[Vec3], p_r: &Vec3, r: &Mat3) -> f64 {
    let dim = p.envelope.dim();
    let body: Vec<f64> = pts_w
        .iter()
        .flat_map(|q| {
            let b = mat_t_vec(r, &[q[0] - p_r[0], q[1] - p_r[1], q[2] - p_r[2]]);
            b[..dim].to_vec()
        })
        .collect();
    evaluate_composite(&body, dim, p, SimdLevel::detect()).unwrap().value
}

fn world_points(seed: u64, n: usize, dim: usize) -> Vec<Vec3> {
    let mut g = rng(seed);
    let flat = random_scan(&mut g, n, dim, 2.5);
    flat.chunks(dim).map(|c| [c[0] + 0.3, c[1] - 0.2, if dim == 3 { c[2] } else { 0.0 }]).collect()
}

#[test]
fn gradient_and_time_derivative_match_central_differences_planar() {
    let omega = [0.0, 0.0, 0.8];
    let p = params(&[0.9, 0.45], omega, None);
    let pts = world_points(1, 60, 2);
    let p_r = [0.3, -0.2, 0.0];
    let r = rot_z(0.7);
    let body: Vec<f64> = pts.iter().flat_map(|q| mat_t_vec(&r, &[q[0] - p_r[0], q[1] - p_r[1], 0.0])[..2].to_vec()).collect();
    let b = evaluate_composite(&body, 2, &p, SimdLevel::detect()).unwrap();
    let g = mat_vec(&r, &b.grad_body);
    let eps = 1e-6;
    for k in 0..2 {
        let (mut a, mut c) = (p_r, p_r);
        a[k] += eps;
        c[k] -= eps;
        let fd = (h_at(&p, &pts, &a, &r) - h_at(&p, &pts, &c, &r)) / (2.0 * eps);
        assert!((fd - g[k]).abs() < 1e-6 * (1.0 + fd.abs()), "axis {k}: fd {fd} vs {}", g[k]);
    }
    let fd_t = (h_at(&p, &pts, &p_r, &rot_z(0.7 + 0.8 * eps)) - h_at(&p, &pts, &p_r, &rot_z(0.7 - 0.8 * eps))) / (2.0 * eps);
    assert!((fd_t - b.dh_dt).abs() < 1e-6 * (1.0 + fd_t.abs()), "dH/dt: fd {fd_t} vs {}", b.dh_dt);
    assert!(b.dh_dt.abs() > 1e-3, "the test must exercise a non-zero dH/dt");
}

#[test]
fn gradient_and_time_derivative_match_central_differences_3d() {
    let omega = [0.3, -0.5, 0.9];
    let p = params(&[0.9, 0.45, 0.35], omega, None);
    let pts = world_points(2, 80, 3);
    let p_r = [0.3, -0.2, 0.1];
    let r = rot_rpy(0.2, -0.3, 1.2);
    let body: Vec<f64> = pts.iter().flat_map(|q| mat_t_vec(&r, &[q[0] - p_r[0], q[1] - p_r[1], q[2] - p_r[2]]).to_vec()).collect();
    let b = evaluate_composite(&body, 3, &p, SimdLevel::detect()).unwrap();
    let g = mat_vec(&r, &b.grad_body);
    let eps = 1e-6;
    for k in 0..3 {
        let (mut a, mut c) = (p_r, p_r);
        a[k] += eps;
        c[k] -= eps;
        let fd = (h_at(&p, &pts, &a, &r) - h_at(&p, &pts, &c, &r)) / (2.0 * eps);
        assert!((fd - g[k]).abs() < 1e-6 * (1.0 + fd.abs()), "axis {k}: fd {fd} vs {}", g[k]);
    }
    let fd_t = (h_at(&p, &pts, &p_r, &advance(&r, &omega, eps)) - h_at(&p, &pts, &p_r, &advance(&r, &omega, -eps))) / (2.0 * eps);
    assert!((fd_t - b.dh_dt).abs() < 1e-6 * (1.0 + fd_t.abs()), "dH/dt: fd {fd_t} vs {}", b.dh_dt);
    assert!(b.dh_dt.abs() > 1e-3);
}

#[test]
fn body_frame_kernel_agrees_with_world_frame_equations() {
    for (dim, axes, omega) in [(2, vec![0.9, 0.45], [0.0, 0.0, -0.6]), (3, vec![0.9, 0.45, 0.3], [0.2, 0.4, -0.6])] {
        let p = params(&axes, omega, None);
        let pts = world_points(3 + dim as u64, 150, dim);
        let p_r = [12.0, -7.0, if dim == 3 { 0.4 } else { 0.0 }];
        let pts: Vec<Vec3> = pts.iter().map(|q| [q[0] + p_r[0], q[1] + p_r[1], q[2] + p_r[2]]).collect();
        let r = if dim == 3 { rot_rpy(0.1, 0.25, -2.0) } else { rot_z(-2.0) };
        let (hw, gw, dtw) = composite_world(&p.envelope, 0.9, 8.0, &pts, &p_r, &r, &omega);
        let body: Vec<f64> = pts.iter().flat_map(|q| mat_t_vec(&r, &[q[0] - p_r[0], q[1] - p_r[1], q[2] - p_r[2]])[..dim].to_vec()).collect();
        let b = evaluate_composite(&body, dim, &p, SimdLevel::detect()).unwrap();
        let g = mat_vec(&r, &b.grad_body);
        assert!((b.value - hw).abs() < 1e-10, "H {} vs {hw}", b.value);
        for k in 0..dim {
            assert!((g[k] - gw[k]).abs() < 1e-10, "grad[{k}] {} vs {}", g[k], gw[k]);
        }
        assert!((b.dh_dt - dtw).abs() < 1e-10, "dH/dt {} vs {dtw}", b.dh_dt);
    }
}

#[test]
fn nonnegative_composite_implies_every_point_safe() {
    let mut g = rng(7);
    let mut checked_nonneg = 0;
    for trial in 0..400 {
        let n = 1 + trial % 97;
        let pts = random_scan(&mut g, n, 2, 0.6 + 3.0 * (trial as f64 / 400.0));
        let p = params(&[0.9, 0.45], [0.0; 3], None);
        let env = p.envelope;
        for level in [SimdLevel::Portable, SimdLevel::detect()] {
            let b64 = evaluate_composite(&pts, 2, &p, level).unwrap();
            let p32: Vec<f32> = pts.iter().map(|&v| v as f32).collect();
            let b32 = evaluate_composite(&p32, 2, &p, level).unwrap();
            for (b, pts_used) in [(b64, pts.clone()), (b32, p32.iter().map(|&v| v as f64).collect::<Vec<_>>())] {
                if b.value >= 0.0 {
                    checked_nonneg += 1;
                    for c in pts_used.chunks(2) {
                        assert!(env.h_body(&[c[0], c[1], 0.0]) >= 0.0, "H = {} ≥ 0 but a point is inside", b.value);
                    }
                }
                assert!(b.value <= 0.9 * (b.h_min / 0.9).tanh() + 1e-15);
            }
        }
    }
    assert!(checked_nonneg > 100, "the random scans must include many safe ones ({checked_nonneg})");
}

#[test]
fn f32_kernel_accuracy_against_f64() {
    let mut g = rng(11);
    for &n in &[10usize, 1300, 20_000] {
        let pts = random_scan(&mut g, n, 3, 3.0);
        let p = params(&[0.9, 0.45, 0.3], [0.1, -0.2, 0.7], None);
        let b64 = evaluate_composite(&pts, 3, &p, SimdLevel::detect()).unwrap();
        let p32: Vec<f32> = pts.iter().map(|&v| v as f32).collect();
        let b32 = evaluate_composite(&p32, 3, &p, SimdLevel::detect()).unwrap();
        assert!((b64.value - b32.value).abs() < 1e-5, "N={n}: H {} vs {}", b64.value, b32.value);
        let gn = b64.grad_body.iter().map(|v| v * v).sum::<f64>().sqrt();
        for k in 0..3 {
            assert!((b64.grad_body[k] - b32.grad_body[k]).abs() < 1e-4 * gn.max(1e-3), "N={n} grad[{k}]");
        }
        assert!((b64.dh_dt - b32.dh_dt).abs() < 1e-4 * (1.0 + b64.dh_dt.abs()));
    }
}

#[test]
fn simd_levels_agree() {
    let mut g = rng(5);
    let pts = random_scan(&mut g, 1301, 2, 3.0);
    let p = params(&[0.9, 0.45], [0.0, 0.0, 0.4], Some(3.5));
    let base = evaluate_composite(&pts, 2, &p, SimdLevel::Portable).unwrap();
    for level in [SimdLevel::Avx2, SimdLevel::Avx512] {
        if level.is_supported() {
            let b = evaluate_composite(&pts, 2, &p, level).unwrap();
            assert_eq!(b.num_points, base.num_points);
            assert!((b.value - base.value).abs() < 1e-13);
            for k in 0..2 {
                assert!((b.grad_body[k] - base.grad_body[k]).abs() < 1e-12);
            }
        }
    }
}

#[test]
fn finite_outputs_at_extremes() {
    let mut g = rng(9);
    let cases: Vec<(f64, Vec<f64>)> = vec![
        (100.0, random_scan(&mut g, 500, 2, 3.0)),
        (8.0, (0..1000).flat_map(|k| [1e3 + k as f64, -1e3]).collect()),
        (8.0, vec![]),
        (8.0, random_scan(&mut g, 100_000, 2, 3.0)),
        (100.0, (0..1000).flat_map(|k| [1e3 + k as f64, -1e3]).collect()),
        (8.0, vec![0.0, 0.0]),
    ];
    for (kappa, pts) in cases {
        let p = CompositeParams { kappa, ..params(&[0.9, 0.45], [0.0, 0.0, 1.0], None) };
        for b in [evaluate_composite(&pts, 2, &p, SimdLevel::detect()).unwrap(), evaluate_composite(&pts.iter().map(|&v| v as f32).collect::<Vec<_>>(), 2, &p, SimdLevel::detect()).unwrap()] {
            assert!(b.value.is_finite() && b.h_min.is_finite() && b.dh_dt.is_finite(), "{b:?}");
            assert!(b.grad_body.iter().all(|v| v.is_finite()), "{b:?}");
        }
    }
}

#[test]
fn far_dense_cloud_turns_conservative_like_log_n_over_kappa() {
    // every point far: tanh → 1, H → γ − (γ/κ) ln N, negative beyond N = e^κ ≈ 2981
    let p = params(&[0.9, 0.45], [0.0; 3], None);
    for &n in &[100usize, 2900, 3100, 20_000] {
        let pts: Vec<f64> = (0..n).flat_map(|k| [50.0 + k as f64 * 1e-3, 50.0]).collect();
        let b = evaluate_composite(&pts, 2, &p, SimdLevel::detect()).unwrap();
        let expect = 0.9 - 0.9 / 8.0 * (n as f64).ln();
        assert!((b.value - expect).abs() < 1e-9, "N={n}: {} vs {expect}", b.value);
        assert_eq!(b.value < 0.0, n > 2981);
    }
}

#[test]
fn non_finite_points_are_rejected_even_beyond_the_crop() {
    let p = params(&[0.9, 0.45], [0.0; 3], Some(3.5));
    for bad in [f64::NAN, f64::INFINITY] {
        let pts = vec![1.0, 1.0, 100.0, bad];
        assert!(evaluate_composite(&pts, 2, &p, SimdLevel::detect()).is_err());
    }
}

/// The fused kernel (f64 and f32 scans, every SIMD level) against the readable reference, with a
/// rotation and a crop that leaves some points out.
#[test]
fn the_kernel_equals_the_readable_reference() {
    for (seed, axes) in [(1u64, vec![0.9, 0.45]), (2, vec![0.9, 0.45, 0.4]), (3, vec![0.6, 0.6])] {
        let dim = axes.len();
        let p = params(&axes, [0.1, -0.2, 0.7], Some(2.5));
        let mut g = rng(seed);
        let flat = random_scan(&mut g, 500, dim, 3.0);
        let pts: Vec<Vec3> = flat.chunks(dim).map(|c| [c[0], c[1], if dim == 3 { c[2] } else { 0.0 }]).collect();
        let want = composite_reference(&pts, &p);
        assert!(want.num_points > 0 && want.num_points < 500, "{want:?}");
        let flat32: Vec<f32> = flat.iter().map(|&v| v as f32).collect();
        for level in [SimdLevel::Portable, SimdLevel::detect()] {
            let got = evaluate_composite(&flat, dim, &p, level).unwrap();
            let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * (1.0 + b.abs());
            assert_eq!(got.num_points, want.num_points);
            assert!(close(got.value, want.value, 1e-12) && close(got.h_min, want.h_min, 1e-12) && close(got.dh_dt, want.dh_dt, 1e-10), "{got:?} vs {want:?}");
            for d in 0..3 {
                assert!(close(got.grad_body[d], want.grad_body[d], 1e-10) && close(got.grad_omega[d], want.grad_omega[d], 1e-10), "{got:?} vs {want:?}");
            }
            let got32 = evaluate_composite(&flat32, dim, &p, level).unwrap();
            assert!(close(got32.value, want.value, 1e-4), "{got32:?} vs {want:?}");
        }
    }
}
