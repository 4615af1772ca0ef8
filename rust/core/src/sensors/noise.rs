//! Noise draws from the world's seeded RNG (no other source of randomness is used).

use rand::Rng;

use crate::math::Real;

/// One standard-normal draw (Box–Muller, one of the pair), from `rng`.
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> Real {
    // u1 in (0, 1] so ln(u1) is finite
    let u1: Real = 1.0 - rng.random::<Real>();
    let u2: Real = rng.random::<Real>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Standard-normal draws two at a time (both halves of each Box–Muller pair).
#[derive(Debug, Clone, Default)]
pub struct NormalPairs {
    spare: Option<Real>,
}

impl NormalPairs {
    /// The next standard-normal draw.
    pub fn next<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Real {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let u1: Real = 1.0 - rng.random::<Real>();
        let u2: Real = rng.random::<Real>();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
        self.spare = Some(r * s);
        r * c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn standard_normal_has_unit_moments() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 200_000;
        let xs: Vec<Real> = (0..n).map(|_| standard_normal(&mut rng)).collect();
        let mean = xs.iter().sum::<Real>() / n as Real;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<Real>() / n as Real;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.02, "var {var}");
    }

    #[test]
    fn normal_pairs_have_unit_moments_and_no_correlation() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut g = NormalPairs::default();
        let n = 200_000;
        let xs: Vec<Real> = (0..n).map(|_| g.next(&mut rng)).collect();
        let mean = xs.iter().sum::<Real>() / n as Real;
        let var = xs.iter().map(|x| x * x).sum::<Real>() / n as Real;
        let lag1 = xs.windows(2).map(|w| w[0] * w[1]).sum::<Real>() / n as Real;
        assert!(mean.abs() < 0.01 && (var - 1.0).abs() < 0.02 && lag1.abs() < 0.01, "{mean} {var} {lag1}");
    }
}
