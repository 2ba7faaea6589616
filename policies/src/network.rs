//! [`PolicyNetwork`]: the deterministic action of a trained multilayer-perceptron policy,
//! computed the same way, bit for bit, on every CPU.
//!
//! A trained policy evaluated by torch in float32 gives different bits on different CPUs:
//! torch picks its matrix kernels by the vector width the CPU offers (AVX-512, AVX2, or none)
//! and each sums in its own order, so an action near a decision boundary of the episode (grasp
//! now or one step later) can change an episode's outcome on another machine. This forward
//! pass fixes the arithmetic instead:
//!
//! - everything in `f64` (the `f32` weights and observations convert exactly);
//! - every dot product summed in one order, `((b + w0 x0) + w1 x1) + ...`, with separate
//!   multiplies and adds (Rust never contracts them into fused multiply-adds, whatever the
//!   CPU has); the loops run across output neurons, so the compiler may vectorise them without
//!   changing any lane's order of operations;
//! - `tanh` from the `libm` crate (a portable software implementation) rather than the
//!   platform's maths library, whose routines are chosen per CPU.
//!
//! The result is rounded to `f32` once, at the end. Hand-written rather than a BLAS crate on
//! purpose: the BLAS kernels (matrixmultiply, OpenBLAS, MKL) choose their summation order by
//! the CPU at run time, which is exactly what this module exists to avoid. The networks are
//! small (three hidden layers of 256), so the loops cost well under a millisecond per batch of
//! 32 observations, next to about 15 ms for the environments' step.

use panda_rapier_core::{Error, Result};

use crate::features::InputFeatures;

/// The nonlinearity between hidden layers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Activation {
    /// `max(0, x)`.
    Relu,
    /// `tanh(x)` (portable `libm`).
    Tanh,
}

impl Activation {
    /// Parses `"relu"` or `"tanh"`.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "relu" => Ok(Self::Relu),
            "tanh" => Ok(Self::Tanh),
            other => Err(invalid(
                "activation",
                format!("must be \"relu\" or \"tanh\", got {other:?}"),
            )),
        }
    }

    fn apply(self, values: &mut [f64]) {
        match self {
            Self::Relu => values.iter_mut().for_each(|v| *v = v.max(0.0)),
            Self::Tanh => values.iter_mut().for_each(|v| *v = libm::tanh(*v)),
        }
    }
}

/// How the last layer's output becomes an action in `[low, high]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputMap {
    /// Clipped to `[low, high]` (stable-baselines3's PPO and A2C: a Gaussian's mean).
    Clip,
    /// `low + (tanh(x) + 1) / 2 (high - low)` (SAC, TQC: a squashed Gaussian's mean; TD3's
    /// tanh output layer).
    Squash,
}

impl OutputMap {
    /// Parses `"clip"` or `"squash"`.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "clip" => Ok(Self::Clip),
            "squash" => Ok(Self::Squash),
            other => Err(invalid(
                "output",
                format!("must be \"clip\" or \"squash\", got {other:?}"),
            )),
        }
    }
}

/// One fully connected layer, `y = W x + b`, with `W` stored input-major (row `k` holds the
/// weights of input `k` to every output) so that the inner loop runs over outputs.
#[derive(Clone, Debug)]
struct Dense {
    inputs: usize,
    outputs: usize,
    /// `inputs x outputs`, input-major.
    weights: Vec<f64>,
    bias: Vec<f64>,
}

impl Dense {
    /// From a torch `Linear`'s `weight` (`outputs x inputs`, row-major) and `bias`.
    fn from_torch(index: usize, weight: &[f32], bias: &[f32], inputs: usize) -> Result<Self> {
        let outputs = bias.len();
        let what = format!("layer {index}");
        if outputs == 0 || weight.len() != outputs * inputs {
            return Err(Error::WrongLength {
                what: format!("{what} weight ({outputs} x {inputs})"),
                expected: outputs * inputs,
                got: weight.len(),
            });
        }
        finite(&what, weight)?;
        finite(&what, bias)?;
        let mut weights = vec![0.0; inputs * outputs];
        for o in 0..outputs {
            for k in 0..inputs {
                weights[k * outputs + o] = f64::from(weight[o * inputs + k]);
            }
        }
        Ok(Self {
            inputs,
            outputs,
            weights,
            bias: bias.iter().map(|&b| f64::from(b)).collect(),
        })
    }

