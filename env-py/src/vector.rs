//! `PandaVecEnv`: the core [`PandaVecEnv`] (a rayon pool stepping N environments) with batched
//! numpy outputs, for the Gymnasium vector env and the stable-baselines3 `PandaVecEnv`.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use panda_rapier_core::{AutoresetMode, PandaVecEnv};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{compute_reward, contiguous, info_columns, info_dicts, ContextColumns};
use crate::env::parse_config;
use crate::errors::{detached, invalid, to_py, ErrorClass};
use crate::sensors::{image_rows, observation_sensors};

/// N environments stepped in parallel.
#[pyclass(module = "panda_rapier._native", name = "PandaVecEnv")]
pub struct NativeVecEnv {
    pub(crate) vec: PandaVecEnv,
    actions: Vec<f32>,
}

impl NativeVecEnv {
    fn rows<'py, T: numpy::Element + Copy>(
        &self,
        py: Python<'py>,
        values: &[T],
    ) -> PyResult<Bound<'py, PyArray2<T>>> {
        let n = self.vec.num_envs();
        PyArray1::from_slice(py, values).reshape([n, values.len() / n])
    }
}

#[pymethods]
impl NativeVecEnv {
    #[new]
    #[pyo3(signature = (config_json, num_envs, num_threads = None, autoreset_mode = "next_step"))]
    fn new(
        py: Python<'_>,
        config_json: &str,
        num_envs: usize,
        num_threads: Option<usize>,
        autoreset_mode: &str,
    ) -> PyResult<Self> {
        let config = parse_config(py, config_json)?;
        let mode = match autoreset_mode {
            "next_step" => AutoresetMode::NextStep,
            "same_step" => AutoresetMode::SameStep,
            "disabled" => AutoresetMode::Disabled,
            other => {
                return Err(invalid(
                    py,
                    ErrorClass::Config,
                    format!(
                    "autoreset_mode must be 'next_step', 'same_step' or 'disabled', got {other:?}"
                ),
                ))
            }
        };
        let vec = detached(py, || PandaVecEnv::new(config, num_envs, num_threads, mode))?
            .map_err(|e| to_py(py, e))?;
        let actions = vec![0.0; num_envs * vec.action_dim()];
        Ok(Self { vec, actions })
    }

    #[getter]
    fn num_envs(&self) -> usize {
        self.vec.num_envs()
    }

    #[getter]
    fn num_threads(&self) -> usize {
        self.vec.num_threads()
    }

