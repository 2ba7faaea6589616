//! # panda-rapier-policies
//!
//! Policies that need no learning, for baselines and demonstrations:
//!
//! - [`ScriptedPolicy`]: the classic manual-control pick-and-place (open, move above, descend,
//!   close, lift, carry, lower, release, retreat), closed-loop on the observation alone, for
//!   both action modes.
//! - [`evaluate`]: runs a policy on seeded episodes of a [`panda_rapier_core::VecEnv`] and
//!   reports success rate, steps to success and returns.

pub mod evaluation;
pub mod scripted;

pub use evaluation::{evaluate, EpisodeOutcome, EvaluationReport};
pub use scripted::{Decision, Phase, ScriptedParams, ScriptedPolicy};
