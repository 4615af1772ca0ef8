//! What a filter call reads: the body's state and the scan's points.

use super::composite::Motion;
use super::config::{finite, ROTATION_TOLERANCE};
use crate::error::{Error, Result};
use crate::math::{det, orthonormality_error, rot_z, Mat3, Vec3};
use crate::sensors::Mover;

/// The robot's orientation and angular velocity when the scan was taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    pub(super) rotation: Mat3,
    pub(super) omega: Vec3,
    pub(super) planar: bool,
    pub(super) velocity: Option<Vec3>,
    pub(super) velocity_error: f64,
}

/// The largest angular velocity (rad/s) and speed (m/s) a body state may give: far beyond any
/// robot, small enough that `∂H/∂t` and the braking replay stay finite numbers.
pub const MAX_BODY_RATE: f64 = 1.0e4;

/// `values` finite and within `±MAX_BODY_RATE`, else an error naming `name`.
fn body_rate(name: &'static str, values: &[f64]) -> Result<()> {
    finite(name, values)?;
    if values.iter().any(|v| v.abs() > MAX_BODY_RATE) {
        return Err(Error::invalid(name, format!("must be within ±{MAX_BODY_RATE} (rad/s or m/s), got {values:?}")));
    }
    Ok(())
}

impl BodyState {
    /// A planar robot at heading `yaw` (rad) turning at `yaw_rate` (rad/s). For the braking
    /// shield `yaw_rate` is the nominal rotation command, which it filters.
    pub fn planar(yaw: f64, yaw_rate: f64) -> Result<Self> {
        finite("yaw", &[yaw])?;
        body_rate("omega", &[yaw_rate])?;
        Ok(Self { rotation: rot_z(yaw), omega: [0.0, 0.0, yaw_rate], planar: true, velocity: None, velocity_error: 0.0 })
    }

    /// The same state with the body's measured velocity `(v_x, v_y, ω)` (body frame, m/s and
    /// rad/s): the tracker state the braking check starts from.
    pub fn with_velocity(self, velocity: Vec3) -> Result<Self> {
        body_rate("velocity", &velocity)?;
        Ok(Self { velocity: Some(velocity), ..self })
    }

    /// The same state with a bound (m/s) on the measured velocity's error (an odometry's
    /// velocity, say): the braking check keeps that error times the time to stop more.
    pub fn with_velocity_error(self, error: f64) -> Result<Self> {
        if !(error.is_finite() && (0.0..=MAX_BODY_RATE).contains(&error)) {
            return Err(Error::invalid("velocity_error", format!("must be from 0 to {MAX_BODY_RATE} m/s, got {error}")));
        }
        Ok(Self { velocity_error: error, ..self })
    }

    /// The bound on the measured velocity's error (m/s).
    pub fn velocity_error(&self) -> f64 {
        self.velocity_error
    }

    /// The measured body velocity, if given.
    pub fn velocity(&self) -> Option<&Vec3> {
        self.velocity.as_ref()
    }

    /// A robot with body-to-world rotation `rotation` and body-frame angular velocity `omega`.
    pub fn spatial(rotation: Mat3, omega: Vec3) -> Result<Self> {
        finite("rotation", rotation.as_flattened())?;
        body_rate("omega", &omega)?;
        let err = orthonormality_error(&rotation);
        if err > ROTATION_TOLERANCE || det(&rotation) < 0.0 {
            return Err(Error::invalid("rotation", format!("not a proper rotation matrix (|RᵀR − I| = {err:.2e}, det = {:.3})", det(&rotation))));
        }
        Ok(Self { rotation, omega, planar: false, velocity: None, velocity_error: 0.0 })
    }

    /// Body-to-world rotation.
    pub fn rotation(&self) -> &Mat3 {
        &self.rotation
    }

    /// Body-frame angular velocity (rad/s).
    pub fn omega(&self) -> &Vec3 {
        &self.omega
    }
}

/// A borrowed body-frame scan: `N` points stored row-major, 2 or 3 coordinates each.
#[derive(Debug, Clone, Copy)]
pub enum Points<'a> {
    /// Single precision: runs the `f32` kernel.
    F32(&'a [f32]),
    /// Double precision: runs the `f64` kernel.
    F64(&'a [f64]),
}

/// A scan: points, their row stride, an optional [`Motion`] that moves them into the
/// current body frame before use (for points measured in an earlier frame), and the moving
/// objects seen in it ([`Mover`]s, current body frame, not moved by the motion).
#[derive(Debug, Clone, Copy)]
pub struct Scan<'a> {
    pub(super) points: Points<'a>,
    pub(super) stride: usize,
    pub(super) motion: Option<Motion>,
    pub(super) movers: &'a [Mover],
}

impl<'a> Scan<'a> {
    pub(super) fn new(points: Points<'a>, stride: usize) -> Result<Self> {
        let len = match points {
            Points::F32(p) => p.len(),
            Points::F64(p) => p.len(),
        };
        if stride != 2 && stride != 3 {
            return Err(Error::invalid("points", format!("expected 2 or 3 columns, got {stride}")));
        }
        if len % stride != 0 {
            return Err(Error::invalid("points", format!("{len} values do not make rows of {stride}")));
        }
        Ok(Self { points, stride, motion: None, movers: &[] })
    }

    /// The same points with the moving objects `movers` (current body frame): the braking
    /// shield keeps the robot from driving into their predicted positions, and the braking and
    /// composite rows take their motion into `∂H/∂t`. The points keep the objects' returns
    /// too, as static at their current positions.
    pub fn with_movers(self, movers: &'a [Mover]) -> Self {
        Self { movers, ..self }
    }

    /// The moving objects.
    pub fn movers(&self) -> &'a [Mover] {
        self.movers
    }

    /// The same points, moved by `motion` before use (crop, band and barrier see the moved
    /// points; the composite applies it inside its kernel, the other methods to a copy).
    pub fn moved(self, motion: Motion) -> Self {
        Self { motion: Some(motion), ..self }
    }

    /// The motion applied before use, if any.
    pub fn motion(&self) -> Option<Motion> {
        self.motion
    }

    /// A scan of `f32` points with `stride` (2 or 3) coordinates each.
    pub fn new_f32(points: &'a [f32], stride: usize) -> Result<Self> {
        Self::new(Points::F32(points), stride)
    }

    /// A scan of `f64` points with `stride` (2 or 3) coordinates each.
    pub fn new_f64(points: &'a [f64], stride: usize) -> Result<Self> {
        Self::new(Points::F64(points), stride)
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        match self.points {
            Points::F32(p) => p.len() / self.stride,
            Points::F64(p) => p.len() / self.stride,
        }
    }

    /// No points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Coordinates per point.
    pub fn stride(&self) -> usize {
        self.stride
    }
}

pub(super) fn check_finite(scan: &Scan) -> Result<()> {
    let ok = match scan.points {
        Points::F32(p) => p.iter().all(|v| v.is_finite()),
        Points::F64(p) => p.iter().all(|v| v.is_finite()),
    };
    if ok {
        Ok(())
    } else {
        Err(Error::invalid("points", "contains NaN or inf"))
    }
}
