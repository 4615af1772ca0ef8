//! `shieldnav._core`: the thin PyO3 layer over `shieldnav-core`. Each method extracts and
//! validates its arguments, calls the core, and maps errors to the exceptions of
//! `shieldnav.exceptions`; nothing here computes.

use pyo3::prelude::*;

mod batch;
mod config;
mod episode;
mod errors;
mod node;
mod outcome;
mod planner;
mod shield;
mod world;

/// The native module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    shield::register(m)?;
    planner::register(m)?;
    world::register(m)?;
    episode::register(m)?;
    batch::register(m)?;
    node::register(m)?;
    Ok(())
}
