//! # panda-rapier-policies
//!
//! Policies that need no learning, for baselines and demonstrations:
//!
//! - [`ScriptedPolicy`]: the classic manual-control pick-and-place (open, move above, descend,
//!   close, lift, carry, lower, release, retreat), closed-loop on the observation alone, for
//!   both action modes.
//! - [`tutorial`]: the classic tutorial's open-loop pick-and-place sequence on a bare
//!   [`panda_rapier_core::Simulation`], with slip and tracking measurements (a test of the
//!   physics rather than a policy).
//! - [`Evaluation`]: seeded episodes of a [`panda_rapier_core::PandaVecEnv`] handed out by refill,
//!   with a record per episode (return, length, success, steps to success and to placing),
//!   driven step by step with any policy's actions; [`evaluate`] drives it with the scripted
//!   policy. The Python package's `evaluate` and `panda-rapier eval` run the same evaluator.
//! - [`PolicyNetwork`]: a trained multilayer-perceptron policy's deterministic action in a
//!   fixed-order `f64` forward pass, the same bits on every CPU (what `panda-rapier eval` runs
//!   a saved stable-baselines3 model with).

pub mod evaluation;
pub mod features;
pub mod network;
pub mod scripted;
pub mod tutorial;

pub use evaluation::{evaluate, EpisodeRecord, Evaluation, EvaluationReport};
pub use features::InputFeatures;
pub use network::{Activation, NetworkWeights, OutputMap, PolicyNetwork};
pub use scripted::{Decision, Phase, ScriptedParams, ScriptedPolicy};
