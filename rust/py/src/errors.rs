//! Core errors to Python exceptions, one arm per variant. The exception classes live in
//! `shieldnav/exceptions.py` (so that `InvalidArgumentError` is also a `ValueError`).

use pyo3::prelude::*;
use shieldnav_core::Error;

pyo3::import_exception!(shieldnav.exceptions, InvalidArgumentError);
pyo3::import_exception!(shieldnav.exceptions, SolverError);
pyo3::import_exception!(shieldnav.exceptions, MapFileError);

/// Maps a core error to its Python exception.
pub fn to_py(err: Error) -> PyErr {
    match err {
        Error::InvalidArgument { .. } | Error::DimensionMismatch { .. } | Error::UnknownPreset { .. } => InvalidArgumentError::new_err(err.to_string()),
        Error::MapFile { .. } => MapFileError::new_err(err.to_string()),
        Error::Solver(_) => SolverError::new_err(err.to_string()),
    }
}

/// An `InvalidArgumentError` (a `ValueError`) about argument `name`.
pub fn invalid(name: &str, reason: impl std::fmt::Display) -> PyErr {
    InvalidArgumentError::new_err(format!("invalid `{name}`: {reason}"))
}

/// Refuses bool and complex input where numbers are expected: a numpy array or scalar of bool
/// or complex dtype (numpy would read them as 1/0 or drop the imaginary part), or a Python
/// `bool` / `complex`, or a list or tuple holding one. `name` is the argument's name.
pub fn refuse_bool_complex(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<()> {
    fn kind(o: &Bound<'_, PyAny>) -> Option<char> {
        if o.is_instance_of::<pyo3::types::PyBool>() {
            return Some('b');
        }
        if o.is_instance_of::<pyo3::types::PyComplex>() {
            return Some('c');
        }
        let dtype = o.getattr(pyo3::intern!(o.py(), "dtype")).ok()?;
        let k: String = dtype.getattr(pyo3::intern!(o.py(), "kind")).ok()?.extract().ok()?;
        k.chars().next()
    }
    let what = |k: char| match k {
        'b' => Some("bool"),
        'c' => Some("complex"),
        _ => None,
    };
    if let Some(w) = kind(obj).and_then(what) {
        return Err(invalid(name, format!("expected real numbers, not {w} (got {})", repr(obj))));
    }
    if obj.is_instance_of::<pyo3::types::PyList>() || obj.is_instance_of::<pyo3::types::PyTuple>() {
        for item in obj.try_iter()? {
            let item = item?;
            if let Some(w) = kind(&item).and_then(what) {
                return Err(invalid(name, format!("expected real numbers, not {w} (got {})", repr(obj))));
            }
            if item.is_instance_of::<pyo3::types::PyList>() || item.is_instance_of::<pyo3::types::PyTuple>() {
                refuse_bool_complex(&item, name)?;
            }
        }
    }
    Ok(())
}

/// `repr(obj)`, or nothing if that fails.
fn repr(obj: &Bound<'_, PyAny>) -> String {
    obj.repr().map(|r| r.to_string()).unwrap_or_default()
}

/// An integer argument from 0 to 2**64 − 1: bool, negative, fractional or too big values are
/// an `InvalidArgumentError` naming `name` (PyO3 raised a bare `OverflowError`).
pub fn u64_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<u64> {
    refuse_bool_complex(obj, name)?;
    obj.extract::<u64>().map_err(|_| invalid(name, format!("expected {what} (an integer from 0 to 2**64 - 1), got {}", repr(obj))))
}

/// [`u64_arg`] for a count held as `usize`.
pub fn usize_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<usize> {
    let v = u64_arg(name, obj, what)?;
    usize::try_from(v).map_err(|_| invalid(name, format!("expected {what}, got {v}: too big")))
}

/// `N` real numbers (a tuple, list or array of exactly `N`), named `name` in the error;
/// `what` says what they are (`"(x, y, z, yaw)"`).
pub fn reals_arg<const N: usize>(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<[f64; N]> {
    refuse_bool_complex(obj, name)?;
    obj.extract::<[f64; N]>().map_err(|_| invalid(name, format!("expected {what}: {N} numbers, got {}", repr(obj))))
}

/// `seed` of `Episode(...)` and `Episode.reset(seed)` (for `#[pyo3(from_py_with)]`).
pub fn seed_arg(obj: &Bound<'_, PyAny>) -> PyResult<u64> {
    u64_arg("seed", obj, "a seed")
}

/// `num_envs` of `Batch(...)`.
pub fn num_envs_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    usize_arg("num_envs", obj, "a number of episodes")
}

/// `threads` of `Batch(...)`.
pub fn threads_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    usize_arg("threads", obj, "a number of threads")
}

/// `channels` of `World(...)`.
pub fn channels_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    usize_arg("channels", obj, "a channel count (1 or 16..=128)")
}

/// `columns` of `World(...)`.
pub fn columns_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    usize_arg("columns", obj, "a column count (512, 1024 or 2048)")
}

/// `mount` of `World(...)`.
pub fn mount_arg(obj: &Bound<'_, PyAny>) -> PyResult<(f64, f64, f64, f64)> {
    let [x, y, z, yaw] = reals_arg::<4>("mount", obj, "(x, y, z, yaw)")?;
    Ok((x, y, z, yaw))
}

/// `vertical_fov` of `World(...)`.
pub fn vertical_fov_arg(obj: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
    let [lo, hi] = reals_arg::<2>("vertical_fov", obj, "(low, high) in rad")?;
    Ok((lo, hi))
}

