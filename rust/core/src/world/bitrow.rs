//! Rows of bits: one grid row packed 64 cells to a word (cell `i` is bit `i % 64` of word
//! `i / 64`), with the shifts and erosions the footprint search runs on whole words.
//!
//! Bits past the row's last cell are always 0, and cells off either end of a row read as 0
//! (blocked), so an erosion never reaches outside the grid.

use super::cell::Cell;

/// Number of words holding `cells` bits.
#[inline]
pub(crate) fn words_for(cells: usize) -> usize {
    cells.div_ceil(64)
}

/// Eight cells as the bytes of a word, cell 0 in the lowest byte.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub(crate) fn cell_bytes(c: &[Cell]) -> u64 {
    u64::from_le_bytes(std::array::from_fn(|i| c[i] as u8))
}

/// Bit `i` set iff cell `i` of the 64 cells `c` equals `v`.
#[inline(always)]
fn equal_bits(c: &[Cell], v: u8) -> u64 {
    debug_assert_eq!(c.len(), 64);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128i, _mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8};
        // SAFETY: SSE2 is part of the x86_64 baseline; `c` holds 64 bytes (`Cell` is a u8),
        // read as four unaligned 16-byte loads.
        unsafe {
            let p = c.as_ptr().cast::<__m128i>();
            let t = _mm_set1_epi8(v as i8);
            let m = |k: usize| _mm_movemask_epi8(_mm_cmpeq_epi8(_mm_loadu_si128(p.add(k)), t)) as u16 as u64;
            m(0) | m(1) << 16 | m(2) << 32 | m(3) << 48
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        const LOW: u64 = 0x0101_0101_0101_0101;
        const HIGH: u64 = 0x8080_8080_8080_8080;
        c.chunks_exact(8).enumerate().fold(0, |m, (b, c)| {
            // the high bit of each byte equal to `v`, gathered into 8 bits
            let y = cell_bytes(c) ^ (v as u64 * LOW);
            let hit = !(((y & !HIGH) + !HIGH) | y) & HIGH;
            m | ((hit >> 7).wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * b)
        })
    }
}

/// Packs the cells of `row` whose value is selected into `out`: cell `c` gives 1 iff
/// `select[c as usize]`.
pub(crate) fn pack_cells(row: &[Cell], select: [bool; 3], out: &mut [u64]) {
    for (k, w) in out.iter_mut().enumerate() {
        let chunk = &row[k * 64..row.len().min((k + 1) * 64)];
        *w = if chunk.len() == 64 {
            (0..3u8).filter(|&v| select[v as usize]).fold(0, |m, v| m | equal_bits(chunk, v))
        } else {
            chunk.iter().enumerate().fold(0, |m, (b, c)| m | (select[*c as usize] as u64) << b)
        };
    }
}

/// Packs the free cells of `row` into `out` (1 = [`Cell::Free`]).
pub(crate) fn pack_free(row: &[Cell], out: &mut [u64]) {
    pack_cells(row, [true, false, false], out);
}

/// Word `k` of `src` shifted by `d` cells: bit `i` of the result is cell `i + d` of `src`
/// (0 off either end).
#[inline(always)]
pub(crate) fn shifted_word(src: &[u64], k: usize, d: i32) -> u64 {
    let (q, r) = (d.div_euclid(64) as isize, d.rem_euclid(64) as u32);
    let at = |m: isize| if m >= 0 && (m as usize) < src.len() { src[m as usize] } else { 0 };
    let base = k as isize + q;
    if r == 0 {
        at(base)
    } else {
        (at(base) >> r) | (at(base + 1) << (64 - r))
    }
}

/// `dst[k] &= (src shifted by d)[k]` for the words `k` in `range` (see [`shifted_word`]).
#[inline]
pub(crate) fn and_shifted(dst: &mut [u64], src: &[u64], d: i32, range: std::ops::Range<usize>) {
    for k in range {
        dst[k] &= shifted_word(src, k, d);
    }
}

