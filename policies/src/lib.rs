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
//! - [`evaluate`]: runs a policy on seeded episodes of a [`panda_rapier_core::PandaVecEnv`] and
//!   reports success rate, steps to success and returns.

pub mod evaluation;
pub mod scripted;
pub mod tutorial;

pub use evaluation::{evaluate, EpisodeOutcome, EvaluationReport};
pub use scripted::{Decision, Phase, ScriptedParams, ScriptedPolicy};
