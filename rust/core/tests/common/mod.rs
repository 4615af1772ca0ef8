//! Shared helpers of the shield integration tests: seeded random scans and a direct,
//! unoptimised transcription of the paper's world-frame equations.
#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shieldnav_core::math::{Mat3, Vec3};
use shieldnav_core::shield::Envelope;

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// `n` body-frame points, uniform in a disc/ball of `radius` (planar when `dim == 2`).
pub fn random_scan(rng: &mut ChaCha8Rng, n: usize, dim: usize, radius: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(n * dim);
    for _ in 0..n {
        for _ in 0..dim {
            out.push(rng.random_range(-radius..radius));
        }
    }
    out
}

/// A body-to-world rotation from roll, pitch, yaw.
pub fn rot_rpy(roll: f64, pitch: f64, yaw: f64) -> Mat3 {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let (sy, cy) = yaw.sin_cos();
    [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
}

pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// `R exp([ω]× dt)` by Rodrigues.
pub fn advance(r: &Mat3, w: &Vec3, dt: f64) -> Mat3 {
    let n = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    if n == 0.0 {
        return *r;
    }
    let th = n * dt;
    let k = [w[0] / n, w[1] / n, w[2] / n];
    let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    let kx2 = mat_mul(&kx, &kx);
    let mut e = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            e[i][j] = if i == j { 1.0 } else { 0.0 } + th.sin() * kx[i][j] + (1.0 - th.cos()) * kx2[i][j];
        }
    }
    mat_mul(r, &e)
}

/// The paper's `H_W`, `∂H_W/∂p_r`, `∂H_W/∂t` by direct world-frame summation (no shift, no
/// fusion): fine for moderate `κ` and `N`.
pub fn composite_world(env: &Envelope, gamma: f64, kappa: f64, pts_w: &[Vec3], p_r: &Vec3, r: &Mat3, w: &Vec3) -> (f64, Vec3, f64) {
    let mut sum = 0.0;
    let mut g = [0.0; 3];
    let mut dt = 0.0;
    for p in pts_w {
        let (h, gi, dti) = env.cbf_world(p, p_r, r, w);
        let e = (-kappa * (h / gamma).tanh()).exp();
        let sech2 = 1.0 / (h / gamma).cosh().powi(2);
        sum += e;
        for k in 0..3 {
            g[k] += e * sech2 * gi[k];
        }
        dt += e * sech2 * dti;
    }
    let hval = -(gamma / kappa) * sum.ln();
    (hval, [g[0] / sum, g[1] / sum, g[2] / sum], dt / sum)
}
