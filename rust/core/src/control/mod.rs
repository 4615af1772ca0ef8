//! The nominal go-to-goal controller of the paper, Sec. III: `u_nom = K_p (p_d − p̂_r)`, with
//! yaw tracking toward the planner's `ψ`, both saturated.

use crate::error::{Error, Result};
use crate::planner::MAX_COORDINATE;

/// Gains and limits; `Default` holds the paper's `K_p = 4 I`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NominalControllerConfig {
    /// Position gain `K_p` (1/s), the same on every axis.
    pub kp: f64,
    /// Yaw gain (1/s).
    pub k_yaw: f64,
    /// Speed limit per world axis (m/s); the command is scaled down, keeping its direction.
    pub u_max: [f64; 2],
    /// Yaw-rate limit (rad/s).
    pub omega_max: f64,
}

impl Default for NominalControllerConfig {
    fn default() -> Self {
        Self { kp: 4.0, k_yaw: 2.0, u_max: [1.0, 1.0], omega_max: 1.0 }
    }
}

/// A planar command: world-frame velocity and yaw rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NominalCommand {
    /// `u_nom` (m/s, world frame).
    pub velocity: [f64; 2],
    /// Yaw rate (rad/s).
    pub yaw_rate: f64,
}

/// `u_nom = sat(K_p (p_d − p̂_r))`, `ω = sat(k_ψ wrap(ψ_d − ψ̂))`.
#[derive(Debug, Clone, Copy)]
pub struct NominalController {
    config: NominalControllerConfig,
}

impl NominalController {
    /// Validates `config`.
    pub fn new(config: NominalControllerConfig) -> Result<Self> {
        for (name, v) in [("kp", config.kp), ("k_yaw", config.k_yaw), ("omega_max", config.omega_max), ("u_max", config.u_max[0]), ("u_max", config.u_max[1])] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(name, format!("must be finite and > 0, got {v}")));
            }
        }
        Ok(Self { config })
    }

    /// The configuration.
    pub fn config(&self) -> &NominalControllerConfig {
        &self.config
    }

    /// The command toward `goal` (m) and `goal_yaw` (rad) from the estimated pose.
    pub fn command(&self, goal: &[f64; 2], goal_yaw: f64, position: &[f64; 2], yaw: f64) -> Result<NominalCommand> {
        let far = |p: &[f64; 2]| !p.iter().all(|v| v.abs() <= MAX_COORDINATE);
        if far(goal) {
            return Err(Error::invalid("goal", format!("must be finite and within {MAX_COORDINATE:e} m, got {goal:?}")));
        }
        if far(position) {
            return Err(Error::invalid("position", format!("must be finite and within {MAX_COORDINATE:e} m, got {position:?}")));
        }
        for (name, v) in [("goal_yaw", goal_yaw), ("yaw", yaw)] {
            if !v.is_finite() {
                return Err(Error::invalid(name, format!("must be finite, got {v}")));
            }
        }
        let c = &self.config;
        // saturated, the direction kept: d / m, from the distance itself so that no gain
        // overflows it (kp · d may be infinite for a finite gain)
        let d = [goal[0] - position[0], goal[1] - position[1]];
        let m = (d[0].abs() / c.u_max[0]).max(d[1].abs() / c.u_max[1]);
        let u = if c.kp * m > 1.0 { [d[0] / m, d[1] / m] } else { [c.kp * d[0], c.kp * d[1]] };
        let err = (goal_yaw - yaw + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        let w = (c.k_yaw * err).clamp(-c.omega_max, c.omega_max);
        Ok(NominalCommand { velocity: u, yaw_rate: w })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proportional_inside_limits_and_direction_kept_when_saturated() {
        let c = NominalController::new(NominalControllerConfig::default()).unwrap();
        let near = c.command(&[0.1, -0.05], 0.0, &[0.0, 0.0], 0.0).unwrap();
        assert!((near.velocity[0] - 0.4).abs() < 1e-12 && (near.velocity[1] + 0.2).abs() < 1e-12);
        let far = c.command(&[3.0, 1.5], 0.0, &[0.0, 0.0], 0.0).unwrap();
        assert!((far.velocity[0] - 1.0).abs() < 1e-12 && (far.velocity[1] - 0.5).abs() < 1e-12);
    }

    /// A gain or distance whose product overflows saturates like any other (it gave NaN).
    #[test]
    fn huge_gain_or_distance_saturates() {
        let c = NominalController::new(NominalControllerConfig { kp: 1e300, ..NominalControllerConfig::default() }).unwrap();
        let u = c.command(&[1e9, 1.0], 0.0, &[0.0, 0.0], 0.0).unwrap().velocity;
        assert!((u[0] - 1.0).abs() < 1e-12 && u[1] > 0.0 && u[1] < 1e-8, "{u:?}");
        let c = NominalController::new(NominalControllerConfig::default()).unwrap();
        let u = c.command(&[1e9, 0.0], 0.0, &[-1e9, 0.0], 0.0).unwrap().velocity;
        assert_eq!(u, [1.0, 0.0]);
        for (goal, pos, yaw, name) in [([1e10, 0.0], [0.0; 2], 0.0, "goal"), ([0.0; 2], [f64::NAN, 0.0], 0.0, "position"), ([0.0; 2], [0.0; 2], f64::INFINITY, "yaw")] {
            let e = c.command(&goal, 0.0, &pos, yaw).unwrap_err().to_string();
            assert!(e.contains(&format!("`{name}`")), "{e}");
        }
    }

    #[test]
    fn yaw_error_wraps_the_short_way() {
        let c = NominalController::new(NominalControllerConfig::default()).unwrap();
        let w = c.command(&[0.0, 0.0], -3.0, &[0.0, 0.0], 3.0).unwrap().yaw_rate;
        assert!(w > 0.0, "from 3.0 to −3.0 rad the short way is counter-clockwise");
    }
}
