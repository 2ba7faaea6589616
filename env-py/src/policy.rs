//! `ScriptedPolicy`: the scripted pick-and-place baseline of `panda-rapier-policies`,
//! acting on whole batches of flat observations in one call.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use panda_rapier_policies::ScriptedPolicy;
use pyo3::prelude::*;

use crate::convert::contiguous;
use crate::env::parse_config;
use crate::errors::{detached, invalid, to_py, ErrorClass};

/// The scripted controller for one environment configuration.
#[pyclass(module = "panda_rapier._native", name = "ScriptedPolicy")]
pub struct NativeScriptedPolicy {
    policy: ScriptedPolicy,
}

impl NativeScriptedPolicy {
    fn checked_rows<'a>(
        &self,
        py: Python<'_>,
        observations: &'a PyReadonlyArray2<'_, f32>,
    ) -> PyResult<&'a [f32]> {
        let shape = observations.as_array().shape().to_vec();
        if shape[1] != self.policy.observation_dim() {
            return Err(invalid(
                py,
                ErrorClass::InvalidArgument,
                format!(
                    "observations must have shape (n, {}), got {shape:?}",
                    self.policy.observation_dim()
                ),
            ));
        }
        contiguous(py, observations, "observations")
    }
}

#[pymethods]
impl NativeScriptedPolicy {
    #[new]
    fn new(py: Python<'_>, config_json: &str) -> PyResult<Self> {
        let config = parse_config(py, config_json)?;
        let policy = detached(py, || ScriptedPolicy::new(&config))?.map_err(|e| to_py(py, e))?;
        Ok(Self { policy })
    }

    #[getter]
    fn action_dim(&self) -> usize {
        self.policy.action_dim()
    }

    #[getter]
    fn observation_dim(&self) -> usize {
        self.policy.observation_dim()
    }

    /// Actions (`n x action_dim`, float32) for flat observations (`n x observation_dim`).
    fn act<'py>(
        &mut self,
        py: Python<'py>,
        observations: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let rows = self.checked_rows(py, &observations)?;
        let n = rows.len() / self.policy.observation_dim().max(1);
        let mut actions = vec![0.0f32; n * self.policy.action_dim()];
        let policy = &mut self.policy;
        detached(py, || policy.act_batch(rows, &mut actions))?.map_err(|e| to_py(py, e))?;
        PyArray1::from_vec(py, actions).reshape([n, self.policy.action_dim()])
    }

    /// The phase the controller recognises in each observation (`approach`, `descend`, ...).
    fn phases(
        &self,
        py: Python<'_>,
        observations: PyReadonlyArray2<'_, f32>,
    ) -> PyResult<Vec<&'static str>> {
        let rows = self.checked_rows(py, &observations)?;
        rows.chunks(self.policy.observation_dim().max(1))
            .map(|row| {
                self.policy
                    .decide(row)
                    .map(|d| d.phase.as_str())
                    .map_err(|e| to_py(py, e))
            })
            .collect()
    }
}
