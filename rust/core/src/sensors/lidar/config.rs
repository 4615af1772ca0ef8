//! The LIDAR's configuration (mount, beams, limits, noise) and one revolution's returns.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::Real;
use crate::world::Pose2;

/// Where the sensor sits on the robot: body-frame position (m; `z` is the height above the
/// floor) and yaw (rad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LidarMount {
    /// Forward offset (m).
    pub x: Real,
    /// Left offset (m).
    pub y: Real,
    /// Height above the floor (m).
    pub z: Real,
    /// Yaw relative to the body (rad).
    pub yaw: Real,
}

impl Default for LidarMount {
    fn default() -> Self {
        Self { x: 0.0, y: 0.0, z: 0.5, yaw: 0.0 }
    }
}

/// The largest accepted `max_range` (m); an OS0 reaches about 50 m.
pub const MAX_RANGE_LIMIT: Real = 200.0;

/// LIDAR parameters. The default is a planar 1024-column ring at 10 Hz, range 0.1–20 m,
/// 1 cm range noise, no dropout.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LidarConfig {
    /// 1 for a planar ring, else 16..=128.
    pub channels: usize,
    /// 512, 1024 or 2048 beams per revolution.
    pub columns: usize,
    /// Lowest and highest elevation (rad) for `channels > 1`; OS0: ±45°.
    pub vertical_fov: (Real, Real),
    /// Returns nearer than this (m) are dropped (and occlude what is behind).
    pub min_range: Real,
    /// Returns farther than this (m) are dropped.
    pub max_range: Real,
    /// Standard deviation of additive Gaussian range noise (m).
    pub range_noise_std: Real,
    /// Probability that a return is dropped, in `[0, 1)`.
    pub dropout: Real,
    /// Revolutions per second (10–20 Hz).
    pub rate_hz: Real,
    /// Mounting pose on the body.
    pub mount: LidarMount,
}

impl Default for LidarConfig {
    fn default() -> Self {
        Self {
            channels: 1,
            columns: 1024,
            vertical_fov: (-std::f64::consts::FRAC_PI_4, std::f64::consts::FRAC_PI_4),
            min_range: 0.1,
            max_range: 20.0,
            range_noise_std: 0.01,
            dropout: 0.0,
            rate_hz: 10.0,
            mount: LidarMount::default(),
        }
    }
}

impl LidarConfig {
    /// Elevation of each channel (rad), lowest first: `[0]` for a planar ring, else evenly
    /// spread over `vertical_fov`.
    pub fn elevations(&self) -> Vec<Real> {
        if self.channels == 1 {
            vec![0.0]
        } else {
            let (lo, hi) = self.vertical_fov;
            (0..self.channels).map(|k| lo + k as Real * (hi - lo) / (self.channels - 1) as Real).collect()
        }
    }

    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<()> {
        if !(self.channels == 1 || (16..=128).contains(&self.channels)) {
            return Err(Error::invalid("channels", format!("must be 1 or in 16..=128, got {}", self.channels)));
        }
        if ![512, 1024, 2048].contains(&self.columns) {
            return Err(Error::invalid("columns", format!("must be 512, 1024 or 2048, got {}", self.columns)));
        }
        let (lo, hi) = self.vertical_fov;
        let half = std::f64::consts::FRAC_PI_2;
        if !(lo.is_finite() && hi.is_finite() && lo < hi && lo > -half && hi < half) {
            return Err(Error::invalid("vertical_fov", format!("needs -π/2 < low < high < π/2, got ({lo}, {hi})")));
        }
        if !(self.min_range.is_finite() && self.min_range >= 0.0) {
            return Err(Error::invalid("min_range", format!("must be finite and >= 0, got {}", self.min_range)));
        }
        if !(self.max_range.is_finite() && self.max_range > self.min_range && self.max_range <= MAX_RANGE_LIMIT) {
            return Err(Error::invalid("max_range", format!("must be > min_range and <= {MAX_RANGE_LIMIT} m, got {}", self.max_range)));
        }
        if !(self.range_noise_std.is_finite() && self.range_noise_std >= 0.0) {
            return Err(Error::invalid("range_noise_std", format!("must be finite and >= 0, got {}", self.range_noise_std)));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(Error::invalid("dropout", format!("must be in [0, 1), got {}", self.dropout)));
        }
        if !(10.0..=20.0).contains(&self.rate_hz) {
            return Err(Error::invalid("rate_hz", format!("must be in [10, 20] Hz, got {}", self.rate_hz)));
        }
        let m = self.mount;
        if ![m.x, m.y, m.z, m.yaw].iter().all(|v| v.is_finite()) || m.z < 0.0 {
            return Err(Error::invalid("mount", format!("must be finite with z >= 0, got {m:?}")));
        }
        Ok(())
    }
}

impl LidarConfig {
    /// Checks that the scan rate can be honoured with the control period `dt` (s): scans are
    /// taken at control steps (each at the first step at or after its due time, the step's
    /// time reported as the scan's `stamp`), so a rate faster than the control rate `1 / dt`
    /// would silently be capped to it. The error names `rate_hz` and `dt`.
    pub fn check_rate(&self, dt: Real) -> Result<()> {
        // (within a relative 1e-9: 10 Hz at 0.1 s is one scan a step)
        if self.rate_hz * dt > 1.0 + 1e-9 {
            return Err(Error::invalid(
                "rate_hz",
                format!("{} Hz is faster than the control rate 1 / dt = {} Hz (dt = {dt} s): scans are taken at control steps; lower `rate_hz` or `dt`", self.rate_hz, 1.0 / dt),
            ));
        }
        Ok(())
    }
}

/// One revolution's returns.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scan {
    /// Channel count.
    pub channels: usize,
    /// Column count.
    pub columns: usize,
    /// Range along each beam (m), `ranges[k * columns + i]`; `+inf` where there is no return.
    pub ranges: Vec<Real>,
    /// Body-frame points `[x, y, z]` (m), same order; NaN where there is no return.
    pub points: Vec<[Real; 3]>,
    /// World time of the scan (s).
    pub stamp: Real,
    /// The true sensor pose in the world when scanned (planar part).
    pub sensor_pose: Pose2,
}

impl Scan {
    /// The valid returns only, in body frame.
    pub fn valid_points(&self) -> impl Iterator<Item = &[Real; 3]> + '_ {
        self.points.iter().filter(|p| !p[0].is_nan())
    }
}
