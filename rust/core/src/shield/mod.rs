//! The composite-CBF safety shield of the paper (Sec. III) and its baselines.
//!
//! A [`Shield`] turns a nominal world-frame velocity `u_nom` and a body-frame LIDAR scan into
//! the filtered command `u*` of Eq. (qp):
//!
//! `u* = argmin ‖u − u_nom‖²  s.t.  ∂H/∂pᵀ u ≥ −α(H) − ∂H/∂t,  |u_j| ≤ u_max_j`.
//!
//! Methods ([`ShieldMethod`]): the braking shield (the composite row over velocity *and*
//! rotation, and the [`braking`] check against the body's tracker, so the guarantee holds
//! for the body that lags behind its command), the paper's soft-min composite of one
//! ellipsoidal CBF per point (closed-form exact QP, translation only), the distance baseline
//! (one spherical row per point, all rows in one Clarabel QP), hard-min (the nearest point's
//! ellipsoidal CBF only), and no filter.
//!
//! ```
//! use shieldnav_core::shield::{BodyState, Scan, Shield, ShieldConfig};
//! let mut shield = Shield::new(ShieldConfig::default()).unwrap();
//! // a wall 0.6 m to the left of the robot, the robot asked to move left at 1 m/s
//! let wall: Vec<f64> = (-20..=20).flat_map(|k| [k as f64 * 0.05, 0.6]).collect();
//! let out = shield.filter(&Scan::new_f64(&wall, 2).unwrap(), &BodyState::planar(0.0, 0.0).unwrap(), &[0.0, 1.0]).unwrap();
//! assert!(out.active && out.feasible);
//! assert!(out.u[1] < 1.0); // slowed down toward the wall
//! ```

mod baselines;
pub mod braking;
mod composite;
mod config;
mod conic;
mod ellipsoid;
mod filter;
mod filter_braking;
mod input;
mod lane;
mod qp;
mod scan;

pub use braking::{clearances_of, BrakingModel, Footprint, Planes, PointSet, Sweep, MAX_FOOTPRINT_VERTICES};
pub use composite::{composite_reference, evaluate_composite, evaluate_composite_moved, CompositeBarrier, CompositeParams, Motion, SimdLevel, MAX_GAMMA, MAX_KAPPA, MIN_GAMMA, MIN_KAPPA};
pub use config::{ShieldConfig, ShieldMethod, ROTATION_TOLERANCE};
pub use conic::{solve_rows, LinearConstraints};
pub use ellipsoid::{Envelope, MAX_SEMI_AXIS, MIN_SEMI_AXIS};
pub use filter::{move_points, Shield, ShieldOutcome};
pub use input::{BodyState, Points, Scan, MAX_BODY_RATE};
pub use lane::Lane;
pub use qp::{project_halfspace_box, QpSolution, MAX_VARS};
pub use scan::{select_points, ScanFilter, ScanScratch, MAX_ANGULAR_BINS};
