//! `ScriptedPolicy` (the scripted experts of `panda-rapier-policies`) and `PolicyNetwork` (a
//! trained policy's CPU-independent forward pass), acting on whole batches of flat
//! observations in one call.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use panda_rapier_policies::{
    Activation, InputFeatures, NetworkWeights, OutputMap, PolicyNetwork, ScriptedPolicy,
};
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

/// A trained policy's deterministic action in a fixed-order `f64` forward pass
/// (`panda_rapier_policies::PolicyNetwork`: the same bits on every CPU).
#[pyclass(module = "panda_rapier._native", name = "PolicyNetwork", frozen)]
pub struct NativePolicyNetwork {
    network: PolicyNetwork,
}

#[pymethods]
impl NativePolicyNetwork {
    /// `layers`: `(weight, bias)` float32 arrays per layer, torch's `outputs x inputs`
    /// weights, the output layer last; `standardizer`: `(mean, scale, clip)` of the features,
    /// or `None`; `features`: `"flat"` or `"cube_orientation"` (`InputFeatures`).
    #[new]
    #[pyo3(signature = (observation_dim, layers, activation, output, low, high, standardizer=None, features="flat"))]
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn new(
        py: Python<'_>,
        observation_dim: usize,
        layers: Vec<(PyReadonlyArray2<'_, f32>, PyReadonlyArray1<'_, f32>)>,
        activation: &str,
        output: &str,
        low: PyReadonlyArray1<'_, f32>,
        high: PyReadonlyArray1<'_, f32>,
        standardizer: Option<(PyReadonlyArray1<'_, f32>, PyReadonlyArray1<'_, f32>, f32)>,
        features: &str,
    ) -> PyResult<Self> {
        let mut copied = Vec::with_capacity(layers.len());
        for (index, (weight, bias)) in layers.iter().enumerate() {
            let shape = weight.as_array().shape().to_vec();
            if shape[0] != bias.as_array().len() {
                return Err(invalid(
                    py,
                    ErrorClass::InvalidArgument,
                    format!(
                        "layer {index}: weight has {} rows but bias {} values",
                        shape[0],
                        bias.as_array().len()
                    ),
                ));
            }
            copied.push((
                contiguous(py, weight, "weight")?.to_vec(),
                contiguous(py, bias, "bias")?.to_vec(),
            ));
        }
        let standardizer = match &standardizer {
            None => None,
            Some((mean, scale, clip)) => Some((
                contiguous(py, mean, "mean")?.to_vec(),
                contiguous(py, scale, "scale")?.to_vec(),
                *clip,
            )),
        };
        let weights = NetworkWeights {
            observation_dim,
            features: InputFeatures::parse(features).map_err(|e| to_py(py, e))?,
            standardizer,
            layers: copied,
            activation: Some(Activation::parse(activation).map_err(|e| to_py(py, e))?),
            output: Some(OutputMap::parse(output).map_err(|e| to_py(py, e))?),
            low: contiguous(py, &low, "low")?.to_vec(),
            high: contiguous(py, &high, "high")?.to_vec(),
        };
        let network = PolicyNetwork::new(weights).map_err(|e| to_py(py, e))?;
        Ok(Self { network })
    }

    #[getter]
    fn action_dim(&self) -> usize {
        self.network.action_dim()
    }

    #[getter]
    fn observation_dim(&self) -> usize {
        self.network.observation_dim()
    }

    #[getter]
    fn hidden_sizes(&self) -> Vec<usize> {
        self.network.hidden_sizes()
    }

    /// Actions (`n x action_dim`, float32) for flat observations (`n x observation_dim`).
    fn act<'py>(
        &self,
        py: Python<'py>,
        observations: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let shape = observations.as_array().shape().to_vec();
        if shape[1] != self.network.observation_dim() {
            return Err(invalid(
                py,
                ErrorClass::InvalidArgument,
                format!(
                    "observations must have shape (n, {}), got {shape:?}",
                    self.network.observation_dim()
                ),
            ));
        }
        let rows = contiguous(py, &observations, "observations")?;
        let n = shape[0];
        let mut actions = vec![0.0f32; n * self.network.action_dim()];
        let network = &self.network;
        detached(py, || network.act(rows, &mut actions))?.map_err(|e| to_py(py, e))?;
        PyArray1::from_vec(py, actions).reshape([n, self.network.action_dim()])
    }
}

/// The input features `features` (`"flat"` or `"cube_orientation"`, `InputFeatures`) of flat
/// observations (`n x observation_dim`, float32, finite): `n x feature_dim`, float32, computed
/// in `f64` as `PolicyNetwork` computes them and rounded once.
#[pyfunction]
pub fn input_features<'py>(
    py: Python<'py>,
    features: &str,
    observations: PyReadonlyArray2<'py, f32>,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let kind = InputFeatures::parse(features).map_err(|e| to_py(py, e))?;
    let shape = observations.as_array().shape().to_vec();
    let (n, dim) = (shape[0], shape[1]);
    let least = kind.min_observation_dim();
    if dim < least {
        return Err(invalid(
            py,
            ErrorClass::InvalidArgument,
            format!("observations for features {features:?} need at least {least} columns, got shape {shape:?}"),
        ));
    }
    let rows = contiguous(py, &observations, "observations")?;
    if let Some(bad) = rows.iter().find(|v| !v.is_finite()) {
        return Err(invalid(
            py,
            ErrorClass::InvalidArgument,
            format!("observations must be finite, got {bad}"),
        ));
    }
    let out_dim = kind.dim(dim);
    let mut out = vec![0.0f32; n * out_dim];
    detached(py, || {
        let mut features = vec![0.0f64; out_dim];
        for (row, out) in rows.chunks_exact(dim).zip(out.chunks_exact_mut(out_dim)) {
            kind.write(row, &mut features);
            for (o, &f) in out.iter_mut().zip(&features) {
                *o = f as f32;
            }
        }
    })?;
    PyArray1::from_vec(py, out).reshape([n, out_dim])
}
