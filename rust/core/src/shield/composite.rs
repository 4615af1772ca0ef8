//! The soft-min composite barrier of the paper, Sec. III-C, in one fused pass over the scan:
//!
//! `H = −(γ/κ) log Σ_i exp(−κ tanh(h_i/γ))`,
//! `∂H/∂p = Σ_i λ_i sech²(h_i/γ) ∂h_i/∂p`, `∂H/∂t = Σ_i λ_i sech²(h_i/γ) ∂h_i/∂t`,
//! `λ_i = exp(−κ tanh(h_i/γ)) / Σ_j exp(−κ tanh(h_j/γ))`.
//!
//! Numerics: the log-sum-exp is shifted so that no term exceeds 1 and none underflows to 0:
//! by the constant `κ` in a single fused pass while `κ ≤ 40` (`f32`) or `κ ≤ 340` (`f64`), so
//! every term lies in `[e^{−2κ}, 1]`, a normal number; for larger `κ` a first pass finds
//! `min h_i` and the shift is the largest exponent `−κ tanh(h_min/γ)`, so the sum is at least 1.
//! Nothing overflows at any κ and `log` never sees 0. The same pass rejects NaN/inf. `tanh` and `sech²`
//! come from one `e = exp(−2|x|)`: `tanh x = sign(x)(1−e)/(1+e)`, `sech² x = 4e/(1+e)²`,
//! accurate in relative terms where `1 − tanh²` would cancel to 0. The reported `H` is
//! finally capped by `γ tanh(h_min/γ)`, the bound of the paper's third remark (Set Inclusion,
//! `H ≤ min_i tanh(h_i/γ)` there; with the `γ` of the composite above, `γ tanh(h_min/γ)`), so
//! `H ≥ 0 ⇒ h_i ≥ 0` holds for the returned numbers exactly, not just up to rounding.
//!
//! Accuracy: the `f64` kernel agrees with a direct `f64` evaluation to about 1e-13 relative;
//! the `f32` kernel (used for `f32` scans), at the paper's `γ = 0.9`, `κ = 8`, to about 1e-5
//! absolute in `H` and 1e-4 relative in the gradient for N ≤ 20,000 (pinned by tests); at
//! extreme parameters (κ = 1e6, γ = 0.01) the `f32` rounding of `h_i` can change which point
//! dominates, and the gradient with it.
//!
//! Speed: the loops are written over fixed-width lane blocks so the compiler vectorises them;
//! [`SimdLevel`] picks an AVX-512 or AVX2+FMA build of the same code at run time (the wheel is
//! built without `target-cpu=native`).

use super::ellipsoid::Envelope;
use super::lane::Lane;
use crate::error::{Error, Result};
use crate::math::Vec3;

pub use crate::simd::SimdLevel;

/// The composite barrier and its derivatives at the robot's current pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompositeBarrier {
    /// `H`, capped by `γ tanh(h_min/γ)`; `γ` for an empty scan (nothing to avoid).
    pub value: f64,
    /// `min_i h_i`; `f64::MAX` for an empty scan.
    pub h_min: f64,
    /// `∂H/∂p_r` in the body frame (rotate by `R` for the world frame); `z = 0` when planar.
    pub grad_body: Vec3,
    /// `∂H/∂t`, the change of `H` caused by the robot's rotation: `grad_omega · ω`.
    pub dh_dt: f64,
    /// `∂(∂H/∂t)/∂ω`: the rotation term is linear in the body-frame angular velocity, so the
    /// filter row is linear in `(v, ω)` with this as the coefficient of `ω` (`[0, 0, ·]`
    /// when planar).
    pub grad_omega: Vec3,
    /// Points that entered the composite (after crop and height band).
    pub num_points: usize,
}

