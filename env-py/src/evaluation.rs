//! `Evaluation`: the seeded evaluation of `panda-rapier-policies` (its vector env, refill
//! schedule and per-episode records), driven step by step by `panda_rapier.evaluation`, which
//! supplies the actions; and `evaluate_scripted`, the Rust `evaluate` of the scripted policy.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use panda_rapier_policies::{EpisodeRecord, Evaluation, EvaluationReport};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::contiguous;
use crate::env::parse_config;
use crate::errors::{detached, invalid, to_py, ErrorClass};
use crate::sensors::{image_rows, observation_sensors};

/// An evaluation in progress (see `panda_rapier.evaluation.evaluate`).
#[pyclass(module = "panda_rapier._native", name = "Evaluation")]
pub struct NativeEvaluation {
    pub(crate) evaluation: Evaluation,
}

#[pymethods]
impl NativeEvaluation {
    #[new]
    #[pyo3(signature = (config_json, episodes, num_envs, num_threads = None, first_seed = 0))]
    fn new(
        py: Python<'_>,
        config_json: &str,
        episodes: usize,
        num_envs: usize,
        num_threads: Option<usize>,
        first_seed: u64,
    ) -> PyResult<Self> {
        let config = parse_config(py, config_json)?;
        let evaluation = detached(py, || {
            Evaluation::new(&config, episodes, num_envs, num_threads, first_seed)
        })?
        .map_err(|e| to_py(py, e))?;
        Ok(Self { evaluation })
    }

    #[getter]
    fn num_envs(&self) -> usize {
        self.evaluation.num_envs()
    }

    #[getter]
    fn num_threads(&self) -> usize {
        self.evaluation.envs().num_threads()
    }

    #[getter]
    fn episodes(&self) -> usize {
        self.evaluation.episodes()
    }

    #[getter]
    fn first_seed(&self) -> u64 {
        self.evaluation.first_seed()
    }

    #[getter]
    fn action_dim(&self) -> usize {
        self.evaluation.envs().action_dim()
    }

    #[getter]
    fn observation_dim(&self) -> usize {
        self.evaluation.envs().observation_dim()
    }

    #[getter]
    fn finished(&self) -> usize {
        self.evaluation.finished()
    }

    #[getter]
    fn done(&self) -> bool {
        self.evaluation.is_done()
    }

    #[getter]
    fn env_steps(&self) -> u64 {
        self.evaluation.env_steps()
    }

    #[getter]
    fn idle_env_steps(&self) -> u64 {
        self.evaluation.idle_env_steps()
    }

    /// The full configuration as JSON (defaults filled in).
    fn config_json(&self) -> String {
        serde_json::to_string(self.evaluation.envs().config()).unwrap_or_default()
    }

    /// Gives the environments observation cameras and touch (as `PandaVecEnv.set_cameras`).
    #[pyo3(signature = (cameras_json, touch = false))]
    fn set_cameras(&mut self, py: Python<'_>, cameras_json: &str, touch: bool) -> PyResult<()> {
        let sensors = observation_sensors(py, cameras_json, touch, self.evaluation.num_envs())?;
        let evaluation = &mut self.evaluation;
        detached(py, || evaluation.set_sensors(sensors))?.map_err(|e| to_py(py, e))
    }

    /// The cameras' images of the current observations, `num_envs x` bytes per environment.
    fn images<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        image_rows(py, self.evaluation.envs(), "current")
    }

    /// The current observations, `num_envs x observation_dim` float32 (flat layout).
    fn observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let rows = self.evaluation.observations();
        let n = self.evaluation.num_envs();
        PyArray1::from_slice(py, rows).reshape([n, rows.len() / n])
    }

    /// The episode each environment runs (`None`: idle).
    fn running(&self) -> Vec<Option<usize>> {
        self.evaluation.running().to_vec()
    }

    /// Steps every environment with its row of `actions` (float32, `num_envs x action_dim`)
    /// and records the episodes that ended; returns how many did. `refill` must follow.
    fn step(&mut self, py: Python<'_>, actions: PyReadonlyArray2<'_, f32>) -> PyResult<usize> {
        let values = contiguous(py, &actions, "actions")?;
        let (n, d) = (self.num_envs(), self.action_dim());
        if values.len() != n * d {
            return Err(invalid(
                py,
                ErrorClass::InvalidAction,
                format!(
                    "actions must have shape ({n}, {d}), got {:?}",
                    actions.as_array().shape()
                ),
            ));
        }
        let evaluation = &mut self.evaluation;
        detached(py, || evaluation.step(values))?.map_err(|e| to_py(py, e))
    }

    /// Starts the next episodes on the environments whose episode ended in the last step (or
    /// leaves them idle); returns which environments started one (bool, `num_envs`).
    fn refill<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let evaluation = &mut self.evaluation;
        detached(py, || evaluation.refill())?.map_err(|e| to_py(py, e))?;
        Ok(PyArray1::from_slice(py, self.evaluation.started()))
    }

    /// The report (a dict: `first_seed`, `num_envs`, `env_steps`, `idle_env_steps` and
    /// `episodes`, one dict per episode in episode order); `ResetNeededError` before the
    /// evaluation is done.
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let report = self.evaluation.report().ok_or_else(|| {
            invalid(
                py,
                ErrorClass::ResetNeeded,
                format!(
                    "the evaluation is not over: {} of {} episodes have ended",
                    self.evaluation.finished(),
                    self.evaluation.episodes()
                ),
            )
        })?;
        report_dict(py, &report)
    }
}

