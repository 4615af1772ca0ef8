//! Scalar types the composite kernel runs in (`f32` or `f64`), with a branch-free `exp`
//! that the compiler vectorises (no libm call in the hot loop).

use core::ops::{Add, Div, Mul, Neg, Sub};

/// A floating-point scalar the composite kernel is generic over.
pub trait Lane: Copy + PartialOrd + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self> + Send + Sync + 'static {
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// +∞.
    const INF: Self;
    /// Name used in docs and benches.
    const NAME: &'static str;
    /// Conversion from `f64` (rounding for `f32`).
    fn from_f64(v: f64) -> Self;
    /// Conversion to `f64` (exact).
    fn to_f64(self) -> f64;
    /// `|x|`.
    fn abs(self) -> Self;
    /// `|self|` with the sign of `sign`.
    fn copysign(self, sign: Self) -> Self;
    /// `a * b + c`, fused when `FMA` (only instantiate `FMA = true` in code compiled with the
    /// `fma` target feature; elsewhere it would call libm).
    fn madd<const FMA: bool>(a: Self, b: Self, c: Self) -> Self;
    /// Largest `κ` for which the kernel can shift its log-sum-exp by the constant `κ`
    /// (terms in `[e^{−2κ}, 1]` stay normal numbers) and skip the pass that finds the max.
    const MAX_FIXED_SHIFT: f64;
    /// `exp(x)` for `x ≤ 0`, relative error below 2 ulp; returns exactly 0 where the result
    /// would be subnormal (x below about −87 for `f32`, −708 for `f64`). NaN is not handled:
    /// callers reject non-finite input first.
    fn exp_nonpos<const FMA: bool>(x: Self) -> Self;
    /// Lowest argument [`Lane::exp2_in_range`] accepts (the smallest normal power of two).
    const EXP2_LOW: Self;
    /// `2^x` for `EXP2_LOW ≤ x ≤ 0` (Taylor series of `2^r`, `|r| ≤ 1/2`: about 1 ulp);
    /// meaningless outside that range, so callers mask or clamp.
    fn exp2_in_range<const FMA: bool>(x: Self) -> Self;
}

#[inline(always)]
fn select<T: Copy>(c: bool, a: T, b: T) -> T {
    if c {
        a
    } else {
        b
    }
}

// (the polynomials' coefficients as fitted: digits past f32's precision kept, and a last one
// that is ln 2 only to within the fit)
#[allow(clippy::excessive_precision, clippy::approx_constant)]
impl Lane for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const INF: Self = f32::INFINITY;
    const NAME: &'static str = "f32";
    const MAX_FIXED_SHIFT: f64 = 40.0;
    #[inline(always)]
    fn madd<const FMA: bool>(a: Self, b: Self, c: Self) -> Self {
        if FMA {
            f32::mul_add(a, b, c)
        } else {
            a * b + c
        }
    }
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        f32::copysign(self, sign)
    }
    const EXP2_LOW: Self = -126.0;
    #[inline(always)]
    fn exp2_in_range<const FMA: bool>(x: Self) -> Self {
        const MAGIC: f32 = 12_582_912.0;
        let t = x + MAGIC;
        let r = x - (t - MAGIC);
        let mut p: f32 = 0.000_154_035_3;
        p = Self::madd::<FMA>(p, r, 0.001_333_355_8);
        p = Self::madd::<FMA>(p, r, 0.009_618_129);
        p = Self::madd::<FMA>(p, r, 0.055_504_11);
        p = Self::madd::<FMA>(p, r, 0.240_226_5);
        p = Self::madd::<FMA>(p, r, 0.693_147_2);
        p = Self::madd::<FMA>(p, r, 1.0);
        p * f32::from_bits(t.to_bits().wrapping_add(127) << 23)
    }
    #[inline(always)]
    fn exp_nonpos<const FMA: bool>(x: Self) -> Self {
        // Cephes expf: x = n ln2 + r, |r| ≤ ln2/2, exp(r) by a degree-7 polynomial.
        const MAGIC: f32 = 12_582_912.0; // 1.5 · 2^23: adding it rounds to an integer
        const LOW: f32 = -87.0;
        let under = x < LOW;
        let xc = select(under, LOW, x);
        let t = Self::madd::<FMA>(xc, core::f32::consts::LOG2_E, MAGIC);
        let n = t - MAGIC;
        let r = xc - n * 0.693_359_4 - n * -2.121_944_4e-4;
        let mut p = 1.987_569_1e-4_f32;
        p = Self::madd::<FMA>(p, r, 1.398_199_9e-3);
        p = Self::madd::<FMA>(p, r, 8.333_452e-3);
        p = Self::madd::<FMA>(p, r, 4.166_579_6e-2);
        p = Self::madd::<FMA>(p, r, 1.666_666_5e-1);
        p = Self::madd::<FMA>(p, r, 5.000_000_1e-1);
        let y = Self::madd::<FMA>(p * r, r, r) + 1.0;
        // The low mantissa bits of `t` hold n + 2^22; shifting n + 127 into the exponent
        // field builds 2^n (n ∈ [−126, 0]) with wrapping integer ops only.
        let scale = f32::from_bits(t.to_bits().wrapping_add(127) << 23);
        select(under, 0.0, y * scale)
    }
}

