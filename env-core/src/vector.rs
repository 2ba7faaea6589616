//! [`PandaVecEnv`]: many [`PandaEnv`]s stepped in parallel on a rayon pool of their own, into
//! contiguous, preallocated buffers.
//!
//! Environment `i` draws from random stream `(seed, i)` and is stepped by whichever thread picks
//! it up, touching nothing shared, so results are bit-identical for any thread count, and
//! environment `i` behaves the same whatever the number of environments.
//!
//! A [`Sensor`] per environment (camera images, from the renderer crate) adds bytes to every
//! observation: it runs on the lane's thread right after the state observation is written,
//! including for same-step final observations, before the reset that follows them.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::env::EnvConfig;
use crate::env::PandaEnv;
use crate::error::{ensure_len, Error, Result};
use crate::sensor::{Sensor, SensorSlot};
use crate::task::{ObservationLayout, ResetOptions, StepInfo, Transition};

/// What happens when an episode ends inside [`PandaVecEnv::step`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AutoresetMode {
    /// Gymnasium's default: the step that ends an episode returns its last observation; the
    /// next step resets that environment (ignoring its action) and returns the first
    /// observation of the new episode with reward 0.
    #[default]
    NextStep,
    /// stable-baselines3's convention: the step that ends an episode resets the environment at
    /// once and returns the new episode's first observation; the last one is kept in
    /// [`PandaVecEnv::final_observations`].
    SameStep,
    /// No automatic reset: ended environments must be reset with [`PandaVecEnv::reset_masked`]
    /// before the next step.
    Disabled,
}

impl AutoresetMode {
    /// The name used by Gymnasium (`next_step`, `same_step`, `disabled`).
    pub fn as_str(self) -> &'static str {
        match self {
            AutoresetMode::NextStep => "next_step",
            AutoresetMode::SameStep => "same_step",
            AutoresetMode::Disabled => "disabled",
        }
    }
}

/// One environment and its latest outputs.
#[derive(Debug)]
struct Lane {
    env: PandaEnv,
    sensor: Option<SensorSlot>,
    transition: Transition,
    reset_info: StepInfo,
    has_final: bool,
    /// The episode ended: reset before (next-step) or instead of (disabled) stepping again.
    ended: bool,
    /// This step reset the environment instead of stepping it (next-step mode).
    was_reset: bool,
    error: Option<Error>,
}

impl Lane {
    /// Writes the environment's current observation into `obs` and its sensor's bytes.
    fn observe(&mut self, obs: &mut [f32]) {
        obs.copy_from_slice(self.env.observation());
        if let Some(slot) = &mut self.sensor {
            slot.sensor.observe(&self.env, &mut slot.data);
        }
    }

    /// Writes the environment's current observation as a final observation.
    fn observe_final(&mut self, final_obs: &mut [f32]) {
        final_obs.copy_from_slice(self.env.observation());
        if let Some(slot) = &mut self.sensor {
            slot.sensor.observe(&self.env, &mut slot.final_data);
        }
    }
}

/// N  environments stepped in parallel.
pub struct PandaVecEnv {
    lanes: Vec<Lane>,
    pool: Option<rayon::ThreadPool>,
    /// The process that started the pool's threads (see [`PandaVecEnv::ensure_pool_usable`]).
    pool_pid: u32,
    num_threads: usize,
    autoreset: AutoresetMode,
    obs_dim: usize,
    action_dim: usize,
    observations: Vec<f32>,
    final_observations: Vec<f32>,
    rewards: Vec<f32>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    has_final: Vec<bool>,
    was_reset: Vec<bool>,
}

impl std::fmt::Debug for PandaVecEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PandaVecEnv")
            .field("num_envs", &self.lanes.len())
            .field("num_threads", &self.num_threads)
            .field("autoreset", &self.autoreset)
            .finish_non_exhaustive()
    }
}

