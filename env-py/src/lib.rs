//! # panda-rapier-py
//!
//! The native module `panda_rapier._native`: thin pyo3 wrappers around `panda-rapier-core`.
//! Everything users see (Gymnasium spaces, info dicts, stable-baselines3 adapters, exception
//! classes) lives in the Python package beside it; this crate converts arrays and errors and
//! releases the GIL while the physics runs. pyo3 appears nowhere else in the workspace.

use pyo3::prelude::*;

mod convert;
mod env;
mod errors;
mod policy;
mod render;
mod vector;

/// The default environment configuration as JSON (every field filled in).
#[pyfunction]
fn default_config_json() -> String {
    serde_json::to_string(&panda_rapier_core::EnvConfig::default()).unwrap_or_default()
}

/// The native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(default_config_json, m)?)?;
    m.add_class::<env::NativeEnv>()?;
    m.add_class::<env::NativeSnapshot>()?;
    m.add_class::<vector::NativeVecEnv>()?;
    m.add_class::<policy::NativeScriptedPolicy>()?;
    m.add_class::<render::NativeRenderer>()?;
    Ok(())
}
