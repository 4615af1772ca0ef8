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
    [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], [-sp, cp * sr, cp * cr]]
}

#[allow(unused_imports)]
pub use shieldnav_core::math::integrate_rotation as advance;

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