impl PandaVecEnv {
    /// Builds `num_envs` environments (environment `i` with random stream `i`) and a pool of
    /// `num_threads` threads (`None`: the machine's cores, at most `num_envs`; 1 steps on the
    /// calling thread).
    pub fn new(
        config: EnvConfig,
        num_envs: usize,
        num_threads: Option<usize>,
        autoreset: AutoresetMode,
    ) -> Result<Self> {
        if num_envs == 0 {
            return Err(Error::InvalidConfig {
                field: "num_envs".into(),
                reason: "must be >= 1, got 0".into(),
            });
        }
        config.validate()?;
        let num_threads = match num_threads {
            Some(0) => {
                return Err(Error::InvalidConfig {
                    field: "num_threads".into(),
                    reason: "must be >= 1, got 0".into(),
                })
            }
            Some(n) => n,
            None => std::thread::available_parallelism()
                .map_or(1, |n| n.get())
                .min(num_envs),
        };
        let pool = build_pool(num_threads)?;
        let build = |i: usize| PandaEnv::with_index(config.clone(), i as u64);
        let envs: Vec<PandaEnv> = match &pool {
            Some(pool) => pool.install(|| {
                (0..num_envs)
                    .into_par_iter()
                    .map(build)
                    .collect::<Result<_>>()
            })?,
            None => (0..num_envs).map(build).collect::<Result<_>>()?,
        };
        let obs_dim = envs[0].layout().flat_dim();
        let action_dim = envs[0].action_dim();
        let lanes = envs
            .into_iter()
            .map(|env| Lane {
                env,
                sensor: None,
                transition: Transition::default(),
                reset_info: StepInfo::default(),
                has_final: false,
                ended: false,
                was_reset: false,
                error: None,
            })
            .collect();
        Ok(Self {
            lanes,
            pool,
            pool_pid: std::process::id(),
            num_threads,
            autoreset,
            obs_dim,
            action_dim,
            observations: vec![0.0; num_envs * obs_dim],
            final_observations: vec![0.0; num_envs * obs_dim],
            rewards: vec![0.0; num_envs],
            terminated: vec![false; num_envs],
            truncated: vec![false; num_envs],
            has_final: vec![false; num_envs],
            was_reset: vec![false; num_envs],
        })
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.lanes.len()
    }

    /// Threads stepping them.
    pub fn num_threads(&self) -> usize {
        self.num_threads
    }

    /// The autoreset mode.
    pub fn autoreset_mode(&self) -> AutoresetMode {
        self.autoreset
    }

    /// Length of one observation row (the flat layout).
    pub fn observation_dim(&self) -> usize {
        self.obs_dim
    }

    /// Length of one action row.
    pub fn action_dim(&self) -> usize {
        self.action_dim
    }

    /// The shared configuration.
    pub fn config(&self) -> &EnvConfig {
        self.lanes[0].env.config()
    }

    /// The task's reward for `n` transitions, recomputed from goals and reward contexts
    /// (`compute_reward`; see [`PandaEnv::compute_rewards`]).
    pub fn compute_rewards(
        &self,
        achieved: &[f32],
        desired: &[f32],
        contexts: &[f32],
        out: &mut [f32],
    ) -> Result<()> {
        self.lanes[0]
            .env
            .compute_rewards(achieved, desired, contexts, out)
    }

    /// Where everything sits in an observation row.
    pub fn layout(&self) -> &ObservationLayout {
        self.lanes[0].env.layout()
    }

    fn lane(&self, i: usize) -> Result<&Lane> {
        self.lanes
            .get(i)
            .ok_or_else(|| out_of_range(i, self.lanes.len()))
    }

    /// Environment `i`.
    pub fn env(&self, i: usize) -> Result<&PandaEnv> {
        self.lane(i).map(|l| &l.env)
    }

    /// Environment `i`, mutably (the next outputs are refreshed by the next step or reset).
    pub fn env_mut(&mut self, i: usize) -> Result<&mut PandaEnv> {
        let n = self.lanes.len();
        self.lanes
            .get_mut(i)
            .map(|l| &mut l.env)
            .ok_or_else(|| out_of_range(i, n))
    }

    /// Observations, `num_envs x observation_dim`, row-major.
    pub fn observations(&self) -> &[f32] {
        &self.observations
    }