    /// `out[r] = W x[r] + b` for every row `r` of a block (rows share each weight row while it
    /// is in cache; each sum's order is the same whatever the block size).
    fn forward(&self, x: &[f64], out: &mut [f64]) {
        let rows = x.len() / self.inputs;
        for r in 0..rows {
            out[r * self.outputs..(r + 1) * self.outputs].copy_from_slice(&self.bias);
        }
        for (k, w) in self.weights.chunks_exact(self.outputs).enumerate() {
            for r in 0..rows {
                let xk = x[r * self.inputs + k];
                let y = &mut out[r * self.outputs..(r + 1) * self.outputs];
                for (y, &w) in y.iter_mut().zip(w) {
                    *y += w * xk;
                }
            }
        }
    }
}

/// Observation standardisation inside the network (`panda_rapier.normalization.
/// NormalizedFlatten`): `clamp((x - mean) / scale, -clip, clip)`.
#[derive(Clone, Debug)]
struct Standardizer {
    mean: Vec<f64>,
    scale: Vec<f64>,
    clip: f64,
}

/// A trained policy's deterministic action: its input features ([`InputFeatures`]), optional
/// standardisation, hidden layers with one activation, an output layer and the map onto the action bounds. Built from a torch model's
/// weights (the Python package's `panda_rapier.inference` reads them from a saved model);
/// [`Self::act`] gives the same bits on every CPU (module docs).
#[derive(Clone, Debug)]
pub struct PolicyNetwork {
    observation_dim: usize,
    features: InputFeatures,
    feature_dim: usize,
    standardizer: Option<Standardizer>,
    hidden: Vec<Dense>,
    activation: Activation,
    head: Dense,
    output: OutputMap,
    low: Vec<f64>,
    high: Vec<f64>,
}

/// Rows evaluated together, sharing each weight row.
const BLOCK: usize = 8;

/// The parts of a [`PolicyNetwork`], as a saved torch model holds them (`f32`).
#[derive(Clone, Debug, Default)]
pub struct NetworkWeights {
    /// Length of a flat observation.
    pub observation_dim: usize,
    /// What the network computes from a flat observation first (the flat observation itself
    /// by default).
    pub features: InputFeatures,
    /// `(mean, scale, clip)` of the standardisation of the features, if the network has one.
    pub standardizer: Option<(Vec<f32>, Vec<f32>, f32)>,
    /// `(weight, bias)` of every layer in order, the output layer last; `weight` is torch's
    /// `outputs x inputs`, row-major.
    pub layers: Vec<(Vec<f32>, Vec<f32>)>,
    /// Between the hidden layers (and after the last hidden one).
    pub activation: Option<Activation>,
    /// How the output layer's values become actions.
    pub output: Option<OutputMap>,
    /// Action bounds, one per action dimension.
    pub low: Vec<f32>,
    /// Action bounds, one per action dimension.
    pub high: Vec<f32>,
}

