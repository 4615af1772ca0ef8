//! The walk's AVX-512 kernels: small sweeps many beams at once, and the reciprocal angle.

use super::super::numeric::{atan2_by, parallel_beam};
use super::tables::*;
use crate::math::Real;

/// The sweeps of at most [`SMALL`] beams of a whole wall (`edge` [`NONE`]) in `sweeps`, eight
/// beams at once (the same test and quotient as [`Lidar::sweep_flat`]; the walls loaded whole
/// and transposed, the beams' directions and ranges gathered by index, the ranges scattered
/// back: the sweeps' beams are distinct), the others listed in `big` (their indices); returns
/// whether one of the beams has no range after them. On the atrium of `ut_gdc_floor2` at 20 m, where 201 of a
/// scan's 303 sweeps are of one or two beams, a scan took 4 % less than with each swept alone.
///
/// `mask` is the columns less one (a power of two less one), `cos`, `sin` and `best` hold a
/// beam each, and `sweeps` has fewer than 2^24 records (its indices times six fit an `i32`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq")]
pub(super) fn small_sweeps_avx512(sweeps: &[Sweep], jobs: &mut Vec<[u32; 2]>, big: &mut Vec<u32>, mask: i64, cos: &[Real], sin: &[Real], best: &mut [Real]) -> bool {
    use std::arch::x86_64::*;
    // the jobs (a beam and its sweep's record, six `f64`s a record), written without branches:
    // every sweep writes SMALL jobs, kept by its count if it is small, and its index in `big`,
    // kept if not (the eight jobs after the last are of sweep 0 and beam 0: read, masked off)
    let need = SMALL * sweeps.len() + 8;
    if jobs.len() < need {
        jobs.resize(need, [0, 0]);
    }
    big.clear();
    big.resize(sweeps.len(), 0);
    let (mut k, mut nb) = (0, 0);
    for (i, sw) in sweeps.iter().enumerate() {
        let count = sw.j1 - sw.j0;
        let small = (count <= SMALL as i32) & (sw.edge == NONE);
        let id = 6 * i as u32;
        // SAFETY: `k + SMALL <= SMALL * (i + 1) < need`, `nb <= i`
        unsafe {
            for o in 0..SMALL {
                *jobs.get_unchecked_mut(k + o) = [id, ((sw.j0 + o as i32) as i64 & mask) as u32];
            }
            *big.get_unchecked_mut(nb) = i as u32;
        }
        k += if small { count as usize } else { 0 };
        nb += !small as usize;
    }
    big.truncate(nb);
    // SAFETY: `k + 8 <= need`
    unsafe { std::ptr::write_bytes(jobs.as_mut_ptr().add(k), 0, 8) };
    let base = sweeps.as_ptr() as *const Real;
    let zero = _mm512_setzero_pd();
    let inf = _mm512_set1_pd(Real::INFINITY);
    let (mut parallel, mut missed) = (0u8, 0u8);
    for at in (0..k).step_by(8) {
        let on: __mmask8 = if k - at >= 8 { 0xff } else { (1u8 << (k - at)) - 1 };
        // SAFETY: `at + 8 <= k + 8 <= need` jobs, each of a sweep (index times six: 48-byte
        // records, `Sweep` is `repr(C)`) and a beam (masked to a column), the jobs after the
        // last of sweep 0 and beam 0; the lanes off are not written
        unsafe {
            let job = jobs.as_ptr().add(at);
            let beam = _mm512_cvtepi64_epi32(_mm512_srli_epi64::<32>(_mm512_loadu_si512(job as *const __m512i)));
            // the eight sweeps' walls (a0 a1 b0 b1 each) loaded whole and turned into four
            // vectors of eight (fewer instructions than four gathers)
            let wall = |o: usize| _mm256_loadu_pd(base.add((*job.add(o))[0] as usize));
            let two = |o: usize| _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(wall(o)), wall(o + 1));
            let (z0, z1, z2, z3) = (two(0), two(2), two(4), two(6));
            // (x0: a0 of walls 0 2, b0 of 0 2, a0 of 1 3, b0 of 1 3; x1 the same of walls 4 to
            // 7; y0, y1 the same of a1 and b1)
            let (x0, x1) = (_mm512_unpacklo_pd(z0, z1), _mm512_unpacklo_pd(z2, z3));
            let (y0, y1) = (_mm512_unpackhi_pd(z0, z1), _mm512_unpackhi_pd(z2, z3));
            let (first, second) = (_mm512_set_epi64(13, 9, 12, 8, 5, 1, 4, 0), _mm512_set_epi64(15, 11, 14, 10, 7, 3, 6, 2));
            let (a0, b0) = (_mm512_permutex2var_pd(x0, first, x1), _mm512_permutex2var_pd(x0, second, x1));
            let (a1, b1) = (_mm512_permutex2var_pd(y0, first, y1), _mm512_permutex2var_pd(y0, second, y1));
            let dc = _mm512_mask_i32gather_pd::<8>(zero, on, beam, cos.as_ptr());
            let ds = _mm512_mask_i32gather_pd::<8>(zero, on, beam, sin.as_ptr());
            let old = _mm512_mask_i32gather_pd::<8>(inf, on, beam, best.as_ptr());
            let (e0, e1) = (_mm512_sub_pd(b0, a0), _mm512_sub_pd(b1, a1));
            let ae = _mm512_sub_pd(_mm512_mul_pd(a0, e1), _mm512_mul_pd(a1, e0));
            let den = _mm512_sub_pd(_mm512_mul_pd(dc, e1), _mm512_mul_pd(ds, e0));
            let sn = _mm512_sub_pd(_mm512_mul_pd(a0, ds), _mm512_mul_pd(a1, dc));
            let ahead =
                _mm512_cmp_pd_mask::<_CMP_GT_OQ>(den, zero) & _mm512_cmp_pd_mask::<_CMP_GE_OQ>(ae, zero) & _mm512_cmp_pd_mask::<_CMP_GE_OQ>(sn, zero) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(sn, den);
            let behind =
                _mm512_cmp_pd_mask::<_CMP_LT_OQ>(den, zero) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(ae, zero) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(sn, zero) & _mm512_cmp_pd_mask::<_CMP_GE_OQ>(sn, den);
            let t = _mm512_div_pd(ae, den);
            let take = (ahead | behind) & on & _mm512_cmp_pd_mask::<_CMP_LT_OQ>(t, old);
            let new = _mm512_mask_mov_pd(old, take, t);
            _mm512_mask_i32scatter_pd::<8>(best.as_mut_ptr(), on, beam, new);
            parallel |= on & _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(den, zero);
            missed |= on & _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(new, inf);
        }
    }
    if parallel != 0 {
        // a beam parallel to its wall (rare): the general test
        missed = 0;
        for &[id, i] in &jobs[..k] {
            let (sw, i) = (&sweeps[id as usize / 6], i as usize);
            best[i] = parallel_beam(sw.a, sw.b, cos[i], sin[i], best[i]);
            missed |= (best[i] == Real::INFINITY) as u8;
        }
    }
    missed != 0
}

