//! [`TaskContext`]: what a task reads of the environment's configuration beside its own
//! section, so a task never holds the whole configuration.

use crate::task::config::{Randomization, RewardType, TaskThresholds, DEFAULT_SUCCESS_THRESHOLD};
use crate::task::reward::{RewardTerm, RewardWeights};

/// What a task reads of the environment's configuration beside its own section: built once
/// per environment ([`EnvConfig::task_context`](crate::env::EnvConfig::task_context)), with
/// the reward weights resolved against the task's terms.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskContext {
    /// Sparse or dense reward.
    pub reward_type: RewardType,
    /// Domain randomisation.
    pub randomization: Randomization,
    /// The goal counts as reached within this distance (m).
    pub success_threshold: f64,
    /// The weight of each of the task's reward terms: its default, or what the
    /// configuration's `reward_weights` sets (a term the task does not pay weighs 0).
    pub reward_weights: RewardWeights,
    /// Thresholds of the task's predicates.
    pub thresholds: TaskThresholds,
}

impl TaskContext {
    /// The context of a task paying `terms` under the default options: the sparse reward, no
    /// randomisation, the default success threshold and thresholds, each term at its default
    /// weight.
    pub fn defaults(terms: &[RewardTerm]) -> Self {
        Self {
            reward_type: RewardType::default(),
            randomization: Randomization::default(),
            success_threshold: DEFAULT_SUCCESS_THRESHOLD,
            reward_weights: RewardWeights::resolve(terms, &Default::default()),
            thresholds: TaskThresholds::default(),
        }
    }
}
