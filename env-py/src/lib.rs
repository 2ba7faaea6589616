//! # panda-rapier-py
//!
//! The native module `panda_rapier._native`: thin pyo3 wrappers around `panda-rapier-core`.
//! Everything users see (Gymnasium spaces, info dicts, stable-baselines3 adapters) lives in the
//! Python package beside it, except the exception classes, which are created here (so core errors
//! become them without importing Python code) and re-exported by `panda_rapier.errors`. This
//! crate converts arrays and errors and releases the GIL while the physics runs. pyo3 appears
//! nowhere else in the workspace.

use pyo3::prelude::*;

mod convert;
mod env;
mod error_class;
mod errors;
mod evaluation;
mod policy;
mod render;
mod sensors;
mod vector;

/// The default environment configuration as JSON (every field filled in).
#[pyfunction]
fn default_config_json() -> String {
    serde_json::to_string(&panda_rapier_core::EnvConfig::default().resolved()).unwrap_or_default()
}

/// Every registered task's static facts, in the registry's order: dicts of `name`,
/// `id_stem`, `episode_steps`, `has_platform`, `has_placed` (an `is_placed` predicate),
/// `ee_control_mode` (`ee`, or `ee_pose` for a task whose end-effector ids turn the hand),
/// `summary`, `defaults` (the task section's default fields as JSON) and `reward_terms`
/// (dicts of `name`, `info_key`, `default_weight`, `description`).
/// `panda_rapier.registration` builds the Gymnasium ids from it.
#[pyfunction]
fn tasks(py: Python<'_>) -> PyResult<Vec<Bound<'_, pyo3::types::PyDict>>> {
    use panda_rapier_core::task::{TaskConfig, TaskKind};
    TaskKind::ALL
        .iter()
        .map(|&kind| {
            let d = kind.descriptor();
            let dict = pyo3::types::PyDict::new(py);
            dict.set_item("name", d.name)?;
            dict.set_item("id_stem", d.id_stem)?;
            dict.set_item("episode_steps", d.episode_steps)?;
            dict.set_item("joint_step", kind.id_joint_step())?;
            dict.set_item(
                "ee_control_mode",
                if kind.id_pose_actions() {
                    "ee_pose"
                } else {
                    "ee"
                },
            )?;
            dict.set_item("has_platform", d.has_platform)?;
            dict.set_item("has_placed", d.has_placed())?;
            dict.set_item("summary", d.summary)?;
            let terms = d
                .reward_terms
                .iter()
                .map(|t| {
                    let term = pyo3::types::PyDict::new(py);
                    term.set_item("name", t.name)?;
                    term.set_item("info_key", t.info_key)?;
                    term.set_item("default_weight", t.default_weight)?;
                    term.set_item("description", t.description)?;
                    Ok(term)
                })
                .collect::<PyResult<Vec<_>>>()?;
            dict.set_item("reward_terms", terms)?;
            let defaults = serde_json::to_string(&TaskConfig::defaults(kind)).unwrap_or_default();
            dict.set_item("defaults", defaults)?;
            Ok(dict)
        })
        .collect()
}

/// The observation and info schema of the environments `config_json` builds: the one
/// definition (in the core) that Python builds its spaces, dict splitting and reward contexts
/// from. Keys: `task`, `goal_dim`, `flat_dim`, `action_dim`, `observation` (a list of slots:
/// `name`, `key` of the goal dict it belongs to, `start`, `stop` in the flat vector,
/// `description`, `source`: `goal`, `robot` or `task`, whose state it reports), `info` (a list of `key`, `dtype`, `description`) and
/// `reward_context_keys` (the info keys `compute_reward` reads, in order).
#[pyfunction]
fn schema<'py>(py: Python<'py>, config_json: &str) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    use panda_rapier_core::task::{ObservationLayout, COMMON_INFO_FIELDS};
    use pyo3::types::PyDict;
    let config = env::parse_config(py, config_json)?;
    let (layout, action_dim) = errors::detached(py, || -> panda_rapier_core::Result<_> {
        let layout = ObservationLayout::for_config(&config)?;
        let robot = panda_rapier_core::RobotSpec::new(&config.sim_config()?)?;
        let action_dim = panda_rapier_core::Controller::action_dim(config.control_mode, &robot);
        Ok((layout, action_dim))
    })?
    .map_err(|e| errors::to_py(py, e))?;
    let dict = PyDict::new(py);
    dict.set_item("task", config.task.kind().as_str())?;
    dict.set_item("goal_dim", layout.goal_dim())?;
    dict.set_item("flat_dim", layout.flat_dim())?;
    dict.set_item("action_dim", action_dim)?;
    let slots = layout
        .slots()
        .iter()
        .map(|slot| {
            let d = PyDict::new(py);
            d.set_item("name", slot.name)?;
            d.set_item("key", slot.key)?;
            d.set_item("start", slot.range.start)?;
            d.set_item("stop", slot.range.end)?;
            d.set_item("description", slot.description)?;
            d.set_item("source", slot.source.as_str())?;
            Ok(d)
        })
        .collect::<PyResult<Vec<_>>>()?;
    dict.set_item("observation", slots)?;
    let descriptor = config.task.kind().descriptor();
    let info = COMMON_INFO_FIELDS
        .iter()
        .chain(descriptor.info_fields)
        .map(|field| {
            let d = PyDict::new(py);
            d.set_item("key", field.key)?;
            d.set_item("dtype", field.dtype.as_str())?;
            d.set_item("description", field.description)?;
            Ok(d)
        })
        .collect::<PyResult<Vec<_>>>()?;
    dict.set_item("info", info)?;
    dict.set_item(
        "reward_context_keys",
        descriptor.reward_context_keys.to_vec(),
    )?;
    Ok(dict)
}

