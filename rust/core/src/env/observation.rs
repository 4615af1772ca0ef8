//! The flat observation vector an MLP policy reads.
//!
//! Layout (`f32`, length `bins + 9`):
//!
//! | slice | content | range |
//! |---|---|---|
//! | `[0, bins)` | nearest horizontal return per azimuth bin over `max_range`; bin `b` is centred on body bearing `b · 2π / bins` (0 = ahead, counter-clockwise); 1 without a return | `[0, 1]` |
//! | `bins + 0..3` | odometry estimate change over the last step, in the previous estimate's body frame: `Δx, Δy` (m), `Δψ` (rad) | unbounded (an odometry jump shows here) |
//! | `bins + 3..6` | body velocity `(v_x, v_y, ω)` over `(v_max,x, v_max,y, ω_max)` | `[-1, 1]` |
//! | `bins + 6..9` | last command sent to the tracker (after the shield), same scaling | unbounded in principle (a shield box wider than the tracker's limits) |

use crate::error::{Error, Result};
use crate::math::Real;
use crate::sensors::Scan;

/// Observation parameters. `Default`: 64 bins.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservationConfig {
    /// Azimuth bins of the range summary, between 4 and the LIDAR's column count.
    pub bins: usize,
}

impl Default for ObservationConfig {
    fn default() -> Self {
        Self { bins: 64 }
    }
}

/// Entries after the range bins.
pub const PROPRIO_LEN: usize = 9;

impl ObservationConfig {
    /// Checks `bins` against the LIDAR's `columns`.
    pub fn validate(&self, columns: usize) -> Result<()> {
        if !(4..=columns).contains(&self.bins) {
            return Err(Error::invalid("lidar_bins", format!("must be in [4, {columns}] (the LIDAR's columns), got {}", self.bins)));
        }
        Ok(())
    }

    /// Length of the flat observation.
    pub fn len(&self) -> usize {
        self.bins + PROPRIO_LEN
    }

    /// Never empty.
    pub fn is_empty(&self) -> bool {
        false
    }
}

/// Bound of the odometry change's `Δx, Δy` in [`observation_bounds`] (m): unbounded in
/// principle, finite for the observation space.
pub const POSE_BOUND: f32 = 1.0e9;

/// The flat observation's bounds `(low, high)`, each of length `bins + 9`, as the layout above
/// gives them. The command's bound is what the tracker's scaling can show: the longest of the
/// shield's box (`shield_box`, the tracker's `v_max` without one), the tracker's `v_max` and the
/// controller's `controller_u_max` (world and waypoint actions arrive turned into the body
/// frame, so by length), over each `v_max` component; the yaw rate's, the larger of the
/// tracker's and the controller's over `w_max`, at least 1.
pub fn observation_bounds(bins: usize, v_max: [Real; 2], w_max: Real, shield_box: Option<[Real; 2]>, controller_u_max: [Real; 2], omega_max: Real) -> (Vec<f32>, Vec<f32>) {
    let boxed = shield_box.unwrap_or(v_max);
    let reach = boxed[0].hypot(boxed[1]).max(v_max[0].hypot(v_max[1])).max(controller_u_max[0].hypot(controller_u_max[1]));
    let cmd = [reach / v_max[0], reach / v_max[1], (omega_max / w_max).max(1.0)].map(|v| v as f32);
    let pi = std::f32::consts::PI;
    let mut high = vec![1.0f32; bins];
    high.extend_from_slice(&[POSE_BOUND, POSE_BOUND, pi, 1.0, 1.0, 1.0, cmd[0], cmd[1], cmd[2]]);
    let mut low = vec![0.0f32; bins];
    low.extend(high[bins..].iter().map(|v| -v));
    (low, high)
}