impl PolicyNetwork {
    /// Checks the shapes (each layer's inputs are the previous one's outputs, bounds as long as
    /// the output, `low < high`) and that every number is finite.
    pub fn new(weights: NetworkWeights) -> Result<Self> {
        let NetworkWeights {
            observation_dim,
            features,
            standardizer,
            layers,
            activation,
            output,
            low,
            high,
        } = weights;
        let least = features.min_observation_dim();
        if observation_dim < least {
            return Err(invalid(
                "observation_dim",
                format!(
                    "must be at least {least} for features {features:?}, got {observation_dim}"
                ),
            ));
        }
        let feature_dim = features.dim(observation_dim);
        let standardizer = match standardizer {
            None => None,
            Some((mean, scale, clip)) => {
                for (name, values) in [("mean", &mean), ("scale", &scale)] {
                    if values.len() != feature_dim {
                        return Err(Error::WrongLength {
                            what: format!("standardizer {name}"),
                            expected: feature_dim,
                            got: values.len(),
                        });
                    }
                    finite(name, values)?;
                }
                if scale.iter().any(|&s| s <= 0.0) {
                    return Err(invalid("standardizer scale", "must be positive".into()));
                }
                if clip.is_nan() || clip <= 0.0 || clip.is_infinite() {
                    return Err(invalid(
                        "standardizer clip",
                        format!("must be > 0, got {clip}"),
                    ));
                }
                Some(Standardizer {
                    mean: mean.iter().map(|&v| f64::from(v)).collect(),
                    scale: scale.iter().map(|&v| f64::from(v)).collect(),
                    clip: f64::from(clip),
                })
            }
        };
        let Some(((head_weight, head_bias), hidden_layers)) = layers.split_last() else {
            return Err(invalid(
                "layers",
                "must hold at least the output layer".into(),
            ));
        };
        let mut inputs = feature_dim;
        let mut hidden = Vec::with_capacity(hidden_layers.len());
        for (index, (weight, bias)) in hidden_layers.iter().enumerate() {
            let layer = Dense::from_torch(index, weight, bias, inputs)?;
            inputs = layer.outputs;
            hidden.push(layer);
        }
        let head = Dense::from_torch(hidden_layers.len(), head_weight, head_bias, inputs)?;
        for (name, bound) in [("low", &low), ("high", &high)] {
            if bound.len() != head.outputs {
                return Err(Error::WrongLength {
                    what: format!("action bound {name}"),
                    expected: head.outputs,
                    got: bound.len(),
                });
            }
            finite(name, bound)?;
        }
        if low.iter().zip(&high).any(|(l, h)| l >= h) {
            return Err(invalid("action bounds", "need low < high".into()));
        }
        Ok(Self {
            observation_dim,
            features,
            feature_dim,
            standardizer,
            hidden,
            activation: activation.unwrap_or(Activation::Relu),
            head,
            output: output.unwrap_or(OutputMap::Clip),
            low: low.iter().map(|&v| f64::from(v)).collect(),
            high: high.iter().map(|&v| f64::from(v)).collect(),
        })
    }

    /// Length of a flat observation row.
    pub fn observation_dim(&self) -> usize {
        self.observation_dim
    }

    /// Length of an action row.
    pub fn action_dim(&self) -> usize {
        self.head.outputs
    }

    /// Widths of the hidden layers.
    pub fn hidden_sizes(&self) -> Vec<usize> {
        self.hidden.iter().map(|l| l.outputs).collect()
    }

    /// Deterministic actions (`n x action_dim`) for flat observations (`n x
    /// observation_dim`); observations must be finite. Rows are independent: a row's action
    /// does not depend on the other rows, the batch size or the number of threads.
    pub fn act(&self, observations: &[f32], actions: &mut [f32]) -> Result<()> {
        let n = observations.len() / self.observation_dim;
        if observations.len() != n * self.observation_dim {
            return Err(Error::WrongLength {
                what: "observations (n x observation_dim)".into(),
                expected: (n + 1) * self.observation_dim,
                got: observations.len(),
            });
        }
        if actions.len() != n * self.action_dim() {
            return Err(Error::WrongLength {
                what: "actions (n x action_dim)".into(),
                expected: n * self.action_dim(),
                got: actions.len(),
            });
        }
        finite("observations", observations)?;
        let widest = self
            .hidden
            .iter()
            .map(|l| l.outputs)
            .chain([self.feature_dim, self.head.outputs])
            .max()
            .unwrap_or(1);
        let mut a = vec![0.0; BLOCK * widest];
        let mut b = vec![0.0; BLOCK * widest];
        for (obs, act) in observations
            .chunks(BLOCK * self.observation_dim)
            .zip(actions.chunks_mut(BLOCK * self.action_dim()))
        {
            self.act_block(obs, act, &mut a, &mut b);
        }
        Ok(())
    }