/// What the composite needs besides the points: envelope, `γ`, `κ`, crop and height band.
#[derive(Debug, Clone, Copy)]
pub struct CompositeParams {
    /// The ellipsoid.
    pub envelope: Envelope,
    /// Saturation `γ > 0`.
    pub gamma: f64,
    /// Sharpness `κ > 0`.
    pub kappa: f64,
    /// Points farther than this from the robot are ignored (`None`: keep all).
    pub crop_radius: Option<f64>,
    /// For a planar envelope fed 3D points: keep `z_lo ≤ z ≤ z_hi` (body frame).
    pub height_band: Option<(f64, f64)>,
    /// Body-frame angular velocity (rad/s); planar robots use `[0, 0, yaw_rate]`.
    pub omega: Vec3,
}

impl CompositeParams {
    /// Checks every field as [`super::Shield::new`] does; the error names the field.
    pub fn validate(&self) -> Result<()> {
        check_gamma_kappa(self.gamma, self.kappa)?;
        if !self.omega.iter().all(|v| v.is_finite()) {
            return Err(Error::invalid("omega", format!("must be finite, got {:?}", self.omega)));
        }
        super::scan::ScanFilter { crop_radius: self.crop_radius, height_band: self.height_band, voxel_size: None, angular_bins: None }.validate()
    }
}

/// A planar rigid motion of the points, applied before use: the points were measured in an
/// earlier body frame whose pose in the current one is `(tx, ty, yaw)`. Each point becomes
/// `x' = tx + (cos·x − sin·y)`, `y' = ty + (sin·x + cos·y)`, `z' = z`, computed in the points'
/// own precision (so [`Motion::apply`] on the same numbers gives the same coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// `cos yaw`.
    pub cos: f64,
    /// `sin yaw`.
    pub sin: f64,
    /// Translation, x (m).
    pub tx: f64,
    /// Translation, y (m).
    pub ty: f64,
}

impl Motion {
    /// The motion by `yaw` (rad) and then `(tx, ty)` (m).
    pub fn planar(yaw: f64, tx: f64, ty: f64) -> Self {
        let (sin, cos) = yaw.sin_cos();
        Self { cos, sin, tx, ty }
    }

    /// Whether every number is finite.
    pub fn is_finite(&self) -> bool {
        [self.cos, self.sin, self.tx, self.ty].iter().all(|v| v.is_finite())
    }

    /// `(x', y')` of the point `(x, y)`, in `T` (the motion's numbers rounded to `T`).
    #[inline(always)]
    pub fn apply<T: Lane>(&self, x: T, y: T) -> (T, T) {
        moved(T::from_f64(self.cos), T::from_f64(self.sin), T::from_f64(self.tx), T::from_f64(self.ty), x, y)
    }
}

/// The motion's formula, on numbers already in `T`.
#[inline(always)]
fn moved<T: Lane>(c: T, s: T, tx: T, ty: T, x: T, y: T) -> (T, T) {
    (tx + (c * x - s * y), ty + (s * x + c * y))
}

#[derive(Clone, Copy)]
struct Coeffs<T> {
    ia: T,
    ib: T,
    ic: T,
    crop2: T,
    z_lo: T,
    z_hi: T,
    /// `2 log₂e / γ`: `exp(−2|h|/γ) = 2^(−|h| c2)`.
    c2: T,
    kappa: T,
    /// `κ log₂e`: the weights are computed as powers of two.
    kappa2: T,
    /// The points' [`Motion`]: cosine, sine, translation.
    mc: T,
    ms: T,
    tx: T,
    ty: T,
}

/// Raw sums of the second pass, reduced across lanes in `f64`.
#[derive(Default, Clone, Copy)]
struct Sums {
    s: f64,
    cx: f64,
    cy: f64,
    cz: f64,
    cxy: f64,
    cxz: f64,
    cyz: f64,
}

#[inline(always)]
fn sel<T: Copy>(c: bool, a: T, b: T) -> T {
    if c {
        a
    } else {
        b
    }
}

/// `(in crop & band, h)` of one point.
#[inline(always)]
fn mask_h<T: Lane, const S: usize, const D: usize>(x: T, y: T, z: T, k: &Coeffs<T>) -> (bool, T) {
    let zz = if D == 3 { z * z } else { T::ZERO };
    let r2 = x * x + y * y + zz;
    let band = if S == 3 && D == 2 { (z >= k.z_lo) & (z <= k.z_hi) } else { true };
    let h = x * x * k.ia + y * y * k.ib + zz * k.ic - T::ONE;
    ((r2 <= k.crop2) & band, h)
}