    /// Last observations of the episodes that ended in the last step (same-step mode); rows
    /// where [`PandaVecEnv::has_final_observation`] is false hold stale data.
    pub fn final_observations(&self) -> &[f32] {
        &self.final_observations
    }

    /// Which rows of [`PandaVecEnv::final_observations`] are fresh.
    pub fn has_final_observation(&self) -> &[bool] {
        &self.has_final
    }

    /// Rows that were reset instead of stepped in the last step (next-step mode).
    pub fn was_reset(&self) -> &[bool] {
        &self.was_reset
    }

    /// Rewards of the last step.
    pub fn rewards(&self) -> &[f32] {
        &self.rewards
    }

    /// Terminated flags of the last step.
    pub fn terminated(&self) -> &[bool] {
        &self.terminated
    }

    /// Truncated flags of the last step.
    pub fn truncated(&self) -> &[bool] {
        &self.truncated
    }

    /// Info of environment `i` for the last step: the step's info, also when the environment
    /// was then reset (same-step mode), or the reset's info for a row that was reset.
    pub fn info(&self, i: usize) -> Result<&StepInfo> {
        self.lane(i).map(|l| &l.transition.info)
    }

    /// Infos of all environments for the last step, in order.
    pub fn infos(&self) -> impl ExactSizeIterator<Item = &StepInfo> {
        self.lanes.iter().map(|l| &l.transition.info)
    }

    /// Info of the first step of the episode that a same-step autoreset started, for row `i`
    /// (only meaningful where [`PandaVecEnv::has_final_observation`] is true).
    pub fn reset_info(&self, i: usize) -> Result<&StepInfo> {
        self.lane(i).map(|l| &l.reset_info)
    }

    /// Gives every environment a sensor (`sensors[i]` for environment `i`; all of the same
    /// [`Sensor::len`]) and fills its bytes from the current state; an empty vector removes
    /// them. Sensor bytes then follow every reset and step, see [`PandaVecEnv::sensor_data`].
    pub fn set_sensors(&mut self, sensors: Vec<Box<dyn Sensor>>) -> Result<()> {
        if sensors.is_empty() {
            for lane in &mut self.lanes {
                lane.sensor = None;
            }
            return Ok(());
        }
        ensure_len("sensors", self.lanes.len(), sensors.len())?;
        let len = sensors[0].len();
        if let Some(other) = sensors.iter().map(|s| s.len()).find(|&l| l != len) {
            return Err(Error::InvalidConfig {
                field: "sensors".into(),
                reason: format!("all sensors must write the same length, got {len} and {other}"),
            });
        }
        for (lane, sensor) in self.lanes.iter_mut().zip(sensors) {
            lane.sensor = Some(SensorSlot {
                sensor,
                data: vec![0; len],
                final_data: vec![0; len],
            });
        }
        self.for_each_lane(&[], |_, lane, obs, _final, _action| lane.observe(obs))
    }

    /// Bytes per environment written by the sensors (0 without sensors).
    pub fn sensor_len(&self) -> usize {
        self.lanes[0].sensor.as_ref().map_or(0, |s| s.data.len())
    }

    /// The sensors' bytes for the current observations, environment after environment, into
    /// `out` (`num_envs x` [`PandaVecEnv::sensor_len`]).
    pub fn sensor_data(&self, out: &mut [u8]) -> Result<()> {
        self.copy_sensor(out, |s| &s.data)
    }

    /// The sensors' bytes for the final observations (see
    /// [`PandaVecEnv::final_observations`]; stale where
    /// [`PandaVecEnv::has_final_observation`] is false), into `out`.
    pub fn final_sensor_data(&self, out: &mut [u8]) -> Result<()> {
        self.copy_sensor(out, |s| &s.final_data)
    }

