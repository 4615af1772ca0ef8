//! Noise draws from the world's seeded RNG (no other source of randomness is used).
//!
//! Every standard-normal draw is the inverse normal CDF of one `u32` `k` of the RNG, at
//! `p = (k + ½) · 2⁻³²`, by Wichura's AS241 to seven digits (PPND7, evaluated in `f32`:
//! relative error below 5e-7). One draw per `u32`, no rejection and no branch: a block of draws is a
//! block of `u32`s converted in SIMD lanes ([`fill_standard_normal`]), and a single draw
//! ([`standard_normal`]) gives the same value as the first draw of a block. The smallest tail
//! probability is `2⁻³³`, so draws lie within ±6.4σ (a wider one would come once in about 5·10⁹
//! draws) and AS241's far piece (`√(−ln p) > 5`) is never needed.

use rand::Rng;

use crate::math::Real;
use crate::simd::SimdLevel;

/// `2⁻⁵³`.
const EPS53: Real = 1.0 / (1u64 << 53) as Real;
/// `2⁻³²`.
const EPS32: f32 = 1.0 / 4_294_967_296.0;

/// The uniform `u ∈ [0, 1)` of one `u64` (its top 53 bits), as `rand`'s `random::<f64>()`.
#[inline(always)]
pub fn unit_uniform(x: u64) -> Real {
    (x >> 11) as Real * EPS53
}

// AS241's PPND7 coefficients (Wichura 1988), lowest power first, as published.
const CENTRAL_NUM: [f32; 4] = [3.387_132_7, 50.434_27, 159.291_13, 59.109_375];
#[allow(clippy::excessive_precision)]
const CENTRAL_DEN: [f32; 4] = [1.0, 17.895_17, 78.757_76, 67.187_564];
const NEAR_NUM: [f32; 4] = [1.423_437_3, 2.756_815_4, 1.306_728_5, 0.170_238_21];
const NEAR_DEN: [f32; 3] = [1.0, 0.737_001_64, 0.120_211_33];

/// `c[0] + c[1] r + …` by Horner's rule.
#[inline(always)]
fn horner<const N: usize>(c: &[f32; N], r: f32) -> f32 {
    let mut acc = c[N - 1];
    for k in (0..N - 1).rev() {
        acc = acc * r + c[k];
    }
    acc
}

/// `ln x` for a positive normal `x`, without branches: `x = 2^e m` with `m ∈ [√½, √2)`, and
/// `ln m = 2 atanh s = 2 (s + s³/3 + … + s¹¹/11)`, `s = (m − 1)/(m + 1)`, `|s| ≤ 0.172`
/// (truncation below 1e-9 relative). Within a few ulp of `f32::ln`.
#[inline(always)]
fn ln_positive(x: f32) -> f32 {
    const ONE_BITS: u32 = 0x3F80_0000;
    let bits = x.to_bits();
    let m = f32::from_bits((bits & 0x007F_FFFF) | ONE_BITS);
    let big = m > std::f32::consts::SQRT_2;
    let m = if big { 0.5 * m } else { m };
    let e = ((bits >> 23) as i32 - 127) as f32 + if big { 1.0 } else { 0.0 };
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let mut acc = 1.0 / 11.0;
    for k in (0..5).rev() {
        acc = acc * s2 + 1.0 / (2 * k + 1) as f32;
    }
    e * std::f32::consts::LN_2 + 2.0 * s * acc
}

/// AS241's central piece holds for `|p − ½| ≤ 0.425`.
const CENTRAL_HALF_WIDTH: f32 = 0.425;