/// `(tanh(h/γ), sech²(h/γ))` from one exponential `e = exp(−2|h|/γ) = 2^(−|h| c2)` with
/// `c2 = 2 log₂e / γ`: `tanh = sign(h)(1−e)/(1+e)`, `sech² = 4e/(1+e)²`; `e` is flushed to 0
/// below the smallest normal power of two.
#[inline(always)]
fn tanh_sech2<T: Lane, const F: bool>(h: T, c2: T) -> (T, T) {
    let x = -(h.abs() * c2);
    let under = x < T::EXP2_LOW;
    let e = sel(under, T::ZERO, T::exp2_in_range::<F>(sel(under, T::EXP2_LOW, x)));
    let inv = T::ONE / (T::ONE + e);
    let th = ((T::ONE - e) * inv).copysign(h);
    let four_e = (e + e) + (e + e);
    (th, four_e * inv * inv)
}

#[inline(always)]
fn coords<T: Lane, const S: usize>(p: &[T]) -> (T, T, T) {
    (p[0], p[1], if S == 3 { p[2] } else { T::ZERO })
}

/// Per-lane running state of a pass.
struct Acc<T, const L: usize> {
    hmin: [T; L],
    cnt: [u32; L],
    fin: [T; L],
    s: [T; L],
    cx: [T; L],
    cy: [T; L],
    cz: [T; L],
    cxy: [T; L],
    cxz: [T; L],
    cyz: [T; L],
}

impl<T: Lane, const L: usize> Acc<T, L> {
    fn new() -> Self {
        let z = [T::ZERO; L];
        Self { hmin: [T::INF; L], cnt: [0; L], fin: z, s: z, cx: z, cy: z, cz: z, cxy: z, cxz: z, cyz: z }
    }

    /// Folds one point into lane `j`. With `SUMS = false` only `min h`, the count and the
    /// finiteness check run (the first pass of the two-pass mode).
    #[inline(always)]
    fn add<const S: usize, const D: usize, const F: bool, const SUMS: bool, const FIXED: bool, const M: bool>(&mut self, j: usize, p: &[T], k: &Coeffs<T>, shift: T) {
        let (x, y, z) = coords::<T, S>(p);
        let (x, y) = if M { moved(k.mc, k.ms, k.tx, k.ty, x, y) } else { (x, y) };
        let (m, h) = mask_h::<T, S, D>(x, y, z, k);
        // `h` is NaN or inf whenever a coordinate it uses is (or is too large to square);
        // the planar height band also reads `z`.
        let probe = if S == 3 && D == 2 { h + z } else { h };
        self.fin[j] = self.fin[j] + probe * T::ZERO;
        let hm = sel(m, h, T::INF);
        self.hmin[j] = sel(hm < self.hmin[j], hm, self.hmin[j]);
        self.cnt[j] += m as u32;
        if SUMS {
            let (th, s2) = tanh_sech2::<T, F>(h, k.c2);
            // w = exp(−κ th − shift) = 2^(−κ log₂e th − shift log₂e), `shift` given in log₂
            // units. For kept points the exponent is ≤ 0 (up to rounding) and, with the fixed
            // shift, ≥ −2κ log₂e ≥ EXP2_LOW; points outside crop or band may fall outside that
            // range and give garbage, dropped by the mask.
            let arg = T::madd::<F>(-k.kappa2, th, -shift);
            let w = T::exp2_in_range::<F>(if FIXED { arg } else { sel(arg < T::EXP2_LOW, T::EXP2_LOW, arg) });
            let w = sel(m & (FIXED || arg >= T::EXP2_LOW), w, T::ZERO);
            let c = w * s2;
            let (cx, cy) = (c * x, c * y);
            self.s[j] = self.s[j] + w;
            self.cx[j] = self.cx[j] + cx;
            self.cy[j] = self.cy[j] + cy;
            self.cxy[j] = T::madd::<F>(cx, y, self.cxy[j]);
            if D == 3 {
                self.cz[j] = T::madd::<F>(c, z, self.cz[j]);
                self.cxz[j] = T::madd::<F>(cx, z, self.cxz[j]);
                self.cyz[j] = T::madd::<F>(cy, z, self.cyz[j]);
            }
        }
    }