/// The most beams of a sweep that [`small_sweeps_avx512`] takes (2, 4, 6, 8, 12 tried on the
/// atrium of `ut_gdc_floor2`: 4 the fastest).
pub(super) const SMALL: usize = 4;
// (`small_sweeps_avx512` reads a sweep's walls as the first four `f64`s of 48-byte records)
const _: () = assert!(std::mem::size_of::<Sweep>() == 48 && std::mem::offset_of!(Sweep, a) == 0 && std::mem::offset_of!(Sweep, b) == 16);

/// [`fast_atan2`] with its one division replaced by AVX-512's reciprocal to 2^-14 (a fifth of
/// the division's latency on the walk's path from a corner to its column): within 7.3e-5 rad
/// (its bound, tested, and `fast_atan2`'s), a fortieth of a beam step at 2 048 columns, so
/// that [`Walker::column`]'s tests of the beams beside it still find the column.
///
/// Only where the CPU runs AVX-512 (the walk's AVX-512 build, [`Walker::rcp14`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn atan2_rcp14(y: Real, x: Real) -> Real {
    use std::arch::x86_64::{_mm_cvtsd_f64, _mm_rcp14_sd, _mm_set_sd, _mm_setzero_pd};
    // SAFETY: called only where the CPU runs AVX-512 (see above)
    atan2_by(y, x, |n, d| n * unsafe { _mm_cvtsd_f64(_mm_rcp14_sd(_mm_setzero_pd(), _mm_set_sd(d))) })
}
