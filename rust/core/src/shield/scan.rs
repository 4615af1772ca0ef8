//! Scan pre-processing the paper uses before the filter: crop to a radius, a height band for
//! planar robots (drops floor and ceiling returns) and optional down-sampling.
//!
//! Down-sampling keeps, in each cell, the point with the *smallest* `h` (the one deepest
//! toward the ellipsoid), so the kept set is never less conservative than the cell's worst
//! point. Why it matters: the soft-min grows conservative like `ln(N)/κ`. With every point far
//! away each `tanh(h_i/γ) → 1` and `H → γ − (γ/κ) ln N`, which is negative once
//! `N > e^κ` (≈ 2,981 points for κ = 8): a dense cloud alone makes the shield refuse to move.
//! Crop and down-sample well below that.

use std::collections::HashMap;

use super::ellipsoid::Envelope;
use super::lane::Lane;
use crate::error::{Error, Result};

/// How the scan is thinned before the filter. The default crops at 3.5 m, as the paper does,
/// and keeps a planar shield's `(N, 3)` points from 0.4 m below to 1.5 m above the body origin
/// (a band of ours: the paper's shield is 3D).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanFilter {
    /// Drop points farther than this (m) from the robot in the shield's space; `None` keeps all.
    pub crop_radius: Option<f64>,
    /// For a planar shield fed `(N, 3)` points: keep body-frame `z_lo ≤ z ≤ z_hi` (m).
    pub height_band: Option<(f64, f64)>,
    /// Keep one point per cubic (square, when planar) voxel of this edge (m).
    pub voxel_size: Option<f64>,
    /// Keep one point per azimuth bin (and, in 3D, per elevation bin of the same width); at
    /// most [`MAX_ANGULAR_BINS`].
    pub angular_bins: Option<usize>,
}

/// Most azimuth bins of [`ScanFilter::angular_bins`] (four times the columns of the densest
/// Ouster scan; more would keep every point of any scan).
pub const MAX_ANGULAR_BINS: usize = 8192;

/// Most bins held in one array (16 bytes each); a 3D scan with more is binned in a hash map.
const DENSE_BINS: usize = 1 << 18;

impl Default for ScanFilter {
    fn default() -> Self {
        Self { crop_radius: Some(3.5), height_band: Some((-0.4, 1.5)), voxel_size: None, angular_bins: None }
    }
}

impl ScanFilter {
    /// Checks every field; the error names the field.
    pub fn validate(&self) -> Result<()> {
        if let Some(r) = self.crop_radius {
            if !(r.is_finite() && r > 0.0) {
                return Err(Error::invalid("crop_radius", format!("must be finite and > 0 (or None), got {r}")));
            }
        }
        if let Some((lo, hi)) = self.height_band {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(Error::invalid("height_band", format!("must be finite with low < high, got ({lo}, {hi})")));
            }
        }
        if let Some(v) = self.voxel_size {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid("voxel_size", format!("must be finite and > 0 (or None), got {v}")));
            }
        }
        if let Some(b) = self.angular_bins {
            if !(4..=MAX_ANGULAR_BINS).contains(&b) {
                return Err(Error::invalid("angular_bins", format!("must be from 4 to {MAX_ANGULAR_BINS} (or None), got {b}")));
            }
        }
        Ok(())
    }

    /// Whether points must be copied (down-sampling) rather than masked in the kernel.
    pub fn downsamples(&self) -> bool {
        self.voxel_size.is_some() || self.angular_bins.is_some()
    }
}

/// Reusable buffers for [`select_points`].
#[derive(Debug, Default, Clone)]
pub struct ScanScratch {
    cells: HashMap<(i64, i64, i64), (f64, usize)>,
    bins: Vec<(f64, usize)>,
    kept: Vec<usize>,
}

