//! The agent's action: three numbers in `[-1, 1]`, read as a command in one of three frames.

use crate::control::NominalController;
use crate::error::{Error, Result};
use crate::math::Real;
use crate::robot::TrackerConfig;
use crate::world::Pose2;

/// How the action `a ∈ [-1, 1]³` becomes the nominal command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ActionMode {
    /// `(v_x, v_y, ω) = a ⊙ (v_max,x, v_max,y, ω_max)`, body frame (`"body"`, the default).
    Body,
    /// `(v_x, v_y) = a₀₁ ⊙ u_max` in the world frame of the odometry estimate, `ω = a₂ ω_max`
    /// (`"world"`); turned into the body frame with the estimated yaw.
    World,
    /// A reference offset: `p_d = p̂ ⊕ a₀₁ · reach` (body frame of the estimate),
    /// `ψ_d = ψ̂ + a₂ π`; the P controller makes `u_nom` (`"waypoint"`).
    Waypoint,
}

impl ActionMode {
    /// Parses `"body"`, `"world"` or `"waypoint"`.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "body" => Ok(Self::Body),
            "world" => Ok(Self::World),
            "waypoint" => Ok(Self::Waypoint),
            other => Err(Error::invalid("action_mode", format!("unknown mode {other:?}; expected \"body\", \"world\" or \"waypoint\""))),
        }
    }

    /// The name [`ActionMode::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Self::Body => "body",
            Self::World => "world",
            Self::Waypoint => "waypoint",
        }
    }
}

/// How far past `±1` (float rounding of an agent's output) an action entry may be.
pub const ACTION_TOLERANCE: Real = 1e-6;

/// Checks that every entry of `action` is finite and within `[-1, 1]` (to
/// [`ACTION_TOLERANCE`]).
pub fn check_action(action: &[Real; 3]) -> Result<[Real; 3]> {
    for &v in action {
        if !(v.is_finite() && v.abs() <= 1.0 + ACTION_TOLERANCE) {
            return Err(Error::invalid("action", format!("every entry must be finite and in [-1, 1], got {action:?}")));
        }
    }
    Ok(action.map(|v| v.clamp(-1.0, 1.0)))
}

/// The body-frame nominal command `(v_x, v_y, ω)` of `action` for a robot whose estimated pose
/// is `estimate`.
pub fn nominal_command(mode: ActionMode, action: &[Real; 3], estimate: Pose2, tracker: &TrackerConfig, controller: &NominalController, reach: Real) -> Result<[Real; 3]> {
    let a = check_action(action)?;
    let (s, c) = estimate.yaw.sin_cos();
    let to_body = |w: [Real; 2]| [c * w[0] + s * w[1], -s * w[0] + c * w[1]];
    Ok(match mode {
        ActionMode::Body => [a[0] * tracker.v_max[0], a[1] * tracker.v_max[1], a[2] * tracker.w_max],
        ActionMode::World => {
            let m = controller.config().u_max;
            let v = to_body([a[0] * m[0], a[1] * m[1]]);
            [v[0], v[1], a[2] * tracker.w_max]
        }
        ActionMode::Waypoint => {
            let goal = estimate.transform_point([a[0] * reach, a[1] * reach]);
            let yaw = estimate.yaw + a[2] * std::f64::consts::PI;
            let cmd = controller.command(&goal, yaw, &[estimate.x, estimate.y], estimate.yaw)?;
            let v = to_body(cmd.velocity);
            [v[0], v[1], cmd.yaw_rate]
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::NominalControllerConfig;

    #[test]
    fn frames_scale_and_rotate_as_documented() {
        let tr = TrackerConfig::default();
        let ctl = NominalController::new(NominalControllerConfig::default()).unwrap();
        let est = Pose2::new(3.0, 4.0, std::f64::consts::FRAC_PI_2);
        let b = nominal_command(ActionMode::Body, &[1.0, -0.5, 0.5], est, &tr, &ctl, 2.0).unwrap();
        assert_eq!(b, [1.6, -0.4, 0.75]);
        // world +x is body −y for a robot facing +y
        let w = nominal_command(ActionMode::World, &[1.0, 0.0, 0.0], est, &tr, &ctl, 2.0).unwrap();
        assert!(w[0].abs() < 1e-12 && (w[1] + 1.0).abs() < 1e-12);
        // a waypoint 0.1 m straight ahead: K_p · 0.1 = 0.4 m/s forward
        let p = nominal_command(ActionMode::Waypoint, &[0.05, 0.0, 0.0], est, &tr, &ctl, 2.0).unwrap();
        assert!((p[0] - 0.4).abs() < 1e-12 && p[1].abs() < 1e-12 && p[2] == 0.0, "{p:?}");
    }

    #[test]
    fn out_of_range_or_nan_actions_are_errors() {
        assert!(check_action(&[1.5, 0.0, 0.0]).is_err());
        assert!(check_action(&[0.0, Real::NAN, 0.0]).is_err());
        assert_eq!(check_action(&[1.0 + 1e-7, 0.0, -1.0]).unwrap(), [1.0, 0.0, -1.0]);
    }
}