/// Writes the range bins of `scan` into `out` (length `bins`). `cos_el` holds the cosine of
/// each channel's elevation.
pub fn bin_ranges(scan: &Scan, cos_el: &[Real], max_range: Real, out: &mut [f32]) {
    let bins = out.len();
    out.iter_mut().for_each(|v| *v = 1.0);
    let cols = scan.columns;
    // column i goes to bin ((i · bins + cols / 2) / cols) mod bins: bin b holds the columns
    // from start(b) to start(b + 1), and bin 0 also those from start(bins) on
    let start = |b: usize| (b * cols).saturating_sub(cols / 2).div_ceil(bins);
    // the least range of a bin gives its value: r ↦ (r cos / max) rounds monotonically
    let least = |s: &[Real]| s.iter().fold(Real::INFINITY, |m, &r| if r < m { r } else { m });
    for (k, c) in cos_el.iter().enumerate() {
        let row = &scan.ranges[k * cols..(k + 1) * cols];
        for (b, o) in out.iter_mut().enumerate() {
            let mut r = least(&row[start(b)..start(b + 1)]);
            if b == 0 {
                r = r.min(least(&row[start(bins)..]));
            }
            let v = (r * c / max_range) as f32;
            if v < *o {
                *o = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_follow_the_layout() {
        // the tracker's 1.6 × 0.8 m/s and 1.5 rad/s, a 2 × 2 shield box, the controller's 1 × 1
        let (low, high) = observation_bounds(4, [1.6, 0.8], 1.5, Some([2.0, 2.0]), [1.0, 1.0], 1.0);
        assert_eq!(low.len(), 4 + PROPRIO_LEN);
        assert_eq!(&high[..4], &[1.0; 4]);
        assert_eq!(&low[..4], &[0.0; 4]);
        assert_eq!(&high[4..10], &[POSE_BOUND, POSE_BOUND, std::f32::consts::PI, 1.0, 1.0, 1.0]);
        let reach = 8f64.sqrt();
        assert_eq!(&high[10..], &[(reach / 1.6) as f32, (reach / 0.8) as f32, 1.0]);
        assert!(low.iter().zip(&high).skip(4).all(|(l, h)| *l == -*h));
        // without a box the tracker's limits bound the command; a fast controller's yaw rate widens ω
        let (_, high) = observation_bounds(4, [1.6, 0.8], 1.5, None, [1.0, 1.0], 3.0);
        assert_eq!(&high[10..], &[(1.6f64.hypot(0.8) / 1.6) as f32, (1.6f64.hypot(0.8) / 0.8) as f32, 2.0]);
    }

    #[test]
    fn bins_take_the_nearest_return_and_centre_bin_zero_ahead() {
        let cols = 16;
        let mut ranges = vec![Real::INFINITY; cols];
        ranges[0] = 4.0; // ahead
        ranges[15] = 2.0; // just right of ahead: same bin as ahead with 4 bins
        ranges[4] = 10.0; // left
        let scan = Scan { channels: 1, columns: cols, ranges, ..Default::default() };
        let mut out = [0.0f32; 4];
        bin_ranges(&scan, &[1.0], 20.0, &mut out);
        assert_eq!(out, [0.1, 0.5, 1.0, 1.0]);
    }

    #[test]
    fn bins_match_the_division_formula_for_any_counts() {
        for (cols, bins) in [(1024, 64), (512, 64), (1000, 7), (16, 4), (8, 32), (2048, 1), (5, 5)] {
            let ranges: Vec<Real> = (0..cols).map(|i| 0.5 + ((i * 7919) % 101) as Real * 0.1).collect();
            let scan = Scan { channels: 1, columns: cols, ranges: ranges.clone(), ..Default::default() };
            let mut got = vec![0.0f32; bins];
            bin_ranges(&scan, &[1.0], 20.0, &mut got);
            let mut want = vec![1.0f32; bins];
            for (i, r) in ranges.iter().enumerate() {
                let b = ((i * bins + cols / 2) / cols) % bins;
                want[b] = want[b].min((r / 20.0) as f32);
            }
            assert_eq!(got, want, "cols {cols} bins {bins}");
        }
    }
}