// (the polynomials' coefficients as fitted: digits past f64's precision kept, and a last one
// that is ln 2 only to within the fit)
#[allow(clippy::excessive_precision, clippy::approx_constant)]
impl Lane for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const INF: Self = f64::INFINITY;
    const NAME: &'static str = "f64";
    const MAX_FIXED_SHIFT: f64 = 340.0;
    #[inline(always)]
    fn madd<const FMA: bool>(a: Self, b: Self, c: Self) -> Self {
        if FMA {
            f64::mul_add(a, b, c)
        } else {
            a * b + c
        }
    }
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        f64::copysign(self, sign)
    }
    const EXP2_LOW: Self = -1022.0;
    #[inline(always)]
    fn exp2_in_range<const FMA: bool>(x: Self) -> Self {
        const MAGIC: f64 = 6_755_399_441_055_744.0;
        let t = x + MAGIC;
        let r = x - (t - MAGIC);
        let mut p: f64 = 2.567_843_599_348_819_6e-11;
        p = Self::madd::<FMA>(p, r, 4.445_538_271_870_81e-10);
        p = Self::madd::<FMA>(p, r, 7.054_911_620_801_121e-9);
        p = Self::madd::<FMA>(p, r, 1.017_808_600_923_969_6e-7);
        p = Self::madd::<FMA>(p, r, 1.321_548_679_014_430_5e-6);
        p = Self::madd::<FMA>(p, r, 1.525_273_380_405_983_8e-5);
        p = Self::madd::<FMA>(p, r, 0.000_154_035_303_933_816_06);
        p = Self::madd::<FMA>(p, r, 0.001_333_355_814_642_844_1);
        p = Self::madd::<FMA>(p, r, 0.009_618_129_107_628_477);
        p = Self::madd::<FMA>(p, r, 0.055_504_108_664_821_576);
        p = Self::madd::<FMA>(p, r, 0.240_226_506_959_100_7);
        p = Self::madd::<FMA>(p, r, 0.693_147_180_559_945_3);
        p = Self::madd::<FMA>(p, r, 1.0);
        p * f64::from_bits(t.to_bits().wrapping_add(1023) << 52)
    }
    #[inline(always)]
    fn exp_nonpos<const FMA: bool>(x: Self) -> Self {
        // x = n ln2 + r with the fdlibm split of ln2, exp(r) by its Taylor series to r^13
        // (truncation below 5e-18 for |r| ≤ ln2/2).
        const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52
        const LOW: f64 = -708.0;
        let under = x < LOW;
        let xc = select(under, LOW, x);
        let t = Self::madd::<FMA>(xc, core::f64::consts::LOG2_E, MAGIC);
        let n = t - MAGIC;
        let r = xc - n * 6.931_471_803_691_238_164_90e-1 - n * 1.908_214_929_270_587_700_02e-10;
        let mut p = 1.0 / 6_227_020_800.0; // 1/13!
        p = Self::madd::<FMA>(p, r, 1.0 / 479_001_600.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 39_916_800.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 3_628_800.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 362_880.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 40_320.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 5_040.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 720.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 120.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 24.0);
        p = Self::madd::<FMA>(p, r, 1.0 / 6.0);
        p = Self::madd::<FMA>(p, r, 0.5);
        let y = Self::madd::<FMA>(p * r, r, r) + 1.0;
        let scale = f64::from_bits(t.to_bits().wrapping_add(1023) << 52);
        select(under, 0.0, y * scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_f64_matches_libm_to_two_ulp() {
        let mut x = -707.9_f64;
        while x <= 0.0 {
            let (got, want) = (f64::exp_nonpos::<false>(x), x.exp());
            assert!(((got - want) / want).abs() < 4.5e-16, "x={x} got={got} want={want}");
            x += 0.0137;
        }
    }

    #[test]
    fn exp_f32_matches_libm_to_two_ulp() {
        let mut x = -86.9_f32;
        while x <= 0.0 {
            let (got, want) = (f32::exp_nonpos::<false>(x) as f64, (x as f64).exp());
            assert!(((got - want) / want).abs() < 2.4e-7, "x={x} got={got} want={want}");
            x += 0.00731;
        }
    }

    #[test]
    fn exp2_in_range_matches_libm() {
        let mut x = -125.9_f64;
        while x <= 0.0 {
            let want = x.exp2();
            assert!(((f64::exp2_in_range::<false>(x) - want) / want).abs() < 4.5e-16, "f64 x={x}");
            let got32 = f32::exp2_in_range::<false>(x as f32) as f64;
            let want32 = (x as f32 as f64).exp2();
            assert!(((got32 - want32) / want32).abs() < 2.4e-7, "f32 x={x}");
            x += 0.0173;
        }
    }

    #[test]
    fn exp_flushes_to_zero_below_the_normal_range() {
        assert_eq!(f32::exp_nonpos::<false>(-1e30), 0.0);
        assert_eq!(f64::exp_nonpos::<false>(-1e300), 0.0);
        assert_eq!(f32::exp_nonpos::<false>(f32::NEG_INFINITY), 0.0);
        assert_eq!(f64::exp_nonpos::<false>(0.0), 1.0);
    }
}