    fn finish(&self) -> (T, usize, bool, Sums) {
        let mut best = T::INF;
        let mut finite = true;
        for j in 0..L {
            best = sel(self.hmin[j] < best, self.hmin[j], best);
            finite &= self.fin[j] == T::ZERO;
        }
        let red = |a: &[T; L]| a.iter().map(|v| v.to_f64()).sum::<f64>();
        let sums = Sums { s: red(&self.s), cx: red(&self.cx), cy: red(&self.cy), cz: red(&self.cz), cxy: red(&self.cxy), cxz: red(&self.cxz), cyz: red(&self.cyz) };
        (best, self.cnt.iter().map(|&c| c as usize).sum(), finite, sums)
    }
}

/// One pass over the scan in blocks of `L` points.
#[inline(always)]
fn pass<T: Lane, const S: usize, const D: usize, const L: usize, const F: bool, const SUMS: bool, const FIXED: bool, const M: bool>(pts: &[T], k: &Coeffs<T>, shift: T) -> (T, usize, bool, Sums) {
    let mut acc = Acc::<T, L>::new();
    let blocks = pts.chunks_exact(L * S);
    let tail = blocks.remainder();
    for block in blocks {
        for j in 0..L {
            acc.add::<S, D, F, SUMS, FIXED, M>(j, &block[j * S..j * S + S], k, shift);
        }
    }
    for p in tail.chunks_exact(S) {
        acc.add::<S, D, F, SUMS, FIXED, M>(0, p, k, shift);
    }
    acc.finish()
}

