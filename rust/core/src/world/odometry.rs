//! The odometry conditions a scenario imposes: drift parameters and scheduled faults (the
//! paper's Scenario 2). The odometry that applies them is [`crate::sensors::Odometry`].

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::Real;

/// A scheduled odometry fault.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum OdometryFault {
    /// At `time` (s) the estimate is shifted by `(dx, dy)` (m, world frame).
    Jump {
        /// When (s).
        time: Real,
        /// Shift along world x (m).
        dx: Real,
        /// Shift along world y (m).
        dy: Real,
    },
    /// At `time` (s) the estimated yaw is rotated by `dyaw` (rad).
    YawJump {
        /// When (s).
        time: Real,
        /// Rotation (rad).
        dyaw: Real,
    },
    /// From `start` to `end` (s) the estimate does not move.
    Freeze {
        /// Start (s).
        start: Real,
        /// End (s).
        end: Real,
    },
}

/// Drift parameters and fault schedule. The default is a perfect odometry.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometryConfig {
    /// Translation error, std per √metre (m/√m): along each body axis a step of `d` metres
    /// adds an error of standard deviation `translation_noise · √|d|`, so after `D` metres
    /// along an axis the error's std is `translation_noise · √D`, independent of the control
    /// period (a random walk in the distance travelled).
    pub translation_noise: Real,
    /// Yaw error, std per √radian (rad/√rad): a step turning `ψ` radians adds an error of
    /// standard deviation `yaw_noise · √|ψ|`, so after turning `Ψ` radians in all the std is
    /// `yaw_noise · √Ψ`, independent of the control period.
    pub yaw_noise: Real,
    /// Constant yaw drift (rad/s).
    pub yaw_bias: Real,
    /// Scheduled faults.
    pub faults: Vec<OdometryFault>,
}

impl OdometryConfig {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [("translation_noise", self.translation_noise), ("yaw_noise", self.yaw_noise)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(name, format!("must be finite and >= 0, got {v}")));
            }
        }
        if !self.yaw_bias.is_finite() {
            return Err(Error::invalid("yaw_bias", format!("must be finite, got {}", self.yaw_bias)));
        }
        for f in &self.faults {
            let ok = match *f {
                OdometryFault::Jump { time, dx, dy } => time.is_finite() && dx.is_finite() && dy.is_finite(),
                OdometryFault::YawJump { time, dyaw } => time.is_finite() && dyaw.is_finite(),
                OdometryFault::Freeze { start, end } => start.is_finite() && end.is_finite() && start < end,
            };
            if !ok {
                return Err(Error::invalid("faults", format!("non-finite or empty interval in {f:?}")));
            }
        }
        Ok(())
    }
}
