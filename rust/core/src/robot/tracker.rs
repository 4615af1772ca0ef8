//! The low-level tracker: body-frame velocity and yaw-rate commands followed through a
//! first-order lag with velocity and acceleration limits.
//!
//! Each step the commanded `(vx, vy, ω)` is limited to the velocity box (and reported as
//! saturated if it had to be), the velocity moves toward it by `1 − e^{−dt/τ}` of the gap, and
//! that change is limited to `a_max·dt` per component.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::Real;

/// Tracker parameters. Defaults are Spot-like: 1.6 m/s forward, 0.8 m/s sideways, 1.5 rad/s,
/// τ = 0.15 s, 2 m/s² and 4 rad/s².
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrackerConfig {
    /// Time constant of the first-order lag (s); 0 follows the command at once.
    pub tau: Real,
    /// Speed limits `[vx, vy]` (m/s, body frame).
    pub v_max: [Real; 2],
    /// Yaw-rate limit (rad/s).
    pub w_max: Real,
    /// Acceleration limits `[ax, ay]` (m/s²).
    pub a_max: [Real; 2],
    /// Yaw acceleration limit (rad/s²).
    pub alpha_max: Real,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        Self { tau: 0.15, v_max: [1.6, 0.8], w_max: 1.5, a_max: [2.0, 2.0], alpha_max: 4.0 }
    }
}

impl TrackerConfig {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<()> {
        if !(self.tau.is_finite() && self.tau >= 0.0) {
            return Err(Error::invalid("tracker_tau", format!("must be finite and >= 0, got {}", self.tau)));
        }
        for (name, v) in [("v_max", self.v_max[0]), ("v_max", self.v_max[1]), ("w_max", self.w_max), ("a_max", self.a_max[0]), ("a_max", self.a_max[1]), ("yaw_accel_max", self.alpha_max)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(name, format!("must be finite and > 0, got {v}")));
            }
        }
        // (the shield refuses body rates beyond it: a command at these limits must pass)
        let limit = crate::shield::MAX_BODY_RATE;
        for (name, v) in [("v_max", self.v_max[0]), ("v_max", self.v_max[1]), ("w_max", self.w_max)] {
            if v > limit {
                return Err(Error::invalid(name, format!("must be at most {limit} (the shield's MAX_BODY_RATE), got {v}")));
            }
        }
        Ok(())
    }
}

/// What one tracker step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerOutcome {
    /// The body-frame velocity `(vx, vy, ω)` after the step.
    pub velocity: [Real; 3],
    /// Whether the command exceeded the velocity limits and was saturated.
    pub saturated: bool,
}

/// The tracker state: the current body-frame velocity.
#[derive(Debug, Clone)]
pub struct Tracker {
    config: TrackerConfig,
    velocity: [Real; 3],
}

impl Tracker {
    /// A tracker at rest.
    pub fn new(config: TrackerConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self { config, velocity: [0.0; 3] })
    }

    /// The current body-frame velocity `(vx, vy, ω)`.
    pub fn velocity(&self) -> [Real; 3] {
        self.velocity
    }

    /// Overrides the current velocity (after a collision stopped the body, for instance).
    pub fn set_velocity(&mut self, v: [Real; 3]) {
        self.velocity = v;
    }

    /// The configuration.
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    /// Advances by `dt` (s) toward the command `(vx, vy, ω)` (m/s, m/s, rad/s, body frame).
    pub fn step(&mut self, command: [Real; 3], dt: Real) -> Result<TrackerOutcome> {
        if !command.iter().all(|c| c.is_finite()) {
            return Err(Error::invalid("command", format!("must be finite, got {command:?}")));
        }
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::invalid("dt", format!("must be finite and > 0, got {dt}")));
        }
        let (velocity, saturated) = self.config.next_velocity(self.velocity, command, self.config.gain(dt), dt);
        self.velocity = velocity;
        Ok(TrackerOutcome { velocity, saturated })
    }
}

impl TrackerConfig {
    /// The share `1 − e^{−dt/τ}` of the gap to the command that one step of `dt` closes.
    pub fn gain(&self, dt: Real) -> Real {
        if self.tau > 0.0 {
            1.0 - (-dt / self.tau).exp()
        } else {
            1.0
        }
    }

    /// The velocity after one step of `dt` from `velocity` toward `command`, with
    /// `gain = self.gain(dt)`, and whether the command was saturated: the tracker's one
    /// formula, which the shield's braking check replays.
    #[inline]
    pub fn next_velocity(&self, velocity: [Real; 3], command: [Real; 3], gain: Real, dt: Real) -> ([Real; 3], bool) {
        let vmax = [self.v_max[0], self.v_max[1], self.w_max];
        let amax = [self.a_max[0], self.a_max[1], self.alpha_max];
        let mut out = velocity;
        let mut saturated = false;
        for k in 0..3 {
            let target = command[k].clamp(-vmax[k], vmax[k]);
            saturated |= target != command[k];
            out[k] += ((target - velocity[k]) * gain).clamp(-amax[k] * dt, amax[k] * dt);
        }
        (out, saturated)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_lag_without_limits_follows_the_exponential() {
        let cfg = TrackerConfig { a_max: [100.0, 100.0], alpha_max: 100.0, ..Default::default() };
        let mut t = Tracker::new(cfg).unwrap();
        let dt = 0.01;
        for _ in 0..15 {
            t.step([1.0, 0.0, 0.0], dt).unwrap();
        }
        // after one time constant: 1 − e^{−1}
        assert!((t.velocity()[0] - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
    }

    #[test]
    fn acceleration_limit_caps_the_change() {
        let mut t = Tracker::new(TrackerConfig { tau: 0.0, ..Default::default() }).unwrap();
        let out = t.step([1.5, 0.0, 1.0], 0.1).unwrap();
        assert!((out.velocity[0] - 0.2).abs() < 1e-12 && (out.velocity[2] - 0.4).abs() < 1e-12);
        assert!(!out.saturated);
    }

    #[test]
    fn over_limit_command_is_saturated_and_reported() {
        let mut t = Tracker::new(TrackerConfig { tau: 0.0, a_max: [1e3, 1e3], alpha_max: 1e3, ..Default::default() }).unwrap();
        let out = t.step([5.0, -3.0, 0.0], 0.1).unwrap();
        assert!(out.saturated);
        assert_eq!(out.velocity, [1.6, -0.8, 0.0]);
    }

    #[test]
    fn non_finite_inputs_are_errors() {
        let mut t = Tracker::new(TrackerConfig::default()).unwrap();
        assert!(t.step([f64::NAN, 0.0, 0.0], 0.1).is_err());
        assert!(t.step([0.0, 0.0, 0.0], 0.0).is_err());
        assert!(Tracker::new(TrackerConfig { w_max: -1.0, ..Default::default() }).is_err());
    }
}