/// `Φ⁻¹((k + ½) · 2⁻³²)` by PPND7, without branches: both pieces are computed, the quotient
/// of the right one is taken. With `t = min(p, 1 − p) = (m + ½) · 2⁻³²`, `m = min(k, !k)`
/// exactly, and `|p − ½| = ½ − t`.
#[inline(always)]
pub fn normal_of_bits(k: u32) -> f32 {
    let low = (k as i32) >= 0; // p < ½
    let m = k ^ ((k as i32 >> 31) as u32);
    let t = (m as i32 as f32 + 0.5) * EPS32;
    let q = 0.5 - t;
    let rc = 0.180_625 - q * q;
    let (num_c, den_c) = (horner(&CENTRAL_NUM, rc) * q, horner(&CENTRAL_DEN, rc));
    let r = (-ln_positive(t)).sqrt() - 1.6;
    let (num_t, den_t) = (horner(&NEAR_NUM, r), horner(&NEAR_DEN, r));
    let central = q <= CENTRAL_HALF_WIDTH;
    let z = (if central { num_c } else { num_t }) / (if central { den_c } else { den_t });
    if low {
        -z
    } else {
        z
    }
}

/// One standard-normal draw from `rng`: [`normal_of_bits`] of one `u32`.
#[inline]
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> Real {
    normal_of_bits(rng.next_u32()) as Real
}

/// Replaces each raw `u32` (stored as `f32` bits) by its standard normal.
#[inline(always)]
fn normals_in_place(out: &mut [f32]) {
    for v in out.iter_mut() {
        *v = normal_of_bits(u32::from_le(v.to_bits()));
    }
}

/// [`normals_in_place`] built for AVX-512 (the same values: no fused multiply-add is asked for).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn normals_in_place_avx512(out: &mut [f32]) {
    normals_in_place(out);
}

/// [`normals_in_place`] built for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn normals_in_place_avx2(out: &mut [f32]) {
    normals_in_place(out);
}

/// Fills `out` with raw draws from `rng`, in order (as `n` calls of `next_u32` or `next_u64`
/// on a little-endian machine give them), as bit patterns.
fn fill_bits<R: Rng + ?Sized, T: Copy>(rng: &mut R, out: &mut [T]) {
    // SAFETY: `out` is `size_of_val(out)` initialised bytes; it is used only with `f32` and
    // `f64`, for which every bit pattern is valid.
    let bytes = unsafe { std::slice::from_raw_parts_mut(out.as_mut_ptr().cast::<u8>(), std::mem::size_of_val(out)) };
    rng.fill_bytes(bytes);
}

