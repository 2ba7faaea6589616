//! Sensor observations of the vector environments: one sensor per environment (the cameras'
//! entries, then the `touch` entry when asked for), and the sensors' bytes as a numpy array.
//! Used by `vector.rs`, `evaluation.rs` and `render.rs` (`Cameras`, a single environment's).

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use panda_rapier_core::{PandaVecEnv, Sensor, SensorChain, TouchSensor};
use panda_rapier_render::Cameras;
use pyo3::prelude::*;

use crate::errors::{invalid, to_py, ErrorClass};

/// The cameras of `cameras_json` (none for `"[]"`).
pub(crate) fn parse_cameras(py: Python<'_>, cameras_json: &str) -> PyResult<Option<Cameras>> {
    if cameras_json.trim() == "[]" {
        return Ok(None);
    }
    Cameras::from_json(cameras_json)
        .map(Some)
        .map_err(|e| to_py(py, e))
}

/// One environment's observation sensor: the cameras' entries, then the touch entry if
/// `touch`; `None` for neither.
pub(crate) fn observation_sensor(
    cameras: Option<&Cameras>,
    touch: bool,
) -> Option<Box<dyn Sensor>> {
    let mut parts: Vec<Box<dyn Sensor>> = Vec::new();
    if let Some(cameras) = cameras {
        parts.push(Box::new(cameras.clone()));
    }
    if touch {
        parts.push(Box::new(TouchSensor));
    }
    match parts.len() {
        0 => None,
        1 => parts.pop(),
        _ => Some(Box::new(SensorChain(parts))),
    }
}

/// One observation sensor per environment from `cameras_json` and `touch` (none for `"[]"`
/// without touch).
pub(crate) fn observation_sensors(
    py: Python<'_>,
    cameras_json: &str,
    touch: bool,
    num_envs: usize,
) -> PyResult<Vec<Box<dyn Sensor>>> {
    let cameras = parse_cameras(py, cameras_json)?;
    Ok((0..num_envs)
        .filter_map(|_| observation_sensor(cameras.as_ref(), touch))
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
