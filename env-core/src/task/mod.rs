//! The pick-and-place task on top of the [`crate::Simulation`]: configuration, observation
//! layout, rewards, and the environment itself. Nothing here touches the physics engine; it
//! goes through [`crate::Simulation`].

pub mod config;
pub mod env;
pub mod observation;
pub mod reward;

pub use config::{ControlMode, EnvConfig, Randomization, Region, RewardType, TaskThresholds};
pub use env::{env_rng, EnvSnapshot, PickAndPlaceEnv, ResetOptions, StepInfo, Transition};
pub use observation::{ObservationLayout, Slot, GOAL_DIM};
pub use reward::{RewardContext, RewardFunction, RewardTerms, RewardWeights};
