//! Seeded evaluation of a policy on the vector environment.

use panda_rapier_core::task::EnvConfig;
use panda_rapier_core::{AutoresetMode, PandaVecEnv, Result};

use crate::ScriptedPolicy;

/// How one episode ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeOutcome {
    /// The seed of the episode...
    pub seed: u64,
    /// ...and the random stream (environment index) it ran on: the episode is that of
    /// `PandaEnv::with_index(config, env_index)` reset with `seed`.
    pub env_index: u64,
    /// Steps until `is_placed` first held, if it did.
    pub steps_to_placed: Option<u32>,
    /// Steps until `is_success` first held, if it did.
    pub steps_to_success: Option<u32>,
    /// `is_success` at the last step.
    pub final_success: bool,
    /// Sum of rewards.
    pub episode_return: f64,
    /// Steps taken.
    pub length: u32,
}

/// Outcomes of an evaluation, in seed order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EvaluationReport {
    /// One entry per episode.
    pub episodes: Vec<EpisodeOutcome>,
    /// Environment steps taken in all.
    pub env_steps: u64,
}

impl EvaluationReport {
    /// Fraction of episodes in which the cube was placed.
    pub fn placed_rate(&self) -> f64 {
        self.rate(|e| e.steps_to_placed.is_some())
    }

    /// Fraction of episodes that ended with `is_success`.
    pub fn success_rate(&self) -> f64 {
        self.rate(|e| e.final_success)
    }

    /// Mean steps until the cube was placed, over the episodes where it was.
    pub fn mean_steps_to_placed(&self) -> f64 {
        let steps: Vec<f64> = self
            .episodes
            .iter()
            .filter_map(|e| e.steps_to_placed.map(f64::from))
            .collect();
        steps.iter().sum::<f64>() / steps.len().max(1) as f64
    }

    /// `(seed, env_index)` of the episodes where the cube was not placed.
    pub fn failed_episodes(&self) -> Vec<(u64, u64)> {
        self.episodes
            .iter()
            .filter(|e| e.steps_to_placed.is_none())
            .map(|e| (e.seed, e.env_index))
            .collect()
    }

    fn rate(&self, f: impl Fn(&EpisodeOutcome) -> bool) -> f64 {
        self.episodes.iter().filter(|e| f(e)).count() as f64 / self.episodes.len().max(1) as f64
    }
}

/// Runs `episodes` episodes (episode `k` seeded with `first_seed + k`) of `config` with the
/// scripted policy, `num_envs` at a time on `num_threads` threads. Episodes run until they end
/// (time limit `config.max_episode_steps`, which must be set, or success termination);
/// `progress` is told how many episodes are done after each batch.
pub fn evaluate(
    config: &EnvConfig,
    episodes: usize,
    num_envs: usize,
    num_threads: Option<usize>,
    first_seed: u64,
    mut progress: impl FnMut(usize),
) -> Result<EvaluationReport> {
    let limit =
        config
            .max_episode_steps
            .ok_or_else(|| panda_rapier_core::Error::InvalidConfig {
                field: "max_episode_steps".into(),
                reason: "evaluation needs a time limit".into(),
            })?;
    let mut policy = ScriptedPolicy::new(config)?;
    let num_envs = num_envs.clamp(1, episodes.max(1));
    let mut envs = PandaVecEnv::new(
        config.clone(),
        num_envs,
        num_threads,
        AutoresetMode::NextStep,
    )?;
    let mut report = EvaluationReport::default();
    let mut actions = vec![0.0; num_envs * policy.action_dim()];
    let mut start = 0;
    while start < episodes {
        let batch = num_envs.min(episodes - start);
        let seeds: Vec<Option<u64>> = (0..num_envs)
            .map(|i| Some(first_seed + (start + i) as u64))
            .collect();
        envs.reset_masked(&vec![true; num_envs], &seeds)?;
        let mut outcomes: Vec<EpisodeOutcome> = (0..batch)
            .map(|i| EpisodeOutcome {
                seed: first_seed + (start + i) as u64,
                env_index: i as u64,
                steps_to_placed: None,
                steps_to_success: None,
                final_success: false,
                episode_return: 0.0,
                length: 0,
            })
            .collect();
        // Rows that ended stay out of the record (an autoreset would start them afresh).
        let mut ended = vec![false; batch];
        for step in 1..=limit {
            policy.act_batch(envs.observations(), &mut actions)?;
            envs.step(&actions)?;
            report.env_steps += batch as u64;
            for (i, outcome) in outcomes.iter_mut().enumerate() {
                if ended[i] {
                    continue;
                }
                ended[i] = envs.terminated()[i] || envs.truncated()[i];
                let info = envs.info(i)?;
                outcome.episode_return += f64::from(envs.rewards()[i]);
                outcome.length = step;
                outcome.final_success = info.is_success;
                if info.is_placed && outcome.steps_to_placed.is_none() {
                    outcome.steps_to_placed = Some(step);
                }
                if info.is_success && outcome.steps_to_success.is_none() {
                    outcome.steps_to_success = Some(step);
                }
            }
            if ended.iter().all(|&e| e) {
                break;
            }
        }
        report.episodes.extend(outcomes);
        start += batch;
        progress(start);
    }
    Ok(report)
}
