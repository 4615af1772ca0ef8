//! The LIDAR's kernel written with vector instructions by hand for every wall: a planar wall's
//! sweep over aligned blocks of four beams (the rest of its AVX2 and AVX-512 builds is the
//! portable code, vectorised by the compiler; see [`crate::simd::SimdLevel`]). The walk's
//! AVX-512 batch of short sweeps, which reads the walk's own records, is in `lidar_mesh`.

use crate::math::Real;

/// The sweep of a planar wall from `a` along `e` (`ae = a × e`, sensor frame) over the beams
/// `i0..i0 + count` (no wrap: `i0 + count <= best.len()`, a multiple of four, as are the
/// lengths of the beam tables `cos`, `sin`), each keeping its nearest range in `best`: the
/// same test and quotient as `Lidar::sweep_flat`'s, four beams at once, over the aligned
/// blocks of four that hold them (the beams outside are stored unchanged). Returns whether
/// one of the beams is parallel to the wall (left unchanged, for the caller to test), and
/// whether one of them has no range (`inf`) after the sweep.
///
/// Aligned blocks, so that a block one wall stores the next loads whole (a load spanning two
/// stores waits for both to retire); a minimum, not a select, so that the store is not made a
/// masked one (slow on some CPUs, and never forwarded to a load).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) fn flat_blocks_avx2(a: [Real; 2], e: [Real; 2], ae: Real, cos: &[Real], sin: &[Real], best: &mut [Real], i0: usize, count: usize) -> (bool, bool) {
    use std::arch::x86_64::*;
    let (lo, hi) = (i0 & !3, (i0 + count).next_multiple_of(4));
    let blocks = cos[lo..hi].as_chunks::<4>().0.iter().zip(sin[lo..hi].as_chunks::<4>().0).zip(best[lo..hi].as_chunks_mut::<4>().0);
    let (a0, a1, e0, e1, aev) = (_mm256_set1_pd(a[0]), _mm256_set1_pd(a[1]), _mm256_set1_pd(e[0]), _mm256_set1_pd(e[1]), _mm256_set1_pd(ae));
    let zero = _mm256_setzero_pd();
    let inf = _mm256_set1_pd(Real::INFINITY);
    // `ae >= 0` and `ae <= 0` as lane masks
    let (ae_pos, ae_neg) = (_mm256_cmp_pd::<_CMP_GE_OQ>(aev, zero), _mm256_cmp_pd::<_CMP_LE_OQ>(aev, zero));
    // the beams swept are the lanes `first..end` of the blocks, counted from `lo`
    let (first, end) = (_mm256_set1_pd((i0 - lo) as Real), _mm256_set1_pd((i0 + count - lo) as Real));
    let (mut lane, four) = (_mm256_set_pd(3.0, 2.0, 1.0, 0.0), _mm256_set1_pd(4.0));
    let (mut parallel, mut missed) = (zero, zero);
    for ((dc, ds), cur) in blocks {
        // SAFETY: each block holds four values.
        let (dc, ds, old) = unsafe { (_mm256_loadu_pd(dc.as_ptr()), _mm256_loadu_pd(ds.as_ptr()), _mm256_loadu_pd(cur.as_ptr())) };
        let on = _mm256_and_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(lane, first), _mm256_cmp_pd::<_CMP_LT_OQ>(lane, end));
        let den = _mm256_sub_pd(_mm256_mul_pd(dc, e1), _mm256_mul_pd(ds, e0));
        let sn = _mm256_sub_pd(_mm256_mul_pd(a0, ds), _mm256_mul_pd(a1, dc));
        let ahead = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(den, zero), ae_pos), _mm256_and_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(sn, zero), _mm256_cmp_pd::<_CMP_LE_OQ>(sn, den)));
        let behind = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(den, zero), ae_neg), _mm256_and_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(sn, zero), _mm256_cmp_pd::<_CMP_GE_OQ>(sn, den)));
        let t = _mm256_div_pd(aev, den);
        let take = _mm256_and_pd(_mm256_and_pd(_mm256_or_pd(ahead, behind), on), _mm256_cmp_pd::<_CMP_LT_OQ>(t, old));
        let new = _mm256_min_pd(old, _mm256_blendv_pd(inf, t, take));
        parallel = _mm256_or_pd(parallel, _mm256_and_pd(on, _mm256_cmp_pd::<_CMP_EQ_OQ>(den, zero)));
        missed = _mm256_or_pd(missed, _mm256_and_pd(on, _mm256_cmp_pd::<_CMP_EQ_OQ>(new, inf)));
        // SAFETY: the block holds four values.
        unsafe { _mm256_storeu_pd(cur.as_mut_ptr(), new) };
        lane = _mm256_add_pd(lane, four);
    }
    (_mm256_movemask_pd(parallel) != 0, _mm256_movemask_pd(missed) != 0)
}
