//! Noise draws from the world's seeded RNG (no other source of randomness is used).

use rand::Rng;

use crate::math::Real;

/// One standard-normal draw from `rng` (ziggurat, `rand_distr::StandardNormal`).
#[inline]
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> Real {
    rng.sample(rand_distr::StandardNormal)
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
}