/// Runs the Rust `panda_rapier_policies::evaluate` (the scripted policy) and returns its report
/// as `Evaluation.report` does.
#[pyfunction]
#[pyo3(signature = (config_json, episodes, num_envs, num_threads = None, first_seed = 0))]
pub(crate) fn evaluate_scripted<'py>(
    py: Python<'py>,
    config_json: &str,
    episodes: usize,
    num_envs: usize,
    num_threads: Option<usize>,
    first_seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let config = parse_config(py, config_json)?;
    let report = detached(py, || {
        panda_rapier_policies::evaluate(
            &config,
            episodes,
            num_envs,
            num_threads,
            first_seed,
            |_| {},
        )
    })?
    .map_err(|e| to_py(py, e))?;
    report_dict(py, &report)
}

fn report_dict<'py>(py: Python<'py>, report: &EvaluationReport) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("first_seed", report.first_seed)?;
    dict.set_item("num_envs", report.num_envs)?;
    dict.set_item("env_steps", report.env_steps)?;
    dict.set_item("idle_env_steps", report.idle_env_steps)?;
    let episodes = report
        .episodes
        .iter()
        .map(|e| record_dict(py, e))
        .collect::<PyResult<Vec<_>>>()?;
    dict.set_item("episodes", episodes)?;
    Ok(dict)
}

/// One record, keyed as the fields of `panda_rapier.evaluation.EpisodeRecord`.
fn record_dict<'py>(py: Python<'py>, record: &EpisodeRecord) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("seed", record.seed)?;
    dict.set_item("env_index", record.env_index)?;
    dict.set_item("episode_return", record.episode_return)?;
    dict.set_item("length", record.length)?;
    dict.set_item("success", record.success)?;
    dict.set_item("placed", record.placed())?;
    dict.set_item("steps_to_success", record.steps_to_success)?;
    dict.set_item("steps_to_placed", record.steps_to_placed)?;
    dict.set_item("physics_unstable", record.physics_unstable)?;
    Ok(dict)
}

/// The statistics of `episodes` (dicts keyed as `panda_rapier.evaluation.EpisodeRecord`'s
/// fields) as a dict of `panda_rapier_policies::EvaluationSummary`'s fields: the one place
/// they are computed.
#[pyfunction]
pub(crate) fn summarize<'py>(
    py: Python<'py>,
    episodes: Vec<Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let get = |d: &Bound<'py, PyDict>, key: &str| -> PyResult<Bound<'py, PyAny>> {
        d.get_item(key)?.ok_or_else(|| {
            invalid(
                py,
                ErrorClass::InvalidArgument,
                format!("an episode record lacks {key:?}"),
            )
        })
    };
    let records = episodes
        .iter()
        .map(|d| {
            Ok(EpisodeRecord {
                seed: get(d, "seed")?.extract()?,
                env_index: get(d, "env_index")?.extract()?,
                episode_return: get(d, "episode_return")?.extract()?,
                length: get(d, "length")?.extract()?,
                success: get(d, "success")?.extract()?,
                steps_to_success: get(d, "steps_to_success")?.extract()?,
                steps_to_placed: get(d, "steps_to_placed")?.extract()?,
                physics_unstable: get(d, "physics_unstable")?.extract()?,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let s = panda_rapier_policies::evaluation::summarize(&records);
    let dict = PyDict::new(py);
    dict.set_item("episodes", s.episodes)?;
    dict.set_item("success_rate", s.success_rate)?;
    dict.set_item("success_ci95", [s.success_ci95.0, s.success_ci95.1])?;
    dict.set_item("success_once_rate", s.success_once_rate)?;
    dict.set_item(
        "success_once_ci95",
        [s.success_once_ci95.0, s.success_once_ci95.1],
    )?;
    dict.set_item("placed_rate", s.placed_rate)?;
    dict.set_item("mean_return", s.mean_return)?;
    dict.set_item("std_return", s.std_return)?;
    dict.set_item("mean_length", s.mean_length)?;
    dict.set_item("mean_steps_to_success", s.mean_steps_to_success)?;
    dict.set_item("median_steps_to_success", s.median_steps_to_success)?;
    dict.set_item("mean_steps_to_placed", s.mean_steps_to_placed)?;
    dict.set_item("physics_unstable_episodes", s.physics_unstable_episodes)?;
    Ok(dict)
}

/// The Wilson score interval of `successes` of `n` (95 % for the default `z`).
#[pyfunction]
#[pyo3(signature = (successes, n, z = 1.959964))]
pub(crate) fn wilson_interval(successes: usize, n: usize, z: f64) -> (f64, f64) {
    panda_rapier_policies::evaluation::wilson_interval(successes, n, z)
}
