//! `shieldnav._core`: the thin PyO3 layer over `shieldnav-core`.

use pyo3::prelude::*;

mod world;

/// The native module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    world::register(m)?;
    Ok(())
}