    fn copy_sensor(&self, out: &mut [u8], which: impl Fn(&SensorSlot) -> &Vec<u8>) -> Result<()> {
        let len = self.sensor_len();
        ensure_len("sensor buffer", self.lanes.len() * len, out.len())?;
        if len == 0 {
            return Ok(());
        }
        for (lane, row) in self.lanes.iter().zip(out.chunks_exact_mut(len)) {
            if let Some(slot) = &lane.sensor {
                row.copy_from_slice(which(slot));
            }
        }
        Ok(())
    }

    /// Resets every environment; environment `i` is seeded from `(seed, i)` when a seed is given.
    pub fn reset(&mut self, seed: Option<u64>) -> Result<()> {
        let mask = vec![true; self.lanes.len()];
        let seeds = vec![seed; self.lanes.len()];
        self.reset_masked(&mask, &seeds)
    }

    /// Resets the environments where `mask` is true; `seeds` is empty (no re-seeding) or has
    /// one optional seed per environment (environment `i` seeded from `(seeds[i], i)`). The other
    /// rows keep their outputs.
    pub fn reset_masked(&mut self, mask: &[bool], seeds: &[Option<u64>]) -> Result<()> {
        let n = self.lanes.len();
        ensure_len("reset mask", n, mask.len())?;
        if !seeds.is_empty() {
            ensure_len("seeds", n, seeds.len())?;
        }
        let options = ResetOptions::default();
        self.for_each_lane(&[], |i, lane, obs, _final, _action| {
            if !mask[i] {
                lane.was_reset = false;
                return;
            }
            let seed = seeds.get(i).copied().flatten();
            match lane.env.reset(seed, &options) {
                Ok(info) => {
                    lane.transition = Transition {
                        info: *info,
                        ..Transition::default()
                    };
                    lane.observe(obs);
                }
                Err(e) => lane.error = Some(e),
            }
            lane.ended = false;
            lane.has_final = false;
            lane.was_reset = true;
        })?;
        self.gather(Some(mask))
    }

    /// Steps every environment with its row of `actions` (`num_envs x action_dim`, row-major).
    /// Every action is checked before any environment moves: on an error nothing has changed.
    pub fn step(&mut self, actions: &[f32]) -> Result<()> {
        let n = self.lanes.len();
        if actions.len() != n * self.action_dim {
            return Err(Error::InvalidAction {
                what: "actions (num_envs x action_dim)".into(),
                reason: format!(
                    "must have {} values, got {}",
                    n * self.action_dim,
                    actions.len()
                ),
            });
        }
        for (i, lane) in self.lanes.iter().enumerate() {
            let action = &actions[i * self.action_dim..(i + 1) * self.action_dim];
            lane.env
                .check_action(action)
                .map_err(|e| with_env_index(e, i))?;
            let must_reset = lane.ended && self.autoreset == AutoresetMode::Disabled;
            let never_reset = lane.env.needs_reset() && !lane.ended;
            if must_reset || never_reset {
                return Err(Error::ResetNeeded {
                    reason: if never_reset {
                        format!("environment {i} has not been reset; call reset() first")
                    } else {
                        format!(
                            "environment {i} ended its episode and autoreset is disabled; reset it first"
                        )
                    },
                });
            }
        }
        let autoreset = self.autoreset;
        let options = ResetOptions::default();
        self.for_each_lane(actions, |_, lane, obs, final_obs, action| {
            lane.has_final = false;
            lane.was_reset = false;
            if lane.ended && autoreset == AutoresetMode::NextStep {
                match lane.env.reset(None, &options) {
                    Ok(info) => {
                        lane.transition = Transition {
                            info: *info,
                            ..Transition::default()
                        };
                    }
                    Err(e) => lane.error = Some(e),
                }
                lane.ended = false;
                lane.was_reset = true;
                lane.observe(obs);
                return;
            }
            let transition = lane.env.step_checked(action);
            lane.transition = transition;
            let done = transition.terminated || transition.truncated;
            if done && autoreset == AutoresetMode::SameStep {
                lane.observe_final(final_obs);
                lane.has_final = true;
                match lane.env.reset(None, &options) {
                    Ok(info) => lane.reset_info = *info,
                    Err(e) => lane.error = Some(e),
                }
            } else {
                lane.ended = done;
            }
            lane.observe(obs);
        })?;
        self.gather(None)
    }

