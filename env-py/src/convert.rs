//! Conversions between core values and Python objects: info dicts, batched info columns,
//! reward contexts read back from Python, poses.

use numpy::{PyArray1, PyReadonlyArray2};
use panda_rapier_core::nalgebra::{Isometry3, Quaternion, UnitQuaternion, Vector3};
use panda_rapier_core::task::{InfoField, InfoType, InfoValue, COMMON_INFO_FIELDS};
use panda_rapier_core::{Error, StepInfo};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::errors::{invalid, ErrorClass};

/// The info of one step as a dict of Python scalars.
pub(crate) fn info_dict<'py>(py: Python<'py>, info: &StepInfo) -> PyResult<Bound<'py, PyDict>> {
    let mut dicts = info_dicts(py, std::iter::once(info))?;
    Ok(dicts.remove(0))
}

/// The fields of an info: every task's, then the task's own.
fn fields_of(info: &StepInfo) -> Vec<&'static InfoField> {
    COMMON_INFO_FIELDS
        .iter()
        .chain(info.task.fields())
        .collect()
}

/// The infos of a batch (of one task) as one dict of Python scalars per environment. The key
/// strings are made once per call and shared by every dict (making them per dict cost more
/// than the values: about 1.4 us per dict).
pub(crate) fn info_dicts<'a, 'py>(
    py: Python<'py>,
    infos: impl Iterator<Item = &'a StepInfo>,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let mut keys: Vec<Bound<'py, PyString>> = Vec::new();
    infos
        .map(|info| {
            if keys.is_empty() {
                keys = fields_of(info)
                    .iter()
                    .map(|field| PyString::intern(py, field.key))
                    .collect();
            }
            let dict = PyDict::new(py);
            for (key, (_, value)) in keys.iter().zip(info.entries()) {
                match value {
                    InfoValue::Bool(v) => dict.set_item(key, v)?,
                    InfoValue::Float(v) => dict.set_item(key, v)?,
                    InfoValue::Int(v) => dict.set_item(key, v)?,
                }
            }
            Ok(dict)
        })
        .collect()
}

/// The infos of a batch (of one task) as one numpy array per key (bool, float64 or int64).
pub(crate) fn info_columns<'py>(
    py: Python<'py>,
    infos: &[StepInfo],
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    let Some(first) = infos.first() else {
        return Ok(dict);
    };
    let rows: Vec<Vec<InfoValue>> = infos
        .iter()
        .map(|info| info.entries().map(|(_, v)| v).collect())
        .collect();
    for (k, field) in fields_of(first).into_iter().enumerate() {
        let column = rows.iter().map(|row| row[k]);
        match field.dtype {
            InfoType::Bool => {
                let values = column.map(|v| matches!(v, InfoValue::Bool(true))).collect();
                dict.set_item(field.key, PyArray1::<bool>::from_vec(py, values))?
            }
            InfoType::Float => {
                let values = column
                    .map(|v| match v {
                        InfoValue::Float(x) => x,
                        _ => f64::NAN,
                    })
                    .collect();
                dict.set_item(field.key, PyArray1::<f64>::from_vec(py, values))?
            }
            InfoType::Int => {
                let values = column
                    .map(|v| match v {
                        InfoValue::Int(x) => x,
                        _ => 0,
                    })
                    .collect();
                dict.set_item(field.key, PyArray1::<i64>::from_vec(py, values))?
            }
        }
    }
    Ok(dict)
}

/// The goal-free reward inputs of `n` transitions, gathered from infos by the Python side:
/// an `n x k` float32 array of the task's `reward_context_keys` (flags as 0 or 1).
pub(crate) type ContextColumns<'py> = PyReadonlyArray2<'py, f32>;

/// Batched reward through the task's `compute_rewards`: `achieved` and `desired` are
/// `n x goal_dim` float32; `context` (`n x k`) is required for a dense reward that reads one.
pub(crate) fn compute_reward<'py>(
    py: Python<'py>,
    goal_dim: usize,
    compute: impl FnOnce(&[f32], &[f32], &[f32], &mut [f32]) -> Result<(), Error>,
    achieved: PyReadonlyArray2<'py, f32>,
    desired: PyReadonlyArray2<'py, f32>,
    context: Option<ContextColumns<'py>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let achieved = contiguous(py, &achieved, "achieved_goal")?;
    let desired = contiguous(py, &desired, "desired_goal")?;
    let n = achieved.len() / goal_dim.max(1);
    let contexts: &[f32] = match &context {
        None => &[],
        Some(rows) => {
            if rows.as_array().nrows() != n {
                return Err(invalid(
                    py,
                    ErrorClass::InvalidArgument,
                    format!("info must describe {n} transitions, one per goal pair"),
                ));
            }
            contiguous(py, rows, "reward context")?
        }
    };
    let mut rewards = vec![0.0f32; n];
    compute(achieved, desired, contexts, &mut rewards).map_err(|e| crate::errors::to_py(py, e))?;
    Ok(PyArray1::from_vec(
        py,
        rewards.into_iter().map(f64::from).collect(),
    ))
}

/// The array's data as one slice, or an `InvalidArgumentError` for strided views (the Python
/// side passes contiguous copies, so this only trips on direct use of the native module).
pub(crate) fn contiguous<'a, T: numpy::Element, D: numpy::ndarray::Dimension>(
    py: Python<'_>,
    array: &'a numpy::PyReadonlyArray<'_, T, D>,
    what: &str,
) -> PyResult<&'a [T]> {
    array.as_slice().map_err(|_| {
        invalid(
            py,
            ErrorClass::InvalidArgument,
            format!("{what} must be a C-contiguous array"),
        )
    })
}

/// A pose as `(position xyz, quaternion xyzw)`.
pub(crate) fn pose_tuple(pose: &Isometry3<f64>) -> ([f64; 3], [f64; 4]) {
    let t = pose.translation.vector;
    let q = pose.rotation.coords;
    ([t.x, t.y, t.z], [q.x, q.y, q.z, q.w])
}

/// A rotation from a quaternion given as `xyzw`, normalised; an error for a zero or non-finite one.
pub(crate) fn quaternion_xyzw(py: Python<'_>, q: [f64; 4]) -> PyResult<UnitQuaternion<f64>> {
    let quaternion = Quaternion::new(q[3], q[0], q[1], q[2]);
    let norm = quaternion.norm();
    if !norm.is_finite() || norm < 1e-9 {
        return Err(invalid(
            py,
            ErrorClass::InvalidArgument,
            format!("orientation must be a non-zero, finite quaternion (x, y, z, w), got {q:?}"),
        ));
    }
    Ok(UnitQuaternion::from_quaternion(quaternion))
}

/// A vector from three values.
pub(crate) fn vector3(v: [f64; 3]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}