/// Runs the classic tutorial's pick-and-place sequence on a bare simulation of `config_json`
/// and returns what the physics did: the accuracy side of a benchmark (grasp slip, tracking
/// error, placement).
#[pyfunction]
fn tutorial_fidelity<'py>(
    py: Python<'py>,
    config_json: &str,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    use panda_rapier_policies::tutorial::{run, TutorialSequence};
    let config = env::parse_config(py, config_json)?;
    let report = errors::detached(py, || {
        let mut sim = panda_rapier_core::Simulation::new(config.sim_config()?)?;
        let plan = TutorialSequence::for_scene(&sim);
        run(&mut sim, &plan)
    })?
    .map_err(|e| errors::to_py(py, e))?;
    let dict = pyo3::types::PyDict::new(py);
    dict.set_item("lift_m", report.lift)?;
    dict.set_item("carry_distance_m", report.carry_distance)?;
    dict.set_item("carry_slip_mm", report.carry_slip * 1e3)?;
    dict.set_item("carry_slip_deg", report.carry_slip_angle.to_degrees())?;
    dict.set_item("max_slip_mm", report.max_slip * 1e3)?;
    dict.set_item("max_slip_deg", report.max_slip_angle.to_degrees())?;
    dict.set_item("max_tracking_error_mm", report.max_tracking_error * 1e3)?;
    dict.set_item("placement_error_mm", report.placement_error * 1e3)?;
    dict.set_item("on_platform", report.on_platform)?;
    dict.set_item("non_finite_seen", report.non_finite_seen)?;
    Ok(dict)
}

/// The native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::add_classes(m)?;
    m.add_function(wrap_pyfunction!(default_config_json, m)?)?;
    m.add_function(wrap_pyfunction!(schema, m)?)?;
    m.add_function(wrap_pyfunction!(tasks, m)?)?;
    m.add_function(wrap_pyfunction!(tutorial_fidelity, m)?)?;
    m.add_function(wrap_pyfunction!(evaluation::evaluate_scripted, m)?)?;
    m.add_function(wrap_pyfunction!(evaluation::summarize, m)?)?;
    m.add_function(wrap_pyfunction!(evaluation::wilson_interval, m)?)?;
    m.add_class::<env::NativeEnv>()?;
    m.add_class::<env::NativeSnapshot>()?;
    m.add_class::<vector::NativeVecEnv>()?;
    m.add_class::<policy::NativeScriptedPolicy>()?;
    m.add_function(wrap_pyfunction!(policy::input_features, m)?)?;
    m.add_class::<policy::NativePolicyNetwork>()?;
    m.add_class::<evaluation::NativeEvaluation>()?;
    m.add_class::<render::NativeRenderer>()?;
    m.add_class::<render::NativeCameras>()?;
    render::add_defaults(m)?;
    // The policy networks' input features: name -> entries beyond the flat observation's.
    m.add(
        "INPUT_FEATURES",
        panda_rapier_policies::InputFeatures::ALL
            .iter()
            .map(|f| (f.name(), f.extra_entries()))
            .collect::<std::collections::BTreeMap<_, _>>(),
    )?;
    // The `touch` observation entry's layout: (name, start, count) of each part.
    m.add(
        "TOUCH_LAYOUT",
        panda_rapier_core::TouchReading::LAYOUT.to_vec(),
    )?;
    Ok(())
}