    /// Runs `f(i, lane, observation row, final observation row, action row)` for every
    /// environment, in parallel when the pool has more than one thread.
    fn for_each_lane<F>(&mut self, actions: &[f32], f: F) -> Result<()>
    where
        F: Fn(usize, &mut Lane, &mut [f32], &mut [f32], &[f32]) + Sync,
    {
        self.ensure_pool_usable()?;
        let d = self.obs_dim;
        let a = self.action_dim;
        let action_row = |i: usize| actions.get(i * a..(i + 1) * a).unwrap_or(&[]);
        match &self.pool {
            // One environment gains nothing from a hop to the pool.
            Some(pool) if self.lanes.len() > 1 => {
                let lanes = &mut self.lanes;
                let obs = &mut self.observations;
                let fin = &mut self.final_observations;
                pool.install(|| {
                    lanes
                        .par_iter_mut()
                        .zip(obs.par_chunks_mut(d))
                        .zip(fin.par_chunks_mut(d))
                        .enumerate()
                        .for_each(|(i, ((lane, o), fo))| f(i, lane, o, fo, action_row(i)));
                });
            }
            _ => {
                for (i, ((lane, o), fo)) in self
                    .lanes
                    .iter_mut()
                    .zip(self.observations.chunks_mut(d))
                    .zip(self.final_observations.chunks_mut(d))
                    .enumerate()
                {
                    f(i, lane, o, fo, action_row(i));
                }
            }
        }
        Ok(())
    }

    /// A process forked from the one that built the pool (Python's `multiprocessing`,
    /// stable-baselines3's `SubprocVecEnv`) inherits the pool's bookkeeping but none of its
    /// threads: work handed to it would wait forever. Such a child builds a pool of its own.
    fn ensure_pool_usable(&mut self) -> Result<()> {
        let pid = std::process::id();
        if self.pool.is_some() && pid != self.pool_pid {
            // Dropping the inherited pool would signal threads that do not exist here, through
            // locks a parent thread may have held at the fork; leak it instead (once per fork).
            std::mem::forget(self.pool.take());
            self.pool = build_pool(self.num_threads)?;
            self.pool_pid = pid;
        }
        Ok(())
    }

    /// Copies the lanes' scalar outputs into the contiguous buffers; reports the first error.
    fn gather(&mut self, mask: Option<&[bool]>) -> Result<()> {
        let mut first_error = None;
        for (i, lane) in self.lanes.iter_mut().enumerate() {
            self.was_reset[i] = lane.was_reset;
            if mask.is_some_and(|m| !m[i]) {
                continue;
            }
            self.rewards[i] = lane.transition.reward;
            self.terminated[i] = lane.transition.terminated;
            self.truncated[i] = lane.transition.truncated;
            self.has_final[i] = lane.has_final;
            if let Some(e) = lane.error.take() {
                first_error.get_or_insert(with_env_index(e, i));
            }
        }
        first_error.map_or(Ok(()), Err)
    }
}

/// A pool of `num_threads` workers, or `None` for one thread (work stays on the caller's).
fn build_pool(num_threads: usize) -> Result<Option<rayon::ThreadPool>> {
    if num_threads <= 1 {
        return Ok(None);
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(num_threads)
        .thread_name(|i| format!("panda-rapier-{i}"))
        .build()
        .map(Some)
        .map_err(|e| Error::InvalidConfig {
            field: "num_threads".into(),
            reason: format!("could not start {num_threads} threads: {e}"),
        })
}

fn out_of_range(index: usize, count: usize) -> Error {
    Error::InvalidConfig {
        field: "env index".into(),
        reason: format!("{index} is out of range for {count} environments"),
    }
}

/// Names the environment in an error about one row of a batch.
fn with_env_index(error: Error, i: usize) -> Error {
    match error {
        Error::InvalidAction { what, reason } => Error::InvalidAction {
            what: format!("{what} of environment {i}"),
            reason,
        },
        other => other,
    }
}