    fn act_block(&self, observations: &[f32], actions: &mut [f32], a: &mut [f64], b: &mut [f64]) {
        let rows = observations.len() / self.observation_dim;
        let x = &mut a[..rows * self.feature_dim];
        for (obs, x) in observations
            .chunks_exact(self.observation_dim)
            .zip(x.chunks_exact_mut(self.feature_dim))
        {
            self.features.write(obs, x);
        }
        if let Some(s) = &self.standardizer {
            for row in x.chunks_exact_mut(self.feature_dim) {
                for ((v, m), sc) in row.iter_mut().zip(&s.mean).zip(&s.scale) {
                    *v = ((*v - m) / sc).clamp(-s.clip, s.clip);
                }
            }
        }
        let (mut input, mut output) = (a, b);
        for layer in &self.hidden {
            let y = &mut output[..rows * layer.outputs];
            layer.forward(&input[..rows * layer.inputs], y);
            self.activation.apply(y);
            std::mem::swap(&mut input, &mut output);
        }
        let y = &mut output[..rows * self.head.outputs];
        self.head.forward(&input[..rows * self.head.inputs], y);
        for (row, act) in y
            .chunks_exact(self.head.outputs)
            .zip(actions.chunks_exact_mut(self.head.outputs))
        {
            for (((value, action), low), high) in row.iter().zip(act).zip(&self.low).zip(&self.high)
            {
                let mapped = match self.output {
                    OutputMap::Clip => value.clamp(*low, *high),
                    OutputMap::Squash => low + 0.5 * (libm::tanh(*value) + 1.0) * (high - low),
                };
                *action = mapped as f32;
            }
        }
    }
}

fn invalid(field: &str, reason: String) -> Error {
    Error::InvalidConfig {
        field: field.to_string(),
        reason,
    }
}

