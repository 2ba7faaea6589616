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
mod vector;

/// The native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<env::NativeEnv>()?;
    m.add_class::<env::NativeSnapshot>()?;
    m.add_class::<vector::NativeVecEnv>()?;
    Ok(())
}
