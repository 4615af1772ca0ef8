//! Noise draws from the world's seeded RNG (no other source of randomness is used).
//!
//! Every standard-normal draw is the inverse normal CDF of one uniform made from one `u64` of
//! the RNG: `p = (⌊x / 2¹²⌋ + ½) · 2⁻⁵² ∈ (0, 1)`, `z = Φ⁻¹(p)` by Wichura's AS241 (PPND16,
//! relative error about 1e-16; the algorithm of Python's `statistics.NormalDist.inv_cdf`).
//! One draw per `u64`, no rejection and no branch: a block of draws is a block of `u64`s,
//! converted in SIMD lanes ([`fill_standard_normal`]); a single draw ([`standard_normal`])
//! gives the same value as the first draw of a block.

use rand::Rng;

use crate::math::Real;

/// `2⁻⁵³`.
const EPS53: Real = 1.0 / (1u64 << 53) as Real;
/// The bits of `1.0`.
const ONE_BITS: u64 = 0x3FF0_0000_0000_0000;
/// The fraction bits of an `f64`.
const FRACTION: u64 = 0x000F_FFFF_FFFF_FFFF;

/// The uniform `p ∈ (0, 1)` of one `u64`: its top 52 bits, offset by half a step (exact:
/// `1 + m·2⁻⁵²` is built from the bits, then `1 − 2⁻⁵³` taken off).
#[inline(always)]
pub fn open_uniform(x: u64) -> Real {
    (Real::from_bits(ONE_BITS | (x >> 12)) - 1.0) + EPS53
}

/// The uniform `u ∈ [0, 1)` of one `u64` (its top 53 bits), as `rand`'s `random::<f64>()`.
#[inline(always)]
pub fn unit_uniform(x: u64) -> Real {
    (x >> 11) as Real * EPS53
}

// AS241's coefficients (Wichura 1988), highest power first, as in Python's `statistics`.
const CENTRAL_NUM: [Real; 8] = [2509.0809287301227, 33430.57558358813, 67265.7709270087, 45921.95393154987, 13731.69376550946, 1971.5909503065513, 133.14166789178438, 3.3871328727963665];
const CENTRAL_DEN: [Real; 8] = [5226.495278852854, 28729.085735721943, 39307.89580009271, 21213.794301586597, 5394.196021424751, 687.1870074920579, 42.31333070160091, 1.0];
const NEAR_NUM: [Real; 8] = [0.0007745450142783414, 0.022723844989269184, 0.2417807251774506, 1.2704582524523684, 3.6478483247632045, 5.769497221460691, 4.630337846156546, 1.4234371107496835];
const NEAR_DEN: [Real; 8] = [1.0507500716444169e-09, 0.0005475938084995345, 0.015198666563616457, 0.14810397642748008, 0.6897673349851, 1.6763848301838038, 2.053191626637759, 1.0];
const FAR_NUM: [Real; 8] = [2.0103343992922881e-07, 2.7115555687434876e-05, 0.0012426609473880784, 0.026532189526576124, 0.29656057182850487, 1.7848265399172913, 5.463784911164114, 6.657904643501103];
const FAR_DEN: [Real; 8] = [2.0442631033899397e-15, 1.421511758316446e-07, 1.8463183175100548e-05, 0.0007868691311456133, 0.014875361290850615, 0.1369298809227358, 0.599832206555888, 1.0];

/// `c[0] r⁷ + … + c[7]` by Horner's rule, in AS241's order of operations.
#[inline(always)]
fn horner(c: &[Real; 8], r: Real) -> Real {
    let mut acc = c[0];
    for &ck in &c[1..] {
        acc = acc * r + ck;
    }
    acc
}

/// `ln x` for a positive normal `x`, without branches: `x = 2^e m` with `m ∈ [√½, √2)`, and
/// `ln m = 2 atanh s = 2 (s + s³/3 + … + s²¹/21)`, `s = (m − 1)/(m + 1)`, `|s| ≤ 0.172`
/// (truncation below 1e-19). Within a few ulp of `f64::ln`.
#[inline(always)]
fn ln_positive(x: Real) -> Real {
    let bits = x.to_bits();
    let m = Real::from_bits((bits & FRACTION) | ONE_BITS);
    let big = m > std::f64::consts::SQRT_2;
    let m = if big { 0.5 * m } else { m };
    let e = ((bits >> 52) as i64 - 1023) as Real + if big { 1.0 } else { 0.0 };
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let mut acc = 1.0 / 21.0;
    for k in (0..10).rev() {
        acc = acc * s2 + 1.0 / (2 * k + 1) as Real;
    }
    e * std::f64::consts::LN_2 + 2.0 * s * acc
}

/// AS241's central piece holds for `|p − ½| ≤ 0.425`.
const CENTRAL_HALF_WIDTH: Real = 0.425;

/// AS241's central piece (finite for every `q`).
#[inline(always)]
fn central(q: Real) -> Real {
    let r = 0.180625 - q * q;
    horner(&CENTRAL_NUM, r) * q / horner(&CENTRAL_DEN, r)
}