/// Fills `out` with standard-normal draws, the `k`-th from the `k`-th `u32` of `rng` (the
/// same values as `out.len()` calls of [`standard_normal`]), in SIMD lanes.
pub fn fill_standard_normal<R: Rng + ?Sized>(rng: &mut R, out: &mut [f32]) {
    fill_bits(rng, out);
    match SimdLevel::detect() {
        // SAFETY: the CPU has every feature the build enables (that is what `detect` finds).
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx512 => unsafe { normals_in_place_avx512(out) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        SimdLevel::Avx2 => unsafe { normals_in_place_avx2(out) },
        _ => normals_in_place(out),
    }
}

/// Fills `out` with uniforms in `[0, 1)`, the `k`-th from the `k`-th `u64` of `rng`
/// ([`unit_uniform`]).
pub fn fill_unit_uniform<R: Rng + ?Sized>(rng: &mut R, out: &mut [Real]) {
    fill_bits(rng, out);
    out.iter_mut().for_each(|v| *v = unit_uniform(u64::from_le(v.to_bits())));
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngCore, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// AS241 to sixteen digits (PPND16, in `f64`): the reference `Φ⁻¹`.
    fn reference_inverse_cdf(p: f64) -> f64 {
        const A: [f64; 8] = [3.3871328727963665, 133.14166789178438, 1971.5909503065513, 13731.69376550946, 45921.95393154987, 67265.7709270087, 33430.57558358813, 2509.0809287301227];
        const B: [f64; 8] = [1.0, 42.31333070160091, 687.1870074920579, 5394.196021424751, 21213.794301586597, 39307.89580009271, 28729.085735721943, 5226.495278852854];
        const C: [f64; 8] = [1.4234371107496835, 4.630337846156546, 5.769497221460691, 3.6478483247632045, 1.2704582524523684, 0.2417807251774506, 0.022723844989269184, 0.0007745450142783414];
        const D: [f64; 8] = [1.0, 2.053191626637759, 1.6763848301838038, 0.6897673349851, 0.14810397642748008, 0.015198666563616457, 0.0005475938084995345, 1.0507500716444169e-09];
        const E: [f64; 8] =
            [6.657904643501103, 5.463784911164114, 1.7848265399172913, 0.29656057182850487, 0.026532189526576124, 0.0012426609473880784, 2.7115555687434876e-05, 2.0103343992922881e-07];
        const F: [f64; 8] = [1.0, 0.599832206555888, 0.1369298809227358, 0.014875361290850615, 0.0007868691311456133, 1.8463183175100548e-05, 1.421511758316446e-07, 2.0442631033899397e-15];
        let h = |c: &[f64; 8], r: f64| c.iter().rev().fold(0.0, |acc, &v| acc * r + v);
        let q = p - 0.5;
        if q.abs() <= 0.425 {
            let r = 0.180625 - q * q;
            return q * h(&A, r) / h(&B, r);
        }
        let r = (-(p.min(1.0 - p)).ln()).sqrt();
        let z = if r <= 5.0 { h(&C, r - 1.6) / h(&D, r - 1.6) } else { h(&E, r - 5.0) / h(&F, r - 5.0) };
        if q < 0.0 {
            -z
        } else {
            z
        }
    }

    fn p_of(k: u32) -> f64 {
        (k as f64 + 0.5) / 4_294_967_296.0
    }

    #[test]
    fn standard_normal_has_unit_moments() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 200_000;
        let xs: Vec<Real> = (0..n).map(|_| standard_normal(&mut rng)).collect();
        let mean = xs.iter().sum::<Real>() / n as Real;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<Real>() / n as Real;
        let kurt = xs.iter().map(|x| (x - mean).powi(4)).sum::<Real>() / n as Real / (var * var);
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.02, "var {var}");
        assert!((kurt - 3.0).abs() < 0.1, "kurtosis {kurt}");
    }

    /// Quantiles from Python's `statistics.NormalDist().inv_cdf` at `p = (k + ½) 2⁻³²`, and
    /// the sixteen-digit AS241 over the whole range of `k` (both pieces, every tail): PPND7's
    /// 1.2e-7 and the `f32` rounding stay below 5e-7 relative (3.5e-7 seen).
    #[test]
    fn quantiles_match_the_inverse_cdf_to_seven_digits() {
        let python = [
            (0u32, -6.337957754553789),
            (1, -6.166429517819749),
            (1 << 20, -3.4871039765916896),
            (322_122_547, -1.4395314704450153),
            (2_147_483_647, -2.9180993729166234e-10),
            (2_147_483_648, 2.9180993729166234e-10),
            (3_000_000_000, 0.5200680618488762),
            (u32::MAX, 6.337957754553789),
        ];
        let close = |k: u32, want: f64| {
            let got = normal_of_bits(k) as f64;
            assert!((got - want).abs() <= 5e-7 * want.abs().max(1.0), "k = {k}: {got} against {want}");
        };
        for (k, z) in python {
            close(k, z);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for j in 0..100_000u32 {
            // uniform k, and tails down to the extremes on both sides
            let k = if j % 2 == 0 { rng.next_u32() } else { rng.next_u32() >> (j % 32) };
            let k = if j % 4 == 1 { !k } else { k };
            close(k, reference_inverse_cdf(p_of(k)));
        }
        assert!((reference_inverse_cdf(0.975) - 1.9599639845400536).abs() < 1e-15, "the reference itself");
    }

    /// The distribution, by a Kolmogorov–Smirnov distance against `Φ` tabulated by bisection
    /// on the reference `Φ⁻¹` (monotone), and the exact symmetry of draw `!k` and draw `k`.
    #[test]
    fn draws_follow_the_normal_distribution() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut z = vec![0.0f32; 100_000];
        fill_standard_normal(&mut rng, &mut z);
        z.sort_by(|a, b| a.total_cmp(b));
        let cdf = |x: f64| {
            let (mut lo, mut hi) = (1e-300f64, 1.0 - 1e-16);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if reference_inverse_cdf(mid) < x {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let n = z.len() as Real;
        let ks = z.iter().step_by(97).enumerate().map(|(j, &x)| {
            let i = (j * 97) as Real;
            let f = cdf(x as f64);
            (f - i / n).abs().max((f - (i + 1.0) / n).abs())
        });
        let d = ks.fold(0.0, Real::max);
        // the 1 % critical value of the KS distance for n = 100 000 is 1.63/√n ≈ 0.0052
        assert!(d < 0.0052, "KS distance {d}");
        for k in [0u32, 1, 77, 1 << 20, 322_122_547, 2_000_000_000, 2_147_483_647] {
            assert_eq!(normal_of_bits(!k), -normal_of_bits(k), "symmetry at {k}");
        }
        // monotone in k across the pieces' joins
        let mut last = f32::NEG_INFINITY;
        for k in (0..=u32::MAX).step_by(4099) {
            let z = normal_of_bits(k);
            assert!(z >= last, "not monotone at {k}");
            last = z;
        }
    }

    #[test]
    fn ln_is_within_a_few_ulp_of_std() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for k in 0..100_000 {
            // the tail probabilities the draws use, and values around the √2 split
            let x = if k % 2 == 0 { (rng.next_u32() >> 1) as f32 * EPS32 + 0.5 * EPS32 } else { std::f32::consts::SQRT_2 * (1.0 + (k as f32 - 50_000.0) * 2e-7) };
            let (got, want) = (ln_positive(x) as f64, (x as f64).ln());
            assert!((got - want).abs() <= 3.0 * f32::EPSILON as f64 * want.abs().max(1e-30), "ln {x}: {got} against {want}");
        }
        assert_eq!(ln_positive(1.0), 0.0);
    }

    #[test]
    fn a_block_equals_single_draws_at_every_simd_level() {
        let (mut a, mut b) = (ChaCha8Rng::seed_from_u64(3), ChaCha8Rng::seed_from_u64(3));
        let mut block = vec![0.0f32; 1000];
        fill_standard_normal(&mut a, &mut block);
        let single: Vec<f32> = (0..1000).map(|_| standard_normal(&mut b) as f32).collect();
        assert_eq!(block, single);
        assert!(block.iter().any(|z| z.abs() > 1.44), "the tails are exercised");
        assert_eq!(a.next_u64(), b.next_u64(), "the streams stay in step");
        let raw: Vec<f32> = (0..999u32).map(|k| f32::from_bits(k.wrapping_mul(0x9E37_79B9) ^ (k << 31))).collect();
        let mut portable = raw.clone();
        normals_in_place(&mut portable);
        #[cfg(target_arch = "x86_64")]
        {
            if SimdLevel::Avx2.is_supported() {
                let mut v = raw.clone();
                unsafe { normals_in_place_avx2(&mut v) };
                assert!(v.iter().zip(&portable).all(|(x, y)| x.to_bits() == y.to_bits()), "AVX2");
            }
            if SimdLevel::Avx512.is_supported() {
                let mut v = raw.clone();
                unsafe { normals_in_place_avx512(&mut v) };
                assert!(v.iter().zip(&portable).all(|(x, y)| x.to_bits() == y.to_bits()), "AVX-512");
            }
        }
        let mut u = vec![0.0; 100];
        fill_unit_uniform(&mut a, &mut u);
        let single: Vec<Real> = (0..100).map(|_| b.random::<Real>()).collect();
        assert_eq!(u, single, "uniforms as rand's random::<f64>()");
    }
}