fn finite(what: &str, values: &[f32]) -> Result<()> {
    match values.iter().find(|v| !v.is_finite()) {
        None => Ok(()),
        Some(&value) => Err(Error::NonFinite {
            what: what.to_string(),
            value: f64::from(value),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny(output: OutputMap) -> PolicyNetwork {
        PolicyNetwork::new(NetworkWeights {
            observation_dim: 2,
            features: InputFeatures::Flat,
            standardizer: Some((vec![1.0, 0.0], vec![2.0, 0.5], 10.0)),
            layers: vec![
                (vec![1.0, -1.0, 0.5, 0.25, -2.0, 1.0], vec![0.0, 0.1, 0.0]),
                (vec![1.0, 1.0, 1.0, -1.0, 0.0, 3.0], vec![0.5, -0.5]),
            ],
            activation: Some(Activation::Relu),
            output: Some(output),
            low: vec![-1.0, -1.0],
            high: vec![1.0, 1.0],
        })
        .unwrap()
    }

    #[test]
    fn computes_the_layers_by_hand() {
        let net = tiny(OutputMap::Clip);
        let mut action = [0.0f32; 2];
        net.act(&[3.0, 0.5], &mut action).unwrap();
        // standardised: (1, 1); hidden: relu(0, 0.85, -1) = (0, 0.85, 0);
        // out: (0.5 + 0.85, -0.5 + 0) -> clipped (1, -0.5).
        assert_eq!(action, [1.0, -0.5]);
        let net = tiny(OutputMap::Squash);
        net.act(&[3.0, 0.5], &mut action).unwrap();
        assert_eq!(action[1], libm::tanh(-0.5) as f32);
    }

    #[test]
    fn rows_do_not_depend_on_the_batch() {
        let net = tiny(OutputMap::Clip);
        let rows: Vec<f32> = (0..38).map(|i| (i as f32 * 0.37).sin() * 3.0).collect();
        let mut together = vec![0.0f32; 38];
        net.act(&rows, &mut together).unwrap();
        for (row, expected) in rows.chunks(2).zip(together.chunks(2)) {
            let mut alone = [0.0f32; 2];
            net.act(row, &mut alone).unwrap();
            assert_eq!(alone, expected);
        }
    }

    #[test]
    fn cube_orientation_features_come_before_the_layers() {
        // One output reading the features' first entry (D's corner), one the row's last entry.
        let observation_dim = 10;
        let feature_dim = InputFeatures::CubeOrientation.dim(observation_dim);
        assert_eq!(feature_dim, 26);
        let mut weight = vec![0.0; 2 * feature_dim];
        weight[0] = 1.0;
        weight[2 * feature_dim - 1] = 1.0;
        let net = PolicyNetwork::new(NetworkWeights {
            observation_dim,
            features: InputFeatures::CubeOrientation,
            layers: vec![(weight, vec![0.0, 0.0])],
            low: vec![-10.0; 2],
            high: vec![10.0; 2],
            ..Default::default()
        })
        .unwrap();
        assert_eq!(net.observation_dim(), 10);
        // The cube a quarter turn about z, the goal unturned: D = Rz(-90 deg), D[0][0] = 0.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let row = [0.0, 0.0, h, h, 0.0, 0.0, 0.0, 1.0, 0.0, 0.75];
        let mut action = [0.0f32; 2];
        net.act(&row, &mut action).unwrap();
        assert!(action[0].abs() < 1e-6, "{action:?}");
        assert_eq!(action[1], 0.75);
        // Too short a row for the goals, and a standardizer of the flat length, are refused.
        let short = NetworkWeights {
            observation_dim: 8,
            features: InputFeatures::CubeOrientation,
            layers: vec![(vec![0.0; 48], vec![0.0, 0.0])],
            low: vec![-1.0; 2],
            high: vec![1.0; 2],
            ..Default::default()
        };
        assert!(PolicyNetwork::new(short).is_err());
        let flat_standardizer = NetworkWeights {
            observation_dim,
            features: InputFeatures::CubeOrientation,
            standardizer: Some((vec![0.0; 10], vec![1.0; 10], 10.0)),
            layers: vec![(vec![0.0; 2 * feature_dim], vec![0.0, 0.0])],
            low: vec![-1.0; 2],
            high: vec![1.0; 2],
            ..Default::default()
        };
        assert!(PolicyNetwork::new(flat_standardizer).is_err());
    }

    #[test]
    fn bad_shapes_and_values_are_errors() {
        let net = tiny(OutputMap::Clip);
        let mut action = [0.0f32; 2];
        assert!(net.act(&[1.0, 2.0, 3.0], &mut action).is_err());
        assert!(net.act(&[f32::NAN, 2.0], &mut action).is_err());
        assert!(net.act(&[1.0, 2.0], &mut [0.0; 3]).is_err());
        let mut weights = NetworkWeights {
            observation_dim: 2,
            layers: vec![(vec![1.0; 6], vec![0.0; 3])],
            low: vec![-1.0; 3],
            high: vec![1.0; 3],
            ..Default::default()
        };
        assert!(PolicyNetwork::new(weights.clone()).is_ok());
        weights.layers[0].0.pop();
        assert!(PolicyNetwork::new(weights.clone()).is_err());
        weights.layers[0].0.push(f32::INFINITY);
        assert!(PolicyNetwork::new(weights.clone()).is_err());
        weights.layers[0].0[5] = 0.0;
        weights.high[0] = -1.0;
        assert!(PolicyNetwork::new(weights).is_err());
        assert!(Activation::parse("gelu").is_err());
    }
}