/// `Φ⁻¹(p)` for `p ∈ (0, 1)` (AS241), without branches: both pieces are computed, the
/// quotient of the right one is taken (one division). The sign and quotient follow AS241.
#[inline(always)]
pub fn inverse_normal_cdf(p: Real) -> Real {
    pieces::<true>(p)
}

/// A little above `e⁻²⁵ ≈ 1.39e-11`: below this `min(p, 1 − p)` AS241 may take its far piece
/// (`√(−ln t) > 5`), so a block redoes its draws with all pieces.
const FAR_BELOW: Real = 1.5e-11;

/// AS241 by its central and near pieces; with `FAR`, also its far piece (else the far lanes,
/// `min(p, 1 − p) < e⁻²⁵`, are wrong and must be redone).
#[inline(always)]
fn pieces<const FAR: bool>(p: Real) -> Real {
    let q = p - 0.5;
    let rc = 0.180625 - q * q;
    let (num_c, den_c) = (horner(&CENTRAL_NUM, rc) * q, horner(&CENTRAL_DEN, rc));
    let t = if q <= 0.0 { p } else { 1.0 - p };
    let r = (-ln_positive(t)).sqrt();
    let (mut num_t, mut den_t) = (horner(&NEAR_NUM, r - 1.6), horner(&NEAR_DEN, r - 1.6));
    if FAR && r > 5.0 {
        (num_t, den_t) = (horner(&FAR_NUM, r - 5.0), horner(&FAR_DEN, r - 5.0));
    }
    let num_t = if q < 0.0 { -num_t } else { num_t };
    let central = q.abs() <= CENTRAL_HALF_WIDTH;
    (if central { num_c } else { num_t }) / (if central { den_c } else { den_t })
}

/// One standard-normal draw from `rng`: `Φ⁻¹` of one `u64`'s open uniform.
#[inline]
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> Real {
    inverse_normal_cdf(open_uniform(rng.next_u64()))
}

/// Replaces each raw `u64` (stored as `f64` bits) by its standard normal. In blocks: the
/// central piece for every draw in lanes; the tail draws (15 %) gathered and given the near
/// piece in lanes; the rare far draws (about one in 4·10¹⁰) redone with all pieces.
#[inline(always)]
fn normals_in_place(out: &mut [Real]) {
    const BLOCK: usize = 256;
    let mut ps = [0.0; BLOCK];
    let mut tail_p = [0.5; BLOCK];
    let mut tail_k = [0u16; BLOCK];
    for block in out.chunks_mut(BLOCK) {
        let ps = &mut ps[..block.len()];
        for (p, v) in ps.iter_mut().zip(block.iter_mut()) {
            *p = open_uniform(u64::from_le(v.to_bits()));
            *v = central(*p - 0.5);
        }
        // gather the tails without branches: every draw is written, only tails advance
        let mut m = 0;
        for (k, &p) in ps.iter().enumerate() {
            tail_p[m] = p;
            tail_k[m] = k as u16;
            m += ((p - 0.5).abs() > CENTRAL_HALF_WIDTH) as usize;
        }
        let mut far = false;
        for p in tail_p[..m].iter_mut() {
            far |= p.min(1.0 - *p) < FAR_BELOW;
            *p = pieces::<false>(*p);
        }
        for (&k, &z) in tail_k[..m].iter().zip(&tail_p[..m]) {
            block[k as usize] = z;
        }
        if far {
            for (&p, v) in ps.iter().zip(block.iter_mut()) {
                *v = inverse_normal_cdf(p);
            }
        }
    }
}

/// [`normals_in_place`] built for AVX-512 (the same values: no fused multiply-add is asked for).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn normals_in_place_avx512(out: &mut [Real]) {
    normals_in_place(out);
}

/// [`normals_in_place`] built for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn normals_in_place_avx2(out: &mut [Real]) {
    normals_in_place(out);
}

/// Fills `out` with raw `u64` draws from `rng`, in order (as `out.len()` calls of `next_u64`
/// on a little-endian machine give them), stored as `f64` bit patterns.
fn fill_bits<R: Rng + ?Sized>(rng: &mut R, out: &mut [Real]) {
    // SAFETY: `out` is `8·len` initialised bytes; every bit pattern is a valid `f64`.
    let bytes = unsafe { std::slice::from_raw_parts_mut(out.as_mut_ptr().cast::<u8>(), std::mem::size_of_val(out)) };
    rng.fill_bytes(bytes);
}

