//! Seeded evaluation of a policy on the vector environment: the one evaluator behind
//! [`evaluate`] (the scripted policy, from Rust), `panda_rapier.evaluation.evaluate` (any
//! policy, from Python) and `panda-rapier eval`.
//!
//! Over 600 lines: the evaluator, the one place the summary statistics are computed, and
//! their unit tests (112 lines) belong together; the schedule below is their
//! contract.
//!
//! # The schedule
//!
//! An [`Evaluation`] runs `episodes` episodes on `num_envs` environments of a [`PandaVecEnv`]
//! (`min(num_envs, episodes)` of them). Episode `k` (`k = 0, 1, ...`) is reset with seed
//! `first_seed + k`, and episodes are handed out in order by **refill**: episodes
//! `0..num_envs` start together on environments `0..num_envs`; whenever episodes end, the
//! environments they ran on start the next episodes not yet begun, in environment order. An
//! episode ends when it terminates (success termination, unstable physics) or reaches the time
//! limit `max_episode_steps`, which must be set.
//!
//! Environment `i` draws from random stream `(seed, i)`, so an episode depends on its seed and
//! on the environment that ran it (its record's `env_index`). For a deterministic policy the
//! records are therefore a function of `(config, first_seed, num_envs)`: bit-identical for any
//! thread count and across runs; a different `num_envs` runs other (equally valid) episodes.
//! Which environment runs episode `k` depends only on how the earlier episodes ended, so the
//! first `m` records of an evaluation of `n > m` episodes are those of an evaluation of `m`.
//!
//! # Idle environments and the step count
//!
//! [`PandaVecEnv::step`] steps every row. Once every episode has been handed out, an environment
//! whose episode ends is *idle*: it is reset without a new seed (continuing its random stream)
//! and stepped along with the others, with whatever actions the policy gives it, until the last
//! episode ends; nothing it does is recorded. [`EvaluationReport::env_steps`] counts every
//! environment step simulated, idle ones included (the work a throughput figure divides by),
//! and [`EvaluationReport::idle_env_steps`] the idle ones among them: the recorded episodes'
//! lengths add up to the difference.
//!
//! # Driving it
//!
//! ```text
//! let mut evaluation = Evaluation::new(&config, episodes, num_envs, None, first_seed)?;
//! while !evaluation.is_done() {
//!     policy.act_batch(evaluation.observations(), &mut actions)?;
//!     evaluation.step(&actions)?;   // records the episodes that ended
//!     evaluation.refill()?;         // starts the next ones on the freed environments
//! }
//! let report = evaluation.report();
//! ```
//!
//! Stepping and refilling are separate calls so that a caller can look at the environments
//! between them (a video of environment 0 shows the last state of each episode).
//!
//! Over 600 lines: the refill schedule, the records and their statistics (the one place
//! evaluations are summarised, for Rust and Python) belong together, and half of it is tests.

use panda_rapier_core::EnvConfig;
use panda_rapier_core::{AutoresetMode, Error, PandaVecEnv, Result, Sensor};

use crate::ScriptedPolicy;

/// How one episode went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeRecord {
    /// The seed of the episode (`first_seed + k` for episode `k`)...
    pub seed: u64,
    /// ...and the environment (random stream) it ran on: the episode is that of
    /// `PandaEnv::with_index(config, env_index)` reset with `seed`.
    pub env_index: u64,
    /// Sum of the rewards (each an `f32`, summed in `f64`).
    pub episode_return: f64,
    /// Steps taken.
    pub length: u32,
    /// `is_success` at the last step (Gymnasium-Robotics' success criterion).
    pub success: bool,
    /// First step (1-based) at which `is_success` held, if it did.
    pub steps_to_success: Option<u32>,
    /// First step (1-based) at which `is_placed` held (cube released, at rest on the platform
    /// at the goal), if it did.
    pub steps_to_placed: Option<u32>,
    /// The episode ended because the physics became unstable (`physics_unstable` at the last
    /// step).
    pub physics_unstable: bool,
}

impl EpisodeRecord {
    fn start(seed: u64, env_index: usize) -> Self {
        Self {
            seed,
            env_index: env_index as u64,
            episode_return: 0.0,
            length: 0,
            success: false,
            steps_to_success: None,
            steps_to_placed: None,
            physics_unstable: false,
        }
    }