/// Horizontal erosion: cell `i` of `out` is set iff cells `i − w ..= i + w` of `src` all are.
/// `tmp` is scratch of the same length.
pub(crate) fn erode(src: &[u64], w: usize, out: &mut [u64], tmp: &mut [u64]) {
    debug_assert!(out.len() == src.len() && tmp.len() == src.len());
    let span = 2 * w + 1;
    // out(i) = cells i .. i + p all set, doubling p up to the largest power of two <= span
    out.copy_from_slice(src);
    let mut p = 1;
    while 2 * p <= span {
        tmp.copy_from_slice(out);
        and_shifted(out, tmp, p as i32, 0..src.len());
        p *= 2;
    }
    // span = p + (span - p): cells i .. i + span all set, then centre the window on i
    if span > p {
        tmp.copy_from_slice(out);
        and_shifted(out, tmp, (span - p) as i32, 0..src.len());
    }
    tmp.copy_from_slice(out);
    for (k, o) in out.iter_mut().enumerate() {
        *o = shifted_word(tmp, k, -(w as i32));
    }
}

/// Appends the runs of set bits of `row`.
pub(crate) fn extract_runs(row: &[u64], out: &mut Vec<(i32, i32)>) {
    let mut fill = out.len();
    for k in 0..row.len() {
        let x = row[k];
        if x == 0 {
            continue;
        }
        let below = if k > 0 { row[k - 1] >> 63 } else { 0 };
        let above = if k + 1 < row.len() { row[k + 1] & 1 } else { 0 };
        let mut starts = x & !((x << 1) | below);
        let mut ends = x & !((x >> 1) | (above << 63));
        while starts != 0 {
            out.push(((k * 64) as i32 + starts.trailing_zeros() as i32, -1));
            starts &= starts - 1;
        }
        while ends != 0 {
            out[fill].1 = (k * 64) as i32 + ends.trailing_zeros() as i32;
            fill += 1;
            ends &= ends - 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bit(row: &[u64], i: i64) -> bool {
        i >= 0 && (i as usize) < row.len() * 64 && row[i as usize / 64] >> (i % 64) & 1 == 1
    }

    fn pattern(n: usize, seed: u64) -> Vec<Cell> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                match (s >> 33) % 9 {
                    0 => Cell::Occupied,
                    1 => Cell::Unknown,
                    _ => Cell::Free,
                }
            })
            .collect()
    }

    #[test]
    fn shifts_and_erosion_match_brute_force() {
        for (n, seed) in [(1, 1), (63, 2), (64, 3), (65, 4), (200, 5), (517, 6)] {
            let cells = pattern(n, seed);
            let mut row = vec![0; words_for(n)];
            pack_free(&cells, &mut row);
            let free = |i: i64| i >= 0 && (i as usize) < n && cells[i as usize] == Cell::Free;
            for i in 0..row.len() as i64 * 64 {
                assert_eq!(bit(&row, i), free(i), "pack {n} {i}");
            }
            for select in [[false, true, false], [false, true, true], [true, true, true], [false, false, true]] {
                let mut sel = vec![0; row.len()];
                pack_cells(&cells, select, &mut sel);
                for i in 0..row.len() as i64 * 64 {
                    assert_eq!(bit(&sel, i), i < n as i64 && select[cells[i as usize] as usize], "pack {select:?} {n} {i}");
                }
            }
            let mut runs = Vec::new();
            extract_runs(&row, &mut runs);
            let mut want = Vec::new();
            for i in 0..n as i64 {
                if free(i) && !free(i - 1) {
                    want.push((i as i32, -1));
                }
                if free(i) && !free(i + 1) {
                    want.last_mut().unwrap().1 = i as i32;
                }
            }
            assert_eq!(runs, want, "runs {n}");
            for d in [-130, -64, -63, -17, -1, 0, 1, 5, 63, 64, 100] {
                let s: Vec<u64> = (0..row.len()).map(|k| shifted_word(&row, k, d)).collect();
                for i in 0..row.len() as i64 * 64 {
                    assert_eq!(bit(&s, i), free(i + d as i64), "shift {n} {d} {i}");
                }
            }
            for w in [0, 1, 2, 3, 7, 12, 31, 40] {
                let (mut out, mut tmp) = (vec![0; row.len()], vec![0; row.len()]);
                erode(&row, w, &mut out, &mut tmp);
                for i in 0..row.len() as i64 * 64 {
                    let want = (i - w as i64..=i + w as i64).all(free);
                    assert_eq!(bit(&out, i), want, "erode {n} {w} {i}");
                }
            }
        }
    }
}