/// Both passes. The log-sum-exp is shifted so its largest term is at most 1: by the constant
/// `κ` (≥ every `−κ tanh(·)`) in one fused pass when `κ ≤ T::MAX_FIXED_SHIFT`, else by the
/// exact `−κ tanh(h_min/γ)` found in a first pass.
#[inline(always)]
fn both_passes<T: Lane, const S: usize, const D: usize, const L: usize, const F: bool, const M: bool>(pts: &[T], k: &Coeffs<T>) -> (T, usize, bool, Sums, T) {
    if k.kappa.to_f64() <= T::MAX_FIXED_SHIFT {
        let (hmin, n, finite, sums) = pass::<T, S, D, L, F, true, true, M>(pts, k, k.kappa2);
        return (hmin, n, finite, sums, k.kappa);
    }
    let (hmin, n, finite, _) = pass::<T, S, D, L, F, false, false, M>(pts, k, T::ZERO);
    if !finite || n == 0 {
        return (hmin, n, finite, Sums::default(), T::ZERO);
    }
    let (th_min, _) = tanh_sech2::<T, F>(hmin, k.c2);
    let (_, _, _, sums) = pass::<T, S, D, L, F, true, false, M>(pts, k, -(k.kappa2 * th_min));
    (hmin, n, finite, sums, -(k.kappa * th_min))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn both_passes_avx2<T: Lane, const S: usize, const D: usize, const L: usize, const M: bool>(pts: &[T], k: &Coeffs<T>) -> (T, usize, bool, Sums, T) {
    both_passes::<T, S, D, L, true, M>(pts, k)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
fn both_passes_avx512<T: Lane, const S: usize, const D: usize, const L: usize, const M: bool>(pts: &[T], k: &Coeffs<T>) -> (T, usize, bool, Sums, T) {
    both_passes::<T, S, D, L, true, M>(pts, k)
}

fn dispatch<T: Lane, const S: usize, const D: usize, const L: usize, const M: bool>(pts: &[T], k: &Coeffs<T>, level: SimdLevel) -> (T, usize, bool, Sums, T) {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: each arm runs only when the CPU reports the features its build enables.
        match level {
            SimdLevel::Avx512 if SimdLevel::Avx512.is_supported() => {
                return unsafe { both_passes_avx512::<T, S, D, L, M>(pts, k) };
            }
            SimdLevel::Avx2 | SimdLevel::Avx512 if SimdLevel::Avx2.is_supported() => {
                return unsafe { both_passes_avx2::<T, S, D, L, M>(pts, k) };
            }
            _ => {}
        }
    }
    let _ = level;
    both_passes::<T, S, D, L, false, M>(pts, k)
}

/// Evaluates the composite barrier over a body-frame scan stored row-major with `stride`
/// coordinates per point (2 or 3). A planar envelope uses `x, y` (and `z` only for the
/// height band); a 3D envelope needs `stride == 3`.
///
/// ```
/// use shieldnav_core::shield::{evaluate_composite, CompositeParams, Envelope, SimdLevel};
/// let params = CompositeParams {
///     envelope: Envelope::new(&[0.9, 0.45]).unwrap(), gamma: 0.9, kappa: 8.0,
///     crop_radius: Some(3.5), height_band: None, omega: [0.0; 3],
/// };
/// // one wall point 1 m to the left: h = 1/0.45² − 1 ≈ 3.94
/// let b = evaluate_composite(&[0.0f64, 1.0], 2, &params, SimdLevel::detect()).unwrap();
/// assert!((b.h_min - (1.0 / 0.2025 - 1.0)).abs() < 1e-12);
/// assert!(b.grad_body[1] < 0.0); // moving left lowers H
/// ```
pub fn evaluate_composite<T: Lane>(pts: &[T], stride: usize, p: &CompositeParams, level: SimdLevel) -> Result<CompositeBarrier> {
    evaluate_composite_moved(pts, stride, None, p, level)
}

/// The composite barrier written as the paper's equations, one point at a time in `f64`: the
/// readable reference that [`evaluate_composite`]'s fused kernel is tested against (not used in
/// the filter). `points` are body-frame points (`z` ignored by a planar envelope, except for
/// the height band); crop and height band as in the kernel.
///
/// - `h_i = p_iᵀ A p_i − 1` ([`Envelope::h_body`]), `∂h_i/∂p_r = −2 A p_i`, and
///   `∂h_i/∂t = 2 ω · (A p_i × p_i)` ([`Envelope::grad_body`], [`Envelope::dh_dt_body`]);
/// - `H = −(γ/κ) log Σ_i exp(−κ tanh(h_i/γ))`, capped by `γ tanh(h_min/γ)`;
/// - `∂H/∂p_r = Σ_i λ_i sech²(h_i/γ) ∂h_i/∂p_r` and `∂H/∂t = Σ_i λ_i sech²(h_i/γ) ∂h_i/∂t`,
///   with `λ_i = exp(−κ tanh(h_i/γ)) / Σ_j exp(−κ tanh(h_j/γ))`.
pub fn composite_reference(points: &[Vec3], p: &CompositeParams) -> CompositeBarrier {
    let planar = p.envelope.dim() == 2;
    let kept: Vec<Vec3> = points
        .iter()
        .filter(|q| p.crop_radius.is_none_or(|r| q[0] * q[0] + q[1] * q[1] + if planar { 0.0 } else { q[2] * q[2] } <= r * r))
        .filter(|q| !planar || p.height_band.is_none_or(|(lo, hi)| (lo..=hi).contains(&q[2])))
        .map(|q| if planar { [q[0], q[1], 0.0] } else { *q })
        .collect();
    if kept.is_empty() {
        return CompositeBarrier { value: p.gamma, h_min: f64::MAX, grad_body: [0.0; 3], dh_dt: 0.0, grad_omega: [0.0; 3], num_points: 0 };
    }
    let (g, k) = (p.gamma, p.kappa);
    let h: Vec<f64> = kept.iter().map(|q| p.envelope.h_body(q)).collect();
    let h_min = h.iter().copied().fold(f64::INFINITY, f64::min);
    // the exponents −κ tanh(h_i/γ), shifted by their largest so the sum is at least 1
    let shift = -k * (h_min / g).tanh();
    let e: Vec<f64> = h.iter().map(|&hi| (-k * (hi / g).tanh() - shift).exp()).collect();
    let sum: f64 = e.iter().sum();
    let soft = -(g / k) * (sum.ln() + shift);
    let (mut grad, mut grad_omega) = ([0.0; 3], [0.0; 3]);
    let a = p.envelope.inv_sq();
    for ((q, &hi), &ei) in kept.iter().zip(&h).zip(&e) {
        let weight = ei / sum / (hi / g).cosh().powi(2); // λ_i sech²(h_i/γ)
        let gi = p.envelope.grad_body(q);
        // ∂h_i/∂t = ω · 2 (A p × p): its coefficient of ω
        let ap = [a[0] * q[0], a[1] * q[1], a[2] * q[2]];
        let wi = [2.0 * (ap[1] * q[2] - ap[2] * q[1]), 2.0 * (ap[2] * q[0] - ap[0] * q[2]), 2.0 * (ap[0] * q[1] - ap[1] * q[0])];
        for d in 0..3 {
            grad[d] += weight * gi[d];
            grad_omega[d] += weight * wi[d];
        }
    }
    let dh_dt = (0..3).map(|d| grad_omega[d] * p.omega[d]).sum();
    CompositeBarrier { value: soft.min(g * (h_min / g).tanh()), h_min, grad_body: grad, dh_dt, grad_omega, num_points: kept.len() }
}

/// [`evaluate_composite`] on points that are first moved by `motion` (see [`Motion`]), in
/// the same pass: crop, height band and barrier see the moved points.
pub fn evaluate_composite_moved<T: Lane>(pts: &[T], stride: usize, motion: Option<Motion>, p: &CompositeParams, level: SimdLevel) -> Result<CompositeBarrier> {
    p.validate()?;
    composite_of_valid(pts, stride, motion, p, level)
}

/// [`evaluate_composite_moved`] with parameters known valid (the [`super::Shield`]'s, checked
/// when it was built): the points are still checked.
pub(crate) fn composite_of_valid<T: Lane>(pts: &[T], stride: usize, motion: Option<Motion>, p: &CompositeParams, level: SimdLevel) -> Result<CompositeBarrier> {
    let dim = p.envelope.dim();
    if stride != 2 && stride != 3 {
        return Err(Error::invalid("points", format!("points need 2 or 3 coordinates, got {stride}")));
    }
    if !pts.len().is_multiple_of(stride) {
        return Err(Error::invalid("points", format!("{} values do not make rows of {stride}", pts.len())));
    }
    if dim > stride {
        return Err(Error::DimensionMismatch { name: "points", expected: dim, got: stride });
    }
    let a = p.envelope.inv_sq();
    let (z_lo, z_hi) = p.height_band.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    let crop = p.crop_radius.unwrap_or(f64::INFINITY);
    if motion.is_some_and(|m| !m.is_finite()) {
        return Err(Error::invalid("motion", "contains NaN or inf"));
    }
    let m = motion.unwrap_or(Motion { cos: 1.0, sin: 0.0, tx: 0.0, ty: 0.0 });
    let k = Coeffs {
        ia: T::from_f64(a[0]),
        ib: T::from_f64(a[1]),
        ic: T::from_f64(a[2]),
        crop2: T::from_f64(crop * crop),
        z_lo: T::from_f64(z_lo),
        z_hi: T::from_f64(z_hi),
        c2: T::from_f64(2.0 * std::f64::consts::LOG2_E / p.gamma),
        kappa: T::from_f64(p.kappa),
        kappa2: T::from_f64(p.kappa * std::f64::consts::LOG2_E),
        mc: T::from_f64(m.cos),
        ms: T::from_f64(m.sin),
        tx: T::from_f64(m.tx),
        ty: T::from_f64(m.ty),
    };
    let (hmin, n, finite, sums, shift) = match (stride, dim, motion.is_some()) {
        (2, _, false) => dispatch::<T, 2, 2, 16, false>(pts, &k, level),
        (3, 2, false) => dispatch::<T, 3, 2, 16, false>(pts, &k, level),
        (_, _, false) => dispatch::<T, 3, 3, 16, false>(pts, &k, level),
        (2, _, true) => dispatch::<T, 2, 2, 16, true>(pts, &k, level),
        (3, 2, true) => dispatch::<T, 3, 2, 16, true>(pts, &k, level),
        (_, _, true) => dispatch::<T, 3, 3, 16, true>(pts, &k, level),
    };
    if !finite {
        return Err(Error::invalid("points", "contains NaN or inf (or a coordinate too large to square)"));
    }
    if n == 0 {
        return Ok(CompositeBarrier { value: p.gamma, h_min: f64::MAX, grad_body: [0.0; 3], dh_dt: 0.0, grad_omega: [0.0; 3], num_points: 0 });
    }
    let shift = shift.to_f64();
    let h_min = hmin.to_f64();
    let soft = -(p.gamma / p.kappa) * (shift + sums.s.ln());
    let value = soft.min(p.gamma * (h_min / p.gamma).tanh());
    let inv_s = 1.0 / sums.s;
    let grad_body = [-2.0 * a[0] * sums.cx * inv_s, -2.0 * a[1] * sums.cy * inv_s, -2.0 * a[2] * sums.cz * inv_s];
    let w = p.omega;
    let grad_omega = [2.0 * inv_s * (a[1] - a[2]) * sums.cyz, 2.0 * inv_s * (a[2] - a[0]) * sums.cxz, 2.0 * inv_s * (a[0] - a[1]) * sums.cxy];
    let dh_dt = w[0] * grad_omega[0] + w[1] * grad_omega[1] + w[2] * grad_omega[2];
    Ok(CompositeBarrier { value, h_min, grad_body, dh_dt, grad_omega, num_points: n })
}

/// Largest soft-min sharpness `κ`: beyond it the weights' products overflow (κ = 1e100 gave a
/// NaN command), and the soft-min equals the hard min to every digit long before.
pub const MAX_KAPPA: f64 = 1e6;
/// Least `κ`: the soft-min's offset `(γ/κ) ln N` grows as `1/κ` (κ = 1e-300 asked for
/// commands of 1e300 m/s).
pub const MIN_KAPPA: f64 = 1e-3;
/// Largest saturation `γ` (m² of `h`): beyond, `γ tanh(h/γ)` is `h` to every digit.
pub const MAX_GAMMA: f64 = 1e6;
/// Least saturation `γ`: below about 1.6e-308 the kernel's `2 log₂e / γ` is infinite (a point
/// on the ellipse gave a NaN command); long before, `tanh(h/γ)` is the sign of `h`.
pub const MIN_GAMMA: f64 = 1e-6;

/// `γ` and `κ` within their bounds ([`MIN_GAMMA`] to [`MAX_GAMMA`], [`MIN_KAPPA`] to
/// [`MAX_KAPPA`]): the one check of [`super::Shield::new`] and [`CompositeParams::validate`].
pub(crate) fn check_gamma_kappa(gamma: f64, kappa: f64) -> Result<()> {
    if !(MIN_GAMMA..=MAX_GAMMA).contains(&gamma) {
        return Err(Error::invalid("gamma", format!("must be from {MIN_GAMMA:e} to {MAX_GAMMA:e} (below, tanh(h/γ) is the sign of h; above, γ tanh(h/γ) is h itself), got {gamma:e}")));
    }
    if !(MIN_KAPPA..=MAX_KAPPA).contains(&kappa) {
        return Err(Error::invalid("kappa", format!("must be from {MIN_KAPPA:e} to {MAX_KAPPA:e} (beyond, the soft-min is the hard min to every digit), got {kappa:e}")));
    }
    Ok(())
}