    #[getter]
    fn autoreset_mode(&self) -> &'static str {
        self.vec.autoreset_mode().as_str()
    }

    #[getter]
    fn action_dim(&self) -> usize {
        self.vec.action_dim()
    }

    #[getter]
    fn observation_dim(&self) -> usize {
        self.vec.observation_dim()
    }

    /// Control period (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.vec.env(0).map(|e| e.dt()).unwrap_or_default()
    }

    /// The full configuration as JSON (defaults filled in).
    fn config_json(&self) -> String {
        serde_json::to_string(&self.vec.config().resolved()).unwrap_or_default()
    }

    /// Resets the environments where `mask` is true (all without a mask); `seeds` has one
    /// optional seed per environment. Returns all observations, `num_envs x observation_dim`.
    #[pyo3(signature = (seeds = None, mask = None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seeds: Option<Vec<Option<u64>>>,
        mask: Option<PyReadonlyArray1<'py, bool>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let n = self.vec.num_envs();
        let mask: Vec<bool> = match &mask {
            Some(m) => contiguous(py, m, "reset mask")?.to_vec(),
            None => vec![true; n],
        };
        let seeds = seeds.unwrap_or_default();
        let vec = &mut self.vec;
        detached(py, || vec.reset_masked(&mask, &seeds))?.map_err(|e| to_py(py, e))?;
        self.rows(py, self.vec.observations())
    }

    /// Steps every environment with its row of `actions` (float32, `num_envs x action_dim`);
    /// returns observations, rewards (float64), terminated, truncated.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
    )> {
        let values = contiguous(py, &actions, "actions")?;
        if values.len() != self.actions.len() {
            return Err(invalid(
                py,
                ErrorClass::InvalidAction,
                format!(
                    "actions must have shape ({}, {}), got {:?}",
                    self.vec.num_envs(),
                    self.vec.action_dim(),
                    actions.as_array().shape()
                ),
            ));
        }
        self.actions.copy_from_slice(values);
        let Self { vec, actions } = self;
        detached(py, || vec.step(actions))?.map_err(|e| to_py(py, e))?;
        let rewards: Vec<f64> = self.vec.rewards().iter().map(|&r| f64::from(r)).collect();
        Ok((
            self.rows(py, self.vec.observations())?,
            PyArray1::from_vec(py, rewards),
            PyArray1::from_slice(py, self.vec.terminated()),
            PyArray1::from_slice(py, self.vec.truncated()),
        ))
    }

    /// Gives every environment the observation cameras of `cameras_json` (a JSON list of
    /// `{"key": ..., "render": {...}}`; `"[]"` removes them) and, with `touch`, the `touch`
    /// entry after them: drawn and read on the environments' threads after every step and
    /// reset, see `images`.
    #[pyo3(signature = (cameras_json, touch = false))]
    fn set_cameras(&mut self, py: Python<'_>, cameras_json: &str, touch: bool) -> PyResult<()> {
        let sensors = observation_sensors(py, cameras_json, touch, self.vec.num_envs())?;
        let vec = &mut self.vec;
        detached(py, || vec.set_sensors(sensors))?.map_err(|e| to_py(py, e))
    }

    /// The cameras' images of the current observations (`which="final"`: of the final
    /// observations), `num_envs x` bytes per environment (all cameras in order).
    #[pyo3(signature = (which = "current"))]
    fn images<'py>(&self, py: Python<'py>, which: &str) -> PyResult<Bound<'py, PyArray2<u8>>> {
        image_rows(py, &self.vec, which)
    }

    /// Last observations of the episodes that ended in the last step (same-step autoreset;
    /// rows without one hold stale values: see `has_final_observation`).
    fn final_observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        self.rows(py, self.vec.final_observations())
    }

    /// Which rows of `final_observations` are valid.
    fn has_final_observation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        PyArray1::from_slice(py, self.vec.has_final_observation())
    }

    /// Which rows the last call reset instead of stepping (next-step autoreset, masked reset).
    fn was_reset<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        PyArray1::from_slice(py, self.vec.was_reset())
    }

    /// The infos of the last step (or, with `which="reset"`, of the first step of the episodes
    /// a same-step autoreset started), one numpy array per key.
    #[pyo3(signature = (which = "step"))]
    fn infos<'py>(&self, py: Python<'py>, which: &str) -> PyResult<Bound<'py, PyDict>> {
        let n = self.vec.num_envs();
        match which {
            "step" => info_columns(py, &self.vec.infos().copied().collect::<Vec<_>>()),
            "reset" => {
                let infos: Vec<_> = (0..n)
                    .filter_map(|i| self.vec.reset_info(i).ok().copied())
                    .collect();
                info_columns(py, &infos)
            }
            other => Err(invalid(
                py,
                ErrorClass::InvalidArgument,
                format!("which must be 'step' or 'reset', got {other:?}"),
            )),
        }
    }

    /// The same infos as `infos`, as one dict of Python scalars per environment (the form
    /// stable-baselines3's `VecEnv.step` returns), built here rather than from the columns.
    #[pyo3(signature = (which = "step"))]
    fn info_rows<'py>(&self, py: Python<'py>, which: &str) -> PyResult<Vec<Bound<'py, PyDict>>> {
        match which {
            "step" => info_dicts(py, self.vec.infos()),
            "reset" => info_dicts(
                py,
                (0..self.vec.num_envs()).filter_map(|i| self.vec.reset_info(i).ok()),
            ),
            other => Err(invalid(
                py,
                ErrorClass::InvalidArgument,
                format!("which must be 'step' or 'reset', got {other:?}"),
            )),
        }
    }

    /// Batched reward (see `panda_rapier.PandaEnv.compute_reward`).
    #[pyo3(signature = (achieved_goal, desired_goal, context = None))]
    fn compute_reward<'py>(
        &self,
        py: Python<'py>,
        achieved_goal: PyReadonlyArray2<'py, f32>,
        desired_goal: PyReadonlyArray2<'py, f32>,
        context: Option<ContextColumns<'py>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        compute_reward(
            py,
            self.vec.layout().goal_dim(),
            |a, d, c, out| self.vec.compute_rewards(a, d, c, out),
            achieved_goal,
            desired_goal,
            context,
        )
    }
}