    /// Whether `is_placed` held at some step.
    pub fn placed(&self) -> bool {
        self.steps_to_placed.is_some()
    }
}

/// The records of an evaluation, in episode (seed) order, and what it cost.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EvaluationReport {
    /// The seed of episode 0.
    pub first_seed: u64,
    /// Environments used (the number asked for, at most the number of episodes).
    pub num_envs: usize,
    /// One record per episode; episode `k` (seed `first_seed + k`) at index `k`.
    pub episodes: Vec<EpisodeRecord>,
    /// Environment steps simulated, idle environments' included.
    pub env_steps: u64,
    /// Steps of idle environments (with no episode left to run) among `env_steps`.
    pub idle_env_steps: u64,
}

/// The headline statistics of a set of episodes: the one place they are computed (the Python
/// package's `EvaluationReport` reads them through `_native.summarize`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EvaluationSummary {
    /// Episodes summarised.
    pub episodes: usize,
    /// Fraction that ended with `is_success`.
    pub success_rate: f64,
    /// Its 95 % Wilson score interval.
    pub success_ci95: (f64, f64),
    /// Fraction in which `is_success` held at some step, the last or an earlier one
    /// (ManiSkill's `success_once`; LeRobot's `lerobot-eval` counts this).
    pub success_once_rate: f64,
    /// Its 95 % Wilson score interval.
    pub success_once_ci95: (f64, f64),
    /// Fraction in which `is_placed` held at some step (0 for tasks without it).
    pub placed_rate: f64,
    /// Mean return (0 without episodes).
    pub mean_return: f64,
    /// Standard deviation of the returns (population, as numpy's default).
    pub std_return: f64,
    /// Mean episode length.
    pub mean_length: f64,
    /// Mean first step of success, over the episodes that succeeded at some step.
    pub mean_steps_to_success: Option<f64>,
    /// Median first step of success, over the same episodes.
    pub median_steps_to_success: Option<f64>,
    /// Mean first step of placing, over the episodes where it happened.
    pub mean_steps_to_placed: Option<f64>,
    /// Episodes that ended because the physics blew up.
    pub physics_unstable_episodes: usize,
}

