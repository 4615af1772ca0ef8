//! Keyword arguments → the core's keyword table (`shieldnav_core::env::keywords`): each value
//! becomes a [`Value`] and the core reads, checks and names every keyword; the defaults Python
//! shows are the core's.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use shieldnav_core::env::keywords::{self, SiteOptions, Value};
use shieldnav_core::env::EpisodeConfig;

use std::path::PathBuf;

use shieldnav_core::env::Site;
use shieldnav_core::world::{load_ros_map, Scenario};

use crate::errors::invalid;

/// Where an episode's world comes from, as the Python keywords give it (exactly one).
pub struct SiteArgs {
    pub preset: Option<String>,
    pub procedural: bool,
    pub ros_map: Option<PathBuf>,
    pub scenario: Option<PathBuf>,
}

impl SiteArgs {
    /// Checks that exactly one source is given.
    pub fn check(&self) -> PyResult<()> {
        let n = self.preset.is_some() as u8 + self.procedural as u8 + self.ros_map.is_some() as u8 + self.scenario.is_some() as u8;
        if n != 1 {
            return Err(invalid("site", format!("give exactly one of preset, procedural=True, ros_map, scenario (got {n})")));
        }
        Ok(())
    }

    /// That the site keywords given apply to this site: `site_kind` to a procedural one, the
    /// map options to a ROS map (else they would be silently ignored).
    pub fn check_keys(&self, kwargs: &[(String, Value)]) -> PyResult<()> {
        keywords::check_site_keys(self.procedural, self.ros_map.is_some(), kwargs).map_err(crate::errors::to_py)
    }

    /// The core's site (loads a map or scenario file; call detached from the GIL).
    pub fn load(self, opts: &SiteOptions) -> shieldnav_core::Result<Site> {
        Ok(if let Some(name) = self.preset {
            Site::Preset(name)
        } else if self.procedural {
            Site::Procedural(opts.generator)
        } else if let Some(path) = self.ros_map {
            Site::Scenario(Box::new(load_ros_map(path, &opts.ros_map)?.scenario))
        } else {
            Site::Scenario(Box::new(Scenario::from_json_file(self.scenario.unwrap_or_default())?))
        })
    }
}

/// `kwargs` as the core's keyword values; a value no keyword can hold (complex, a mapping, an
/// integer beyond 64 bits, ...) is an `InvalidArgumentError` naming its keyword.
pub fn values(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, Value)>> {
    let Some(kw) = kwargs else { return Ok(Vec::new()) };
    kw.iter()
        .map(|(k, v)| {
            let key: String = k.extract().map_err(|_| invalid("kwargs", "keyword names must be strings"))?;
            let value = value_of(&key, &v)?;
            Ok((key, value))
        })
        .collect()
}

/// One Python value as a [`Value`] (numpy scalars and arrays included).
fn value_of(key: &str, v: &Bound<'_, PyAny>) -> PyResult<Value> {
    if v.is_none() {
        return Ok(Value::None);
    }
    let type_name = v.get_type().name().map(|n| n.to_string()).unwrap_or_default();
    if v.is_instance_of::<PyBool>() || type_name == "bool_" || type_name == "bool" {
        return Ok(Value::Bool(v.is_truthy()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Value::Str(v.extract()?));
    }
    if type_name.starts_with("complex") {
        return Err(invalid(key, format!("expected a real number, got {type_name}")));
    }
    if v.is_instance_of::<PyInt>() || (v.hasattr("__index__")? && !v.hasattr("__len__")?) {
        return v.extract::<i64>().map(Value::Int).map_err(|_| invalid(key, "integer out of range"));
    }
    if v.is_instance_of::<PyFloat>() || (v.hasattr("__float__")? && !v.hasattr("__len__")?) {
        return v.extract::<f64>().map(Value::Float).map_err(|e| invalid(key, format!("expected a number: {e}")));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() || type_name == "ndarray" {
        return v.try_iter()?.map(|item| value_of(key, &item?)).collect::<PyResult<Vec<_>>>().map(Value::List);
    }
    Err(invalid(key, format!("unsupported value of type {type_name}")))
}

/// A [`Value`] as a Python object.
fn py_value<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::None => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Int(i) => i.into_pyobject(py)?.into_any(),
        Value::Float(x) => x.into_pyobject(py)?.into_any(),
        Value::Str(s) => s.into_pyobject(py)?.into_any(),
        Value::List(items) => PyList::new(py, items.iter().map(|i| py_value(py, i)).collect::<PyResult<Vec<_>>>()?)?.into_any(),
    })
}

/// A core error as a Python exception, a configuration field named by the keyword given for
/// it ([`keywords::keyed`]).
pub fn keyed(err: shieldnav_core::Error, kwargs: &[(String, Value)]) -> PyErr {
    let given: Vec<&str> = kwargs.iter().map(|(k, _)| k.as_str()).collect();
    crate::errors::to_py(keywords::keyed(err, &given))
}

/// The configuration `kwargs` give over the defaults ([`keywords::episode_config`]).
pub fn episode_config(kwargs: &[(String, Value)]) -> PyResult<(EpisodeConfig, SiteOptions)> {
    keywords::episode_config(kwargs).map_err(crate::errors::to_py)
}

/// The defaults as a dict of the keywords [`episode_config`] reads.
pub fn episode_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in keywords::defaults() {
        d.set_item(k, py_value(py, &v)?)?;
    }
    Ok(d)
}
