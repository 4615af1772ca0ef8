//! The robot-centric ellipsoid and the per-point time-varying CBF of the paper, Sec. III-B:
//!
//! `h_i(p_r, t) = (p_i − p_r)ᵀ Q_W(t) (p_i − p_r) − 1`, `Q_W = R diag(1/a²) Rᵀ`.
//!
//! With the point in the body frame, `p^B = Rᵀ (p_i − p_r)`, and `A = diag(1/a²)`:
//! - `h_i = p^Bᵀ A p^B − 1`
//! - `∂h_i/∂p_r = −2 Q_W (p_i − p_r) = −2 R A p^B` (world frame)
//! - `∂h_i/∂t = (p_i − p_r)ᵀ Q̇_W (p_i − p_r)`. With `Ṙ = R [ω]×` (ω the body-frame angular
//!   velocity), `Q̇_W = R ([ω]× A − A [ω]×) Rᵀ`, so `∂h_i/∂t = 2 p^B · (ω × A p^B)
//!   = 2 ω · (A p^B × p^B)`. In the plane, with yaw rate `r`:
//!   `∂h_i/∂t = 2 r x y (1/a_x² − 1/a_y²)`. Sanity check: a robot longer than wide
//!   (`a_x > a_y`) turning left (`r > 0`) sweeps its long axis toward a point ahead-left
//!   (`x, y > 0`), and `∂h/∂t < 0` says the point is getting closer in the ellipse metric.

use crate::error::{Error, Result};
use crate::math::{cross, dot, mat_mul, mat_t_vec, mat_vec, skew, Mat3, Real, Vec3};

/// Least semi-axis (m): `1/a²` and the points' `pᵀ A p` stay far from overflow in both the
/// f64 and the f32 kernels.
pub const MIN_SEMI_AXIS: Real = 1e-3;
/// Greatest semi-axis (m): `1/a²` stays far from underflow.
pub const MAX_SEMI_AXIS: Real = 1e3;

/// An axis-aligned ellipsoid in the body frame, centred on the robot: planar (`a_x, a_y`) or
/// 3D (`a_x, a_y, a_z`), semi-axes in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    semi_axes: Vec3,
    dim: usize,
}

impl Envelope {
    /// An envelope from 2 (planar) or 3 (3D) strictly positive, finite semi-axes.
    ///
    /// ```
    /// use shieldnav_core::shield::Envelope;
    /// let e = Envelope::new(&[0.9, 0.45]).unwrap();
    /// assert_eq!(e.dim(), 2);
    /// assert!(Envelope::new(&[0.9, 0.0]).is_err());
    /// ```
    pub fn new(semi_axes: &[Real]) -> Result<Self> {
        let dim = semi_axes.len();
        if dim != 2 && dim != 3 {
            return Err(Error::invalid("semi_axes", format!("expected 2 (planar) or 3 (3D) values, got {dim}")));
        }
        if let Some(a) = semi_axes.iter().find(|a| !(MIN_SEMI_AXIS..=MAX_SEMI_AXIS).contains(*a)) {
            return Err(Error::invalid("semi_axes", format!("every semi-axis must be from {MIN_SEMI_AXIS} to {MAX_SEMI_AXIS} m, got {a}")));
        }
        let mut axes = [1.0; 3];
        axes[..dim].copy_from_slice(semi_axes);
        Ok(Self { semi_axes: axes, dim })
    }

    /// 2 for a planar envelope, 3 for an ellipsoid.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The semi-axes (the unused `a_z` of a planar envelope reads 1).
    pub fn semi_axes(&self) -> &[Real] {
        &self.semi_axes[..self.dim]
    }

    /// The diagonal of `A = diag(1/a²)`; `0` for `z` when planar (the plane ignores height).
    pub fn inv_sq(&self) -> Vec3 {
        let mut a = [0.0; 3];
        for (k, v) in a.iter_mut().enumerate().take(self.dim) {
            *v = 1.0 / (self.semi_axes[k] * self.semi_axes[k]);
        }
        a
    }

    /// `h` of one body-frame point (`z` ignored when planar).
    #[inline]
    pub fn h_body(&self, p: &Vec3) -> Real {
        let a = self.inv_sq();
        p[0] * p[0] * a[0] + p[1] * p[1] * a[1] + p[2] * p[2] * a[2] - 1.0
    }

    /// `∂h/∂p_r` in the body frame, `−2 A p^B`.
    #[inline]
    pub fn grad_body(&self, p: &Vec3) -> Vec3 {
        let a = self.inv_sq();
        [-2.0 * a[0] * p[0], -2.0 * a[1] * p[1], -2.0 * a[2] * p[2]]
    }

    /// `∂h/∂t = 2 ω · (A p^B × p^B)` for body angular velocity `omega` (rad/s, body frame).
    #[inline]
    pub fn dh_dt_body(&self, p: &Vec3, omega: &Vec3) -> Real {
        let a = self.inv_sq();
        let ap = [a[0] * p[0], a[1] * p[1], a[2] * p[2]];
        2.0 * dot(omega, &cross(&ap, p))
    }