/// Wilson score interval of a binomial rate: `successes` of `n` (95 % for `z = 1.959964`);
/// `(0, 1)` for `n = 0`.
pub fn wilson_interval(successes: usize, n: usize, z: f64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let n = n as f64;
    let p = successes as f64 / n;
    let denominator = 1.0 + z * z / n;
    let centre = (p + z * z / (2.0 * n)) / denominator;
    let half = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / denominator;
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// The statistics of `episodes` (see [`EvaluationSummary`]).
pub fn summarize(episodes: &[EpisodeRecord]) -> EvaluationSummary {
    let n = episodes.len();
    let mean = |values: &[f64]| -> Option<f64> {
        (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
    };
    let rate = |f: &dyn Fn(&EpisodeRecord) -> bool| {
        episodes.iter().filter(|e| f(e)).count() as f64 / n.max(1) as f64
    };
    let returns: Vec<f64> = episodes.iter().map(|e| e.episode_return).collect();
    let mean_return = mean(&returns).unwrap_or(0.0);
    let variance = mean(
        &returns
            .iter()
            .map(|r| (r - mean_return).powi(2))
            .collect::<Vec<_>>(),
    );
    let lengths: Vec<f64> = episodes.iter().map(|e| f64::from(e.length)).collect();
    let mut to_success: Vec<f64> = episodes
        .iter()
        .filter_map(|e| e.steps_to_success.map(f64::from))
        .collect();
    to_success.sort_by(f64::total_cmp);
    let median = match to_success.len() {
        0 => None,
        k if k % 2 == 1 => Some(to_success[k / 2]),
        k => Some((to_success[k / 2 - 1] + to_success[k / 2]) / 2.0),
    };
    let to_placed: Vec<f64> = episodes
        .iter()
        .filter_map(|e| e.steps_to_placed.map(f64::from))
        .collect();
    let successes = episodes.iter().filter(|e| e.success).count();
    let once = episodes
        .iter()
        .filter(|e| e.success || e.steps_to_success.is_some())
        .count();
    EvaluationSummary {
        episodes: n,
        success_rate: rate(&|e| e.success),
        success_ci95: wilson_interval(successes, n, 1.959964),
        success_once_rate: once as f64 / n.max(1) as f64,
        success_once_ci95: wilson_interval(once, n, 1.959964),
        placed_rate: rate(&EpisodeRecord::placed),
        mean_return,
        std_return: variance.unwrap_or(0.0).sqrt(),
        mean_length: mean(&lengths).unwrap_or(0.0),
        mean_steps_to_success: mean(&to_success),
        median_steps_to_success: median,
        mean_steps_to_placed: mean(&to_placed),
        physics_unstable_episodes: episodes.iter().filter(|e| e.physics_unstable).count(),
    }
}

impl EvaluationReport {
    /// The statistics of the episodes.
    pub fn summary(&self) -> EvaluationSummary {
        summarize(&self.episodes)
    }

    /// Fraction of episodes in which the cube was placed at some step.
    pub fn placed_rate(&self) -> f64 {
        self.summary().placed_rate
    }

    /// Fraction of episodes that ended with `is_success`.
    pub fn success_rate(&self) -> f64 {
        self.summary().success_rate
    }

    /// `(seed, env_index)` of the episodes where the cube was not placed.
    pub fn failed_episodes(&self) -> Vec<(u64, u64)> {
        self.episodes
            .iter()
            .filter(|e| !e.placed())
            .map(|e| (e.seed, e.env_index))
            .collect()
    }
}

/// A seeded evaluation in progress: the vector environment, the refill schedule and the
/// records (see the [module documentation](self) for the schedule). The caller supplies the
/// actions, so any policy can be evaluated; [`evaluate`] drives it with the scripted policy.
#[derive(Debug)]
pub struct Evaluation {
    envs: PandaVecEnv,
    episodes: usize,
    first_seed: u64,
    /// The episode each environment runs; `None`: idle.
    running: Vec<Option<usize>>,
    /// The record of the episode each environment runs, filled in as it goes.
    current: Vec<EpisodeRecord>,
    /// Finished episodes, by episode index.
    records: Vec<Option<EpisodeRecord>>,
    finished: usize,
    next_episode: usize,
    /// Environments whose episode (recorded or idle) ended in the last step, awaiting
    /// [`Evaluation::refill`].
    ended: Vec<bool>,
    refill_pending: bool,
    /// Environments that started an episode in the last refill (all of them at first).
    started: Vec<bool>,
    seeds: Vec<Option<u64>>,
    env_steps: u64,
    idle_env_steps: u64,
}

impl Evaluation {
    /// Builds `min(num_envs, episodes)` environments of `config` on `num_threads` threads (as
    /// [`PandaVecEnv::new`]) and starts episodes `0..num_envs` on them. `config.max_episode_steps`
    /// must be set, `episodes` and `num_envs` at least 1, and `first_seed + episodes - 1` must
    /// fit in a `u64`.
    pub fn new(
        config: &EnvConfig,
        episodes: usize,
        num_envs: usize,
        num_threads: Option<usize>,
        first_seed: u64,
    ) -> Result<Self> {
        if config.max_episode_steps.is_none() {
            return Err(Error::InvalidConfig {
                field: "max_episode_steps".into(),
                reason: "must be set: evaluation needs a time limit".into(),
            });
        }
        for (field, value) in [("episodes", episodes), ("num_envs", num_envs)] {
            if value == 0 {
                return Err(Error::InvalidConfig {
                    field: field.into(),
                    reason: "must be >= 1, got 0".into(),
                });
            }
        }
        if first_seed.checked_add(episodes as u64 - 1).is_none() {
            return Err(Error::InvalidConfig {
                field: "first_seed".into(),
                reason: format!(
                    "{first_seed} + {episodes} episodes runs past the largest seed, 2^64 - 1"
                ),
            });
        }
        let n = num_envs.min(episodes);
        // No autoreset: every ended environment is reset by `refill`, with its next seed; one
        // that was not would be an error rather than a silently unseeded episode.
        let mut envs = PandaVecEnv::new(config.clone(), n, num_threads, AutoresetMode::Disabled)?;
        let seeds: Vec<Option<u64>> = (0..n).map(|i| Some(first_seed + i as u64)).collect();
        envs.reset_masked(&vec![true; n], &seeds)?;
        Ok(Self {
            envs,
            episodes,
            first_seed,
            running: (0..n).map(Some).collect(),
            current: (0..n)
                .map(|i| EpisodeRecord::start(first_seed + i as u64, i))
                .collect(),
            records: vec![None; episodes],
            finished: 0,
            next_episode: n,
            ended: vec![false; n],
            refill_pending: false,
            started: vec![true; n],
            seeds,
            env_steps: 0,
            idle_env_steps: 0,
        })
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.envs.num_envs()
    }

    /// Number of episodes the evaluation runs.
    pub fn episodes(&self) -> usize {
        self.episodes
    }

    /// The seed of episode 0.
    pub fn first_seed(&self) -> u64 {
        self.first_seed
    }

    /// The vector environment (to render or inspect an environment; stepping and resetting
    /// are the evaluation's).
    pub fn envs(&self) -> &PandaVecEnv {
        &self.envs
    }

    /// Gives the environments sensors (camera images; see [`PandaVecEnv::set_sensors`]), for
    /// policies that observe more than the state.
    pub fn set_sensors(&mut self, sensors: Vec<Box<dyn Sensor>>) -> Result<()> {
        self.envs.set_sensors(sensors)
    }

    /// The current observations, `num_envs x observation_dim`, row-major (flat layout): what
    /// the actions of the next [`Evaluation::step`] should answer.
    pub fn observations(&self) -> &[f32] {
        self.envs.observations()
    }

    /// The episode each environment runs (`None`: idle, every episode has been handed out).
    /// Updated by [`Evaluation::refill`]: between a step and the refill, an environment whose
    /// episode just ended still shows it.
    pub fn running(&self) -> &[Option<usize>] {
        &self.running
    }

    /// The environments that started an episode in the last [`Evaluation::refill`] (after
    /// [`Evaluation::new`]: all of them).
    pub fn started(&self) -> &[bool] {
        &self.started
    }

    /// Episodes finished so far.
    pub fn finished(&self) -> usize {
        self.finished
    }

    /// Whether every episode has ended.
    pub fn is_done(&self) -> bool {
        self.finished == self.episodes
    }

    /// Environment steps simulated so far, idle environments' included.
    pub fn env_steps(&self) -> u64 {
        self.env_steps
    }

    /// Steps of idle environments so far.
    pub fn idle_env_steps(&self) -> u64 {
        self.idle_env_steps
    }

    /// Steps every environment with its row of `actions` (`num_envs x action_dim`) and
    /// records the episodes that ended; returns how many did. Their environments keep their
    /// last state until [`Evaluation::refill`], which must come before the next step. Fails
    /// (before anything moves) on bad actions, when a refill is due, or once the evaluation
    /// is done.
    pub fn step(&mut self, actions: &[f32]) -> Result<usize> {
        if self.refill_pending {
            return Err(Error::ResetNeeded {
                reason: "episodes ended in the last step: call refill() to start the next ones \
                         before stepping again"
                    .into(),
            });
        }
        if self.is_done() {
            return Err(Error::ResetNeeded {
                reason: format!(
                    "the evaluation is over: all {} episodes have ended",
                    self.episodes
                ),
            });
        }
        self.envs.step(actions)?;
        self.started.fill(false);
        let n = self.envs.num_envs();
        self.env_steps += n as u64;
        let mut ended_now = 0;
        for i in 0..n {
            let done = self.envs.terminated()[i] || self.envs.truncated()[i];
            self.ended[i] = done;
            self.refill_pending |= done;
            let Some(episode) = self.running[i] else {
                self.idle_env_steps += 1;
                continue;
            };
            let info = self.envs.info(i)?;
            let record = &mut self.current[i];
            record.episode_return += f64::from(self.envs.rewards()[i]);
            record.length += 1;
            if info.is_success && record.steps_to_success.is_none() {
                record.steps_to_success = Some(record.length);
            }
            if info.flag("is_placed") && record.steps_to_placed.is_none() {
                record.steps_to_placed = Some(record.length);
            }
            if done {
                record.success = info.is_success;
                record.physics_unstable = info.physics_unstable;
                self.records[episode] = Some(*record);
                self.finished += 1;
                ended_now += 1;
            }
        }
        Ok(ended_now)
    }

    /// Resets the environments whose episode ended in the last step: each starts the next
    /// episode not yet begun (in environment order) with its seed, or, when every episode has
    /// been handed out, becomes idle (reset without a new seed). Does nothing when no episode
    /// ended.
    pub fn refill(&mut self) -> Result<()> {
        if !self.refill_pending {
            return Ok(());
        }
        for i in 0..self.ended.len() {
            self.seeds[i] = None;
            if !self.ended[i] {
                continue;
            }
            if self.next_episode < self.episodes {
                let k = self.next_episode;
                let seed = self.first_seed + k as u64;
                self.running[i] = Some(k);
                self.current[i] = EpisodeRecord::start(seed, i);
                self.seeds[i] = Some(seed);
                self.started[i] = true;
                self.next_episode += 1;
            } else {
                self.running[i] = None;
            }
        }
        self.envs.reset_masked(&self.ended, &self.seeds)?;
        self.ended.fill(false);
        self.refill_pending = false;
        Ok(())
    }

    /// The report, once every episode has ended ([`Evaluation::is_done`]); `None` before.
    pub fn report(&self) -> Option<EvaluationReport> {
        let episodes = self.records.iter().copied().collect::<Option<Vec<_>>>()?;
        Some(EvaluationReport {
            first_seed: self.first_seed,
            num_envs: self.envs.num_envs(),
            episodes,
            env_steps: self.env_steps,
            idle_env_steps: self.idle_env_steps,
        })
    }
}

/// Evaluates the scripted policy: runs an [`Evaluation`] of `episodes` episodes of `config`
/// (episode `k` seeded with `first_seed + k`, handed out by refill: see the
/// [module documentation](self)) on `num_envs` environments and `num_threads` threads, acting
/// with [`ScriptedPolicy::act_batch`] on every row. `progress` is told how many episodes have
/// ended after every step that ends some. Gives the same records as
/// `panda_rapier.evaluation.evaluate` (and `panda-rapier eval`) with the scripted policy.
pub fn evaluate(
    config: &EnvConfig,
    episodes: usize,
    num_envs: usize,
    num_threads: Option<usize>,
    first_seed: u64,
    mut progress: impl FnMut(usize),
) -> Result<EvaluationReport> {
    let mut policy = ScriptedPolicy::new(config)?;
    let mut evaluation = Evaluation::new(config, episodes, num_envs, num_threads, first_seed)?;
    let mut actions = vec![0.0; evaluation.num_envs() * policy.action_dim()];
    while !evaluation.is_done() {
        policy.act_batch(evaluation.observations(), &mut actions)?;
        if evaluation.step(&actions)? > 0 {
            progress(evaluation.finished());
        }
        evaluation.refill()?;
    }
    evaluation.report().ok_or_else(|| Error::ResetNeeded {
        reason: "evaluation ended with episodes unrecorded".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_hand_made_records() {
        let record = |ret: f64, success: Option<u32>, placed: Option<u32>| EpisodeRecord {
            episode_return: ret,
            length: 10,
            success: success.is_some(),
            steps_to_success: success,
            steps_to_placed: placed,
            ..EpisodeRecord::start(0, 0)
        };
        let episodes = [
            record(1.0, Some(4), None),
            record(3.0, Some(8), Some(9)),
            record(5.0, None, None),
            record(7.0, Some(6), None),
        ];
        let s = summarize(&episodes);
        assert_eq!(s.episodes, 4);
        assert_eq!(s.success_rate, 0.75);
        assert_eq!(s.success_once_rate, 0.75);
        // Successful at step 3, not at the last step: counted once, not at the end.
        let lost = EpisodeRecord {
            success: false,
            ..record(0.0, Some(3), None)
        };
        let s2 = summarize(&[lost, record(0.0, None, None)]);
        assert_eq!((s2.success_rate, s2.success_once_rate), (0.0, 0.5));
        assert_eq!(s2.success_once_ci95, wilson_interval(1, 2, 1.959964));
        assert_eq!(s2.success_ci95, wilson_interval(0, 2, 1.959964));
        assert_eq!(s.placed_rate, 0.25);
        assert_eq!(s.mean_return, 4.0);
        assert_eq!(s.std_return, 5.0f64.sqrt());
        assert_eq!(s.median_steps_to_success, Some(6.0));
        assert_eq!(s.mean_steps_to_success, Some(6.0));
        assert_eq!(s.mean_steps_to_placed, Some(9.0));
        assert_eq!(summarize(&episodes[..2]).median_steps_to_success, Some(6.0));
        let empty = summarize(&[]);
        assert_eq!((empty.success_rate, empty.mean_return), (0.0, 0.0));
        assert_eq!(empty.success_ci95, (0.0, 1.0));
        assert_eq!(empty.success_once_rate, 0.0);
        assert_eq!(empty.mean_steps_to_success, None);
    }

    fn config(limit: u32) -> EnvConfig {
        EnvConfig {
            max_episode_steps: Some(limit),
            ..EnvConfig::default()
        }
    }

    #[test]
    fn refill_hands_out_every_episode_once_in_seed_order() {
        let report = evaluate(&config(8), 7, 3, Some(1), 5, |_| {}).unwrap();
        let seeds: Vec<u64> = report.episodes.iter().map(|e| e.seed).collect();
        assert_eq!(seeds, (5..12).collect::<Vec<_>>());
        // Equal lengths: episodes go round the environments in order; the last step has two
        // idle environments.
        let envs: Vec<u64> = report.episodes.iter().map(|e| e.env_index).collect();
        assert_eq!(envs, [0, 1, 2, 0, 1, 2, 0]);
        assert!(report.episodes.iter().all(|e| e.length == 8));
        assert_eq!(report.env_steps, 3 * 3 * 8);
        assert_eq!(report.idle_env_steps, 2 * 8);
        let lengths: u64 = report.episodes.iter().map(|e| u64::from(e.length)).sum();
        assert_eq!(lengths, report.env_steps - report.idle_env_steps);
    }

    #[test]
    fn records_do_not_depend_on_the_thread_count() {
        // Success ends episodes: unequal lengths, so refill departs from round robin.
        let cfg = EnvConfig {
            terminate_on_success: true,
            ..config(60)
        };
        let one = evaluate(&cfg, 6, 4, Some(1), 0, |_| {}).unwrap();
        let two = evaluate(&cfg, 6, 4, Some(2), 0, |_| {}).unwrap();
        assert_eq!(one, two);
        assert!(one.episodes.iter().any(|e| e.length < 60));
    }

    #[test]
    fn the_order_of_calls_is_checked() {
        let mut evaluation = Evaluation::new(&config(2), 1, 4, Some(1), 0).unwrap();
        assert_eq!(evaluation.num_envs(), 1);
        let actions = vec![0.0; evaluation.envs().action_dim()];
        assert_eq!(evaluation.step(&actions).unwrap(), 0);
        assert!(evaluation.report().is_none());
        assert_eq!(evaluation.step(&actions).unwrap(), 1);
        assert!(evaluation.step(&actions).is_err(), "refill is due");
        evaluation.refill().unwrap();
        assert_eq!(evaluation.running(), [None]);
        assert!(evaluation.is_done());
        assert!(evaluation.step(&actions).is_err(), "the evaluation is over");
        assert_eq!(evaluation.report().unwrap().episodes.len(), 1);
    }

    #[test]
    fn bad_arguments_are_errors() {
        let no_limit = EnvConfig {
            max_episode_steps: None,
            ..EnvConfig::default()
        };
        assert!(Evaluation::new(&no_limit, 1, 1, Some(1), 0).is_err());
        assert!(Evaluation::new(&config(5), 0, 1, Some(1), 0).is_err());
        assert!(Evaluation::new(&config(5), 1, 0, Some(1), 0).is_err());
        assert!(Evaluation::new(&config(5), 2, 1, Some(1), u64::MAX).is_err());
        assert!(Evaluation::new(&config(5), 1, 1, Some(1), u64::MAX).is_ok());
    }
}