/// Fills `out` with standard-normal draws, the `k`-th from the `k`-th `u64` of `rng` (the
/// same values as `out.len()` calls of [`standard_normal`]), in SIMD lanes.
pub fn fill_standard_normal<R: Rng + ?Sized>(rng: &mut R, out: &mut [Real]) {
    fill_bits(rng, out);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx512f") && has!("avx512dq") && has!("avx512vl") && has!("avx2") && has!("fma") {
            // SAFETY: the CPU has every feature the build enables, checked just above.
            return unsafe { normals_in_place_avx512(out) };
        }
        if has!("avx2") && has!("fma") {
            // SAFETY: as above.
            return unsafe { normals_in_place_avx2(out) };
        }
    }
    normals_in_place(out);
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

    /// Quantiles from Python's `statistics.NormalDist().inv_cdf` (also AS241), which agree with
    /// the exact quantiles to about 1e-16 relative; both tail pieces are checked.
    #[test]
    fn inverse_cdf_matches_reference_quantiles() {
        let cases = [
            (0.5, 0.0),
            (0.6, 0.2533471031357998),
            (0.3, -0.5244005127080407),
            (0.925, 1.439531470938456),
            (0.975, 1.9599639845400536),
            (0.999, 3.090232306167813),
            (1e-3, -3.090232306167813),
            (0.05, -1.6448536269514726),
            (1e-10, -6.361340902404056),
            (1e-15, -7.941345326170995),
            (2.0f64.powi(-54), -8.292361075813595),
        ];
        for (p, z) in cases {
            let got = inverse_normal_cdf(p);
            assert!((got - z).abs() <= 1e-15 * z.abs().max(1.0), "Φ⁻¹({p}) = {got}, expected {z}");
        }
    }

    /// The distribution, by a Kolmogorov–Smirnov distance against `Φ` tabulated by bisection
    /// on `Φ⁻¹` (monotone), and the symmetry `Φ⁻¹(1 − p) = −Φ⁻¹(p)`.
    #[test]
    fn draws_follow_the_normal_distribution() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut z = vec![0.0; 100_000];
        fill_standard_normal(&mut rng, &mut z);
        z.sort_by(|a, b| a.total_cmp(b));
        let cdf = |x: Real| {
            let (mut lo, mut hi) = (1e-300f64, 1.0 - 1e-16);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if inverse_normal_cdf(mid) < x {
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
            let f = cdf(x);
            (f - i / n).abs().max((f - (i + 1.0) / n).abs())
        });
        let d = ks.fold(0.0, Real::max);
        // the 1 % critical value of the KS distance for n = 100 000 is 1.63/√n ≈ 0.0052
        assert!(d < 0.0052, "KS distance {d}");
        // (probabilities whose complement is exact)
        for p in [2.0f64.powi(-40), 2.0f64.powi(-17), 2.0f64.powi(-7), 0.0703125, 0.1875, 0.40625] {
            let (a, b) = (inverse_normal_cdf(1.0 - p), inverse_normal_cdf(p));
            assert!((a + b).abs() <= 1e-15 * b.abs(), "symmetry at {p}: {a} against {b}");
        }
    }

    /// Blocks with far draws (the extreme `u64`s) redo them with all pieces.
    #[test]
    fn far_draws_in_a_block_take_the_far_piece() {
        let raw: Vec<u64> = (0..200u64).map(|k| match k % 50 {
            0 => 0,
            1 => u64::MAX,
            2 => 1 << 20,
            _ => k.wrapping_mul(0x9E37_79B9_7F4A_7C15),
        }).collect();
        let mut block: Vec<Real> = raw.iter().map(|&b| Real::from_bits(b)).collect();
        normals_in_place(&mut block);
        for (&b, &z) in raw.iter().zip(&block) {
            assert_eq!(z, inverse_normal_cdf(open_uniform(b)));
        }
        assert!((block[0] + 8.209536151601386).abs() < 1e-14, "Φ⁻¹(2⁻⁵³) = {}", block[0]);
        assert_eq!(block[1], -block[0]);
    }

    #[test]
    fn ln_is_within_a_few_ulp_of_std() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for k in 0..100_000 {
            // p-like values down to 2⁻⁵³, and values around the √2 split
            let x = if k % 2 == 0 { open_uniform(rng.next_u64()) * 0.5f64.powi((k % 53) as i32) } else { std::f64::consts::SQRT_2 * (1.0 + (k as Real - 50_000.0) * 1e-12) };
            let (got, want) = (ln_positive(x), x.ln());
            assert!((got - want).abs() <= 4.0 * f64::EPSILON * want.abs().max(1e-300), "ln {x}: {got} against {want}");
        }
        assert_eq!(ln_positive(1.0), 0.0);
    }

    #[test]
    fn a_block_equals_single_draws() {
        let (mut a, mut b) = (ChaCha8Rng::seed_from_u64(3), ChaCha8Rng::seed_from_u64(3));
        let mut block = vec![0.0; 1000];
        fill_standard_normal(&mut a, &mut block);
        let single: Vec<Real> = (0..1000).map(|_| standard_normal(&mut b)).collect();
        assert_eq!(block, single);
        assert!(block.iter().any(|z| z.abs() > 1.44), "the tails are exercised");
        assert_eq!(a.next_u64(), b.next_u64(), "the streams stay in step");
        let mut u = vec![0.0; 100];
        fill_unit_uniform(&mut a, &mut u);
        let single: Vec<Real> = (0..100).map(|_| b.random::<Real>()).collect();
        assert_eq!(u, single, "uniforms as rand's random::<f64>()");
    }
}