    /// `h`, `∂h/∂p_r` and `∂h/∂t` in the paper's world-frame form, from a world point, the
    /// robot position and `R` (body-to-world): `Q_W = R A Rᵀ`, `Q̇_W = R([ω]×A − A[ω]×)Rᵀ`.
    /// Kept as the literal transcription the body-frame kernels are tested against.
    pub fn cbf_world(&self, p_world: &Vec3, p_robot: &Vec3, rotation: &Mat3, omega: &Vec3) -> (Real, Vec3, Real) {
        let a = self.inv_sq();
        let d = [p_world[0] - p_robot[0], p_world[1] - p_robot[1], p_world[2] - p_robot[2]];
        let q = sandwich(rotation, &diag_mat(&a));
        let wx = skew(omega);
        let inner = sub_mat(&mat_mul(&wx, &diag_mat(&a)), &mat_mul(&diag_mat(&a), &wx));
        let qdot = sandwich(rotation, &inner);
        let qd = mat_vec(&q, &d);
        let h = dot(&d, &qd) - 1.0;
        let grad = [-2.0 * qd[0], -2.0 * qd[1], -2.0 * qd[2]];
        let dt = dot(&d, &mat_vec(&qdot, &d));
        (h, grad, dt)
    }

    /// Body-frame coordinates of a world point: `Rᵀ (p − p_r)`.
    pub fn to_body(p_world: &Vec3, p_robot: &Vec3, rotation: &Mat3) -> Vec3 {
        mat_t_vec(rotation, &[p_world[0] - p_robot[0], p_world[1] - p_robot[1], p_world[2] - p_robot[2]])
    }
}

fn diag_mat(a: &Vec3) -> Mat3 {
    [[a[0], 0.0, 0.0], [0.0, a[1], 0.0], [0.0, 0.0, a[2]]]
}

fn sub_mat(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = *a;
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] -= b[i][j];
        }
    }
    m
}

/// `R M Rᵀ`.
fn sandwich(r: &Mat3, m: &Mat3) -> Mat3 {
    let mut rt = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            rt[i][j] = r[j][i];
        }
    }
    mat_mul(&mat_mul(r, m), &rt)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{integrate_rotation, rot_z};

    fn rot_xyz(roll: f64, pitch: f64, yaw: f64) -> Mat3 {
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let rx = [[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]];
        let ry = [[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]];
        mat_mul(&rot_z(yaw), &mat_mul(&ry, &rx))
    }

    #[test]
    fn dh_dt_matches_central_difference_of_rotating_ellipse_3d() {
        let env = Envelope::new(&[0.9, 0.45, 0.3]).unwrap();
        let r = rot_xyz(0.3, -0.2, 1.1);
        let w = [0.4, -0.7, 1.3];
        let pr = [2.0, -1.0, 0.5];
        let pw = [2.6, -0.4, 0.7];
        let (_, _, dt) = env.cbf_world(&pw, &pr, &r, &w);
        let eps = 1e-5;
        let hp = env.cbf_world(&pw, &pr, &integrate_rotation(&r, &w, eps), &w).0;
        let hm = env.cbf_world(&pw, &pr, &integrate_rotation(&r, &w, -eps), &w).0;
        let fd = (hp - hm) / (2.0 * eps);
        assert!((fd - dt).abs() < 1e-7, "fd={fd} analytic={dt}");
        let pb = Envelope::to_body(&pw, &pr, &r);
        assert!((env.dh_dt_body(&pb, &w) - dt).abs() < 1e-12);
    }

    #[test]
    fn planar_dh_dt_is_negative_when_long_axis_turns_toward_point() {
        let env = Envelope::new(&[0.9, 0.45]).unwrap();
        let d = env.dh_dt_body(&[1.0, 1.0, 0.0], &[0.0, 0.0, 1.0]);
        let expect = 2.0 * 1.0 * 1.0 * 1.0 * (1.0 / 0.81 - 1.0 / 0.2025);
        assert!(d < 0.0);
        assert!((d - expect).abs() < 1e-12);
        let (_, _, dt) = env.cbf_world(&[1.0, 1.0, 0.0], &[0.0; 3], &rot_z(0.0), &[0.0, 0.0, 1.0]);
        assert!((dt - expect).abs() < 1e-12);
        let eps = 1e-6;
        let h = |yaw: f64| env.cbf_world(&[1.0, 1.0, 0.0], &[0.0; 3], &rot_z(yaw), &[0.0; 3]).0;
        assert!(((h(eps) - h(-eps)) / (2.0 * eps) - expect).abs() < 1e-6);
    }

    #[test]
    fn grad_matches_central_difference_in_position() {
        let env = Envelope::new(&[0.9, 0.45, 0.3]).unwrap();
        let r = rot_xyz(0.1, 0.2, -0.7);
        let pw = [1.0, 0.5, 0.2];
        let pr = [0.2, 0.1, -0.1];
        let (_, g, _) = env.cbf_world(&pw, &pr, &r, &[0.0; 3]);
        for k in 0..3 {
            let mut a = pr;
            let mut b = pr;
            a[k] += 1e-6;
            b[k] -= 1e-6;
            let fd = (env.cbf_world(&pw, &a, &r, &[0.0; 3]).0 - env.cbf_world(&pw, &b, &r, &[0.0; 3]).0) / 2e-6;
            assert!((fd - g[k]).abs() < 1e-6, "axis {k}: fd={fd} g={}", g[k]);
        }
        let gb = env.grad_body(&Envelope::to_body(&pw, &pr, &r));
        let gw = mat_vec(&r, &gb);
        for k in 0..3 {
            assert!((gw[k] - g[k]).abs() < 1e-12);
        }
    }

    #[test]
    fn envelope_rejects_bad_semi_axes() {
        assert!(Envelope::new(&[0.9]).is_err());
        assert!(Envelope::new(&[0.9, f64::NAN]).is_err());
        assert!(Envelope::new(&[0.9, -0.1, 0.3]).is_err());
        assert!(Envelope::new(&[0.9, 0.45, 0.3, 1.0]).is_err());
    }
}
