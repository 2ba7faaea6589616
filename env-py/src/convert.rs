//! Conversions between core values and Python objects: info dicts, batched info columns,
//! reward contexts read back from Python, poses.

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use panda_rapier_core::nalgebra::{Isometry3, Quaternion, UnitQuaternion, Vector3};
use panda_rapier_core::task::{RewardContext, RewardFunction};
use panda_rapier_core::StepInfo;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::errors::{invalid, ErrorClass};

/// One info key: its name and how to read it from a [`StepInfo`].
enum InfoField {
    Flag(&'static str, fn(&StepInfo) -> bool),
    Real(&'static str, fn(&StepInfo) -> f64),
    Count(&'static str, fn(&StepInfo) -> i64),
}

/// Every key of the info dict, in order. `reward_reach`, `reward_grasp`, `reward_lift`,
/// `gripper_opening` and the three `cube_*` flags are the goal-free inputs `compute_reward` needs for the dense reward;
/// they are reported for both reward types so transitions can be relabelled either way.
const INFO_FIELDS: &[InfoField] = &[
    InfoField::Flag("is_success", |i| i.is_success),
    InfoField::Flag("is_grasped", |i| i.is_grasped),
    InfoField::Flag("is_lifted", |i| i.is_lifted),
    InfoField::Flag("is_placed", |i| i.is_placed),
    InfoField::Flag("physics_unstable", |i| i.physics_unstable),
    InfoField::Real("goal_distance", |i| i.goal_distance),
    InfoField::Real("reward_reach", |i| i.context.reach as f64),
    InfoField::Real("reward_grasp", |i| i.context.grasp as f64),
    InfoField::Real("reward_lift", |i| i.context.lift as f64),
    InfoField::Real("reward_carry", |i| i.terms.carry as f64),
    InfoField::Real("reward_place", |i| i.terms.place as f64),
    InfoField::Real("reward_release", |i| i.terms.release as f64),
    InfoField::Real("gripper_opening", |i| i.context.gripper_opening as f64),
    InfoField::Flag("cube_released", |i| i.context.cube_released),
    InfoField::Flag("cube_at_rest", |i| i.context.cube_at_rest),
    InfoField::Flag("cube_on_platform", |i| i.context.cube_on_platform),
    InfoField::Real("ik_position_error", |i| i.ik_position_error),
    InfoField::Flag("arm_blocked", |i| i.arm_blocked),
    InfoField::Count("elapsed_steps", |i| i.elapsed_steps as i64),
];

/// The info of one step as a dict of Python scalars.
pub(crate) fn info_dict<'py>(py: Python<'py>, info: &StepInfo) -> PyResult<Bound<'py, PyDict>> {
    let mut dicts = info_dicts(py, std::iter::once(info))?;
    Ok(dicts.remove(0))
}

/// The infos of a batch as one dict of Python scalars per environment. The key strings are
/// made once per call and shared by every dict (making them per dict cost more than the
/// values: about 1.4 us per dict).
pub(crate) fn info_dicts<'a, 'py>(
    py: Python<'py>,
    infos: impl Iterator<Item = &'a StepInfo>,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let keys: Vec<Bound<'py, PyString>> = INFO_FIELDS
        .iter()
        .map(|field| match field {
            InfoField::Flag(name, _) | InfoField::Real(name, _) | InfoField::Count(name, _) => {
                PyString::intern(py, name)
            }
        })
        .collect();
    infos
        .map(|info| {
            let dict = PyDict::new(py);
            for (key, field) in keys.iter().zip(INFO_FIELDS) {
                match field {
                    InfoField::Flag(_, get) => dict.set_item(key, get(info))?,
                    InfoField::Real(_, get) => dict.set_item(key, get(info))?,
                    InfoField::Count(_, get) => dict.set_item(key, get(info))?,
                }
            }
            Ok(dict)
        })
        .collect()
}

/// The infos of a batch as one numpy array per key (bool, float64 or int64).
pub(crate) fn info_columns<'py>(
    py: Python<'py>,
    infos: &[StepInfo],
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for field in INFO_FIELDS {
        match field {
            InfoField::Flag(name, get) => {
                let column: Vec<bool> = infos.iter().map(get).collect();
                dict.set_item(name, PyArray1::from_vec(py, column))?
            }
            InfoField::Real(name, get) => {
                let column: Vec<f64> = infos.iter().map(get).collect();
                dict.set_item(name, PyArray1::from_vec(py, column))?
            }
            InfoField::Count(name, get) => {
                let column: Vec<i64> = infos.iter().map(get).collect();
                dict.set_item(name, PyArray1::from_vec(py, column))?
            }
        }
    }
    Ok(dict)
}

/// The goal-free reward inputs of `n` transitions, as columns gathered from infos by the
/// Python side: `(reward_reach, reward_grasp, reward_lift, gripper_opening)` float32 and
/// `(cube_released, cube_at_rest, cube_on_platform)` bool.
pub(crate) type ContextColumns<'py> = (
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, bool>,
    PyReadonlyArray1<'py, bool>,
    PyReadonlyArray1<'py, bool>,
);

/// Batched reward through the core's [`RewardFunction`]: `achieved` and `desired` are `n x 3`
/// float32; `context` is required for the dense reward.
pub(crate) fn compute_reward<'py>(
    py: Python<'py>,
    function: &RewardFunction,
    achieved: PyReadonlyArray2<'py, f32>,
    desired: PyReadonlyArray2<'py, f32>,
    context: Option<ContextColumns<'py>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let achieved = contiguous(py, &achieved, "achieved_goal")?;
    let desired = contiguous(py, &desired, "desired_goal")?;
    let n = achieved.len() / 3;
    let contexts: Vec<RewardContext> = match context {
        None => Vec::new(),
        Some((reach, grasp, lift, opening, released, at_rest, on_platform)) => {
            let columns = [&reach, &grasp, &lift, &opening];
            let flags = [&released, &at_rest, &on_platform];
            if columns.iter().any(|c| c.as_array().len() != n)
                || flags.iter().any(|c| c.as_array().len() != n)
            {
                return Err(invalid(
                    py,
                    ErrorClass::InvalidArgument,
                    format!("info must describe {n} transitions, one per goal pair"),
                ));
            }
            let [reach, grasp, lift, opening] = columns.map(|c| c.as_array());
            let [released, at_rest, on_platform] = flags.map(|c| c.as_array());
            (0..n)
                .map(|i| RewardContext {
                    reach: reach[i],
                    grasp: grasp[i],
                    lift: lift[i],
                    cube_released: released[i],
                    cube_at_rest: at_rest[i],
                    cube_on_platform: on_platform[i],
                    gripper_opening: opening[i],
                })
                .collect()
        }
    };
    let mut rewards = vec![0.0f32; n];
    function
        .compute_batch(achieved, desired, &contexts, &mut rewards)
        .map_err(|e| crate::errors::to_py(py, e))?;
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