/// Copies into `out` (row-major, `dim` coordinates per point) the points of `pts` (`stride`
/// per point) that pass crop and height band, down-sampled as `filter` asks. `pts` must be
/// finite (callers check).
pub fn select_points<T: Lane>(pts: &[T], stride: usize, envelope: &Envelope, filter: &ScanFilter, scratch: &mut ScanScratch, out: &mut Vec<T>) {
    let dim = envelope.dim();
    let crop2 = filter.crop_radius.map_or(f64::INFINITY, |r| r * r);
    let band = if stride == 3 && dim == 2 { filter.height_band } else { None };
    scratch.kept.clear();
    scratch.cells.clear();
    let point = |i: usize| -> [f64; 3] {
        let b = i * stride;
        [pts[b].to_f64(), pts[b + 1].to_f64(), if stride == 3 { pts[b + 2].to_f64() } else { 0.0 }]
    };
    let n = pts.len() / stride;
    let keep = |p: &[f64; 3]| -> bool {
        let r2 = p[0] * p[0] + p[1] * p[1] + if dim == 3 { p[2] * p[2] } else { 0.0 };
        r2 <= crop2 && band.is_none_or(|(lo, hi)| p[2] >= lo && p[2] <= hi)
    };
    let h_of = |p: &[f64; 3]| envelope.h_body(&[p[0], p[1], if dim == 3 { p[2] } else { 0.0 }]);
    if let Some(bins) = filter.angular_bins {
        let el_bins = if dim == 3 { (bins / 2).max(1) } else { 1 };
        let dense = bins * el_bins <= DENSE_BINS;
        scratch.bins.clear();
        if dense {
            scratch.bins.resize(bins * el_bins, (f64::INFINITY, usize::MAX));
        }
        let tau = std::f64::consts::TAU;
        for i in 0..n {
            let p = point(i);
            if !keep(&p) {
                continue;
            }
            let az = (p[1].atan2(p[0]) + std::f64::consts::PI) / tau;
            let a = ((az * bins as f64) as usize).min(bins - 1);
            let e = if dim == 3 {
                let el = p[2].atan2(p[0].hypot(p[1])) / std::f64::consts::PI + 0.5;
                ((el * el_bins as f64) as usize).min(el_bins - 1)
            } else {
                0
            };
            let h = h_of(&p);
            let slot = if dense { &mut scratch.bins[e * bins + a] } else { scratch.cells.entry((a as i64, e as i64, 0)).or_insert((f64::INFINITY, usize::MAX)) };
            // (the first point of a cell is kept whatever its h: an h that overflows to
            // infinity, of a point 1e155 m away, must not leave the cell empty)
            if h < slot.0 || slot.1 == usize::MAX {
                *slot = (h, i);
            }
        }
        if dense {
            scratch.kept.extend(scratch.bins.iter().filter(|s| s.1 != usize::MAX).map(|s| s.1));
        } else {
            // (in the dense array's order: by bin)
            let mut held: Vec<_> = scratch.cells.iter().map(|(&(a, e, _), s)| (e * bins as i64 + a, s.1)).collect();
            held.sort_unstable();
            scratch.kept.extend(held.into_iter().map(|(_, i)| i));
        }
    } else if let Some(v) = filter.voxel_size {
        for i in 0..n {
            let p = point(i);
            if !keep(&p) {
                continue;
            }
            let key = ((p[0] / v).floor() as i64, (p[1] / v).floor() as i64, if dim == 3 { (p[2] / v).floor() as i64 } else { 0 });
            let h = h_of(&p);
            let slot = scratch.cells.entry(key).or_insert((f64::INFINITY, usize::MAX));
            // (the first point of a cell is kept whatever its h: an h that overflows to
            // infinity, of a point 1e155 m away, must not leave the cell empty)
            if h < slot.0 || slot.1 == usize::MAX {
                *slot = (h, i);
            }
        }
        scratch.kept.extend(scratch.cells.values().map(|s| s.1));
        scratch.kept.sort_unstable();
    } else {
        scratch.kept.extend((0..n).filter(|&i| keep(&point(i))));
    }
    out.clear();
    out.reserve(scratch.kept.len() * dim);
    for &i in &scratch.kept {
        out.extend_from_slice(&pts[i * stride..i * stride + dim]);
    }
}