/// A real number named `name`: bool, complex, strings and numbers no `f64` holds
/// (`10**400`) are an `InvalidArgumentError` naming it and saying what was expected (`what`).
pub fn real_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<f64> {
    refuse_bool_complex(obj, name)?;
    obj.extract::<f64>().map_err(|_| invalid(name, format!("expected {what} (a real number), got {}", repr(obj))))
}

/// [`real_arg`], or `None` for `None`.
pub fn opt_real_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Option<f64>> {
    if obj.is_none() {
        return Ok(None);
    }
    real_arg(name, obj, what).map(Some)
}

/// Real numbers (a sequence or array), named `name` in the error.
pub fn reals_vec_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    refuse_bool_complex(obj, name)?;
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(invalid(name, format!("expected {what} (real numbers), got {}", repr(obj))));
    }
    obj.extract::<Vec<f64>>().map_err(|_| invalid(name, format!("expected {what} (real numbers), got {}", repr(obj))))
}

/// Generates `fn $f(obj) -> PyResult<$t>` reading argument `$name` with `$helper` (for
/// `#[pyo3(from_py_with = ...)]`, which takes a function of the object alone).
macro_rules! named_arg {
    ($f:ident, $t:ty, $helper:ident, $name:literal, $what:literal) => {
        #[doc = concat!("Argument `", $name, "`: ", $what, ".")]
        pub fn $f(obj: &Bound<'_, PyAny>) -> PyResult<$t> {
            $helper($name, obj, $what)
        }
    };
}

fn opt_usize_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Option<usize>> {
    if obj.is_none() {
        return Ok(None);
    }
    usize_arg(name, obj, what).map(Some)
}

fn opt_reals_vec_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Option<Vec<f64>>> {
    if obj.is_none() {
        return Ok(None);
    }
    reals_vec_arg(name, obj, what).map(Some)
}

fn pair_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<[f64; 2]> {
    reals_arg::<2>(name, obj, what)
}

fn opt_pair_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Option<(f64, f64)>> {
    if obj.is_none() {
        return Ok(None);
    }
    reals_arg::<2>(name, obj, what).map(|[a, b]| Some((a, b)))
}

fn footprint_arg(name: &str, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Option<shieldnav_core::shield::Footprint>> {
    use shieldnav_core::shield::Footprint;
    if obj.is_none() {
        return Ok(None);
    }
    refuse_bool_complex(obj, name)?;
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(invalid(name, format!("expected {what}, got {}", repr(obj))));
    }
    if let Ok([length, width]) = obj.extract::<[f64; 2]>() {
        return Footprint::rectangle(length, width).map(Some).map_err(to_py);
    }
    let vertices = obj.extract::<Vec<[f64; 2]>>().map_err(|_| invalid(name, format!("expected {what}, got {}", repr(obj))))?;
    Footprint::polygon(&vertices).map(Some).map_err(to_py)
}

/// The `Shield` keywords, each read with its own name in every error.
pub mod shield_args {
    use super::*;
    named_arg!(semi_axes, Vec<f64>, reals_vec_arg, "semi_axes", "the ellipse's semi-axes in m");
    named_arg!(gamma, f64, real_arg, "gamma", "the saturation γ");
    named_arg!(kappa, f64, real_arg, "kappa", "the sharpness κ");
    named_arg!(alpha, f64, real_arg, "alpha", "the class-K gain α");
    named_arg!(crop_radius, Option<f64>, opt_real_arg, "crop_radius", "the crop radius in m, or None");
    named_arg!(u_max, Option<Vec<f64>>, opt_reals_vec_arg, "u_max", "the speed box in m/s, or None");
    named_arg!(safety_distance, f64, real_arg, "safety_distance", "the distance baseline's radius in m");
    named_arg!(height_band, Option<(f64, f64)>, opt_pair_arg, "height_band", "(z_lo, z_hi) in m, or None");
    named_arg!(voxel_size, Option<f64>, opt_real_arg, "voxel_size", "the voxel edge in m, or None");
    named_arg!(angular_bins, Option<usize>, opt_usize_arg, "angular_bins", "a number of bins, or None");
    named_arg!(grad_eps, f64, real_arg, "grad_eps", "the vanishing-gradient threshold");
    named_arg!(tracker_tau, f64, real_arg, "tracker_tau", "the tracker's time constant in s");
    named_arg!(a_max, [f64; 2], pair_arg, "a_max", "(ax, ay) in m/s²");
    named_arg!(w_max, f64, real_arg, "w_max", "the yaw-rate limit in rad/s");
    named_arg!(yaw_accel_max, f64, real_arg, "yaw_accel_max", "the yaw acceleration limit in rad/s²");
    named_arg!(dt, f64, real_arg, "dt", "the control period in s");
    named_arg!(brake_margin, f64, real_arg, "brake_margin", "the braking check's margin in m");
    named_arg!(rotation_weight, f64, real_arg, "rotation_weight", "the weight of a turn against a speed");
    named_arg!(lidar_noise_std, f64, real_arg, "lidar_noise_std", "the range noise's standard deviation in m");
    named_arg!(tight_speed, f64, real_arg, "tight_speed", "the tight-space speed in m/s");
    named_arg!(mover_accel, f64, real_arg, "mover_accel", "the movers' acceleration bound in m/s²");
    named_arg!(footprint, Option<shieldnav_core::shield::Footprint>, footprint_arg, "footprint", "(length, width) in m, an (M, 2) convex polygon in m, or None");
    named_arg!(yaw, Option<f64>, opt_real_arg, "yaw", "the heading in rad, or None");
}
