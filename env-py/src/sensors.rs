//! Image observations of the vector environments: one `Cameras` sensor per environment, and
//! the sensors' bytes as a numpy array. Used by `vector.rs` and `evaluation.rs`; depends on
//! neither (nor on `render.rs`, which draws for people).

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use panda_rapier_core::{PandaVecEnv, Sensor};
use panda_rapier_render::Cameras;
use pyo3::prelude::*;

use crate::errors::{invalid, to_py, ErrorClass};

/// One `Cameras` sensor per environment from `cameras_json` (none for `"[]"`).
pub(crate) fn camera_sensors(
    py: Python<'_>,
    cameras_json: &str,
    num_envs: usize,
) -> PyResult<Vec<Box<dyn Sensor>>> {
    if cameras_json.trim() == "[]" {
        return Ok(Vec::new());
    }
    let cameras = Cameras::from_json(cameras_json).map_err(|e| to_py(py, e))?;
    Ok((0..num_envs)
        .map(|_| Box::new(cameras.clone()) as Box<dyn Sensor>)
        .collect())
}

/// A vector env's sensor bytes (`which`: `"current"` or `"final"` observations),
/// `num_envs x` bytes per environment.
pub(crate) fn image_rows<'py>(
    py: Python<'py>,
    vec: &PandaVecEnv,
    which: &str,
) -> PyResult<Bound<'py, PyArray2<u8>>> {
    let mut out = vec![0; vec.num_envs() * vec.sensor_len()];
    let copied = match which {
        "current" => vec.sensor_data(&mut out),
        "final" => vec.final_sensor_data(&mut out),
        other => {
            return Err(invalid(
                py,
                ErrorClass::InvalidArgument,
                format!("which must be 'current' or 'final', got {other:?}"),
            ))
        }
    };
    copied.map_err(|e| to_py(py, e))?;
    PyArray1::from_vec(py, out).reshape([vec.num_envs(), vec.sensor_len()])
}
