//! # shieldnav-core
//!
//! The engine of shieldnav, in pure Rust: the composite control-barrier-function (CBF)
//! safety shield of *"Robot-centric safety for LIDAR-based navigation"* (the paper in the
//! project's `shared/seed`), its baselines, and the corridor-inspection simulation.
//!
//! Nothing here knows about Python; the `shieldnav-py` crate is a thin translation layer.
#![warn(missing_docs)]

pub mod control;
pub mod env;
pub mod error;
pub mod math;
pub mod planner;
pub mod robot;
pub mod sensors;
pub mod shield;
pub mod sim;
pub mod simd;
pub mod world;

pub use error::{Error, Result};
