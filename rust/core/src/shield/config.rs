//! The shield's configuration: methods and parameters, with their bounds.

use super::braking::BrakingModel;
use super::scan::ScanFilter;
use crate::error::{Error, Result};

/// Which filter a [`Shield`] applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShieldMethod {
    /// The composite barrier's row over the velocity and the rotation `(v, ω)`, each in its
    /// box, and (planar) the [`braking`] check on the tracker model: the command is sent only
    /// if the robot can still brake to a stop with its ellipse free (`"braking"`).
    Braking,
    /// The paper's soft-min composite of per-point ellipsoidal CBFs, filtering the
    /// translation only (`"composite"`).
    Composite,
    /// One spherical distance row `‖p_i − p_r‖ ≥ s_d` per point, one Clarabel QP (`"distance"`).
    Distance,
    /// The ellipsoidal CBF of the nearest point (smallest `h_i`) only (`"hardmin"`).
    HardMin,
    /// No filter: `u* = u_nom`; the composite is still evaluated and reported (`"none"`).
    Unfiltered,
}

impl ShieldMethod {
    /// Every method name, in the order the docs list them.
    pub const NAMES: [&'static str; 5] = ["braking", "composite", "distance", "hardmin", "none"];

    /// Parses `"braking"`, `"composite"`, `"distance"`, `"hardmin"` or `"none"`.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "braking" => Ok(Self::Braking),
            "composite" => Ok(Self::Composite),
            "distance" => Ok(Self::Distance),
            "hardmin" => Ok(Self::HardMin),
            "none" => Ok(Self::Unfiltered),
            other => Err(Error::invalid("method", format!("unknown method {other:?}; expected \"braking\", \"composite\", \"distance\", \"hardmin\" or \"none\""))),
        }
    }

    /// The name [`ShieldMethod::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Self::Braking => "braking",
            Self::Composite => "composite",
            Self::Distance => "distance",
            Self::HardMin => "hardmin",
            Self::Unfiltered => "none",
        }
    }
}

/// Every parameter of the shield. `Default` holds the paper's values (Sec. IV-B): a
/// 0.9 × 0.45 m ellipse, `γ = 0.9`, `κ = 8`, `α(h) = 2h`, points cropped at 3.5 m, and
/// `s_d = 0.8 m` for the distance baseline.
#[derive(Debug, Clone, PartialEq)]
pub struct ShieldConfig {
    /// Semi-axes of the body-frame ellipsoid (m): 2 values planar, 3 values 3D.
    pub semi_axes: Vec<f64>,
    /// Saturation `γ > 0` of `tanh(h/γ)`.
    pub gamma: f64,
    /// Sharpness `κ > 0` of the soft-min.
    pub kappa: f64,
    /// Gain of the linear class-K function `α(h) = α h`, `α > 0`.
    pub alpha: f64,
    /// Symmetric world-frame velocity box `|u_j| ≤ u_max_j` (m/s), one entry per axis. The
    /// braking shield's default is the tracker's `v_max`.
    pub u_max: Option<Vec<f64>>,
    /// Which filter.
    pub method: ShieldMethod,
    /// Safety distance `s_d` (m) of the distance baseline.
    pub safety_distance: f64,
    /// Crop, height band and down-sampling of the scan.
    pub scan: ScanFilter,
    /// Below this gradient norm the barrier counts as flat: an unmet row is infeasible.
    pub grad_eps: f64,
    /// The body's tracker and control period, for the braking shield: its check replays
    /// them, and the tracker's `w_max` boxes the rotation.
    pub braking: BrakingModel,
    /// How much more the braking shield's QP weighs a change of the rotation (rad/s) than
    /// one of the velocity (m/s): `min ‖u − u_nom‖² + w² ‖ω − ω_nom‖²`. Large, it changes the
    /// translation first, as the paper's filter does, and the turn only where the box leaves
    /// no other way.
    pub rotation_weight: f64,
    /// Speed (m/s) up to which the braking shield follows the nominal command where the
    /// ellipse row would stop the robot but the footprint's braking check lets it pass
    /// (aisles and doorways narrower than the ellipse). 0 keeps the row's command only.
    pub tight_speed: f64,
    /// Acceleration (m/s²) up to which the braking shield expects a mover to leave its
    /// estimated velocity: its predicted disc grows by `a t²/2`.
    pub mover_accel: f64,
}

impl Default for ShieldConfig {
    fn default() -> Self {
        Self {
            semi_axes: vec![0.9, 0.45],
            gamma: 0.9,
            kappa: 8.0,
            alpha: 2.0,
            u_max: None,
            method: ShieldMethod::Composite,
            safety_distance: 0.8,
            scan: ScanFilter::default(),
            grad_eps: 1e-9,
            braking: BrakingModel::default(),
            rotation_weight: 4.0,
            tight_speed: 0.5,
            mover_accel: 0.25,
        }
    }
}

pub(super) fn positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(name, format!("must be finite and > 0, got {v}")))
    }
}

pub(super) fn finite(name: &'static str, v: &[f64]) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::invalid(name, "contains NaN or inf"))
    }
}

/// How far from orthonormal (`max |RᵀR − I|`) a rotation may be: a rotation written to six
/// decimals is off by up to about 3e-6 (1e-6 refused a fifth of them); an error `ε` in `R`
/// moves each `h_i` by about `ε` relative.
pub const ROTATION_TOLERANCE: f64 = 1e-5;
