//! The composition root: [`PandaEnv`], one environment instance of any [`Task`] (reset, step,
//! snapshot), with the robot, its action [`Controller`], the world and the episode bookkeeping
//! every task shares; its configuration [`EnvConfig`] (with [`ControlMode`]), which builds a
//! task from the task's section and a [`TaskContext`](crate::task::TaskContext)
//! ([`make_task`]); and the reader of configurations from before 0.2 ([`migrate`]). It depends
//! on `task`, `robot` and `physics`; none of them depends on it.

pub mod config;
pub mod controller;
pub mod migrate;
pub mod osc;
#[cfg(test)]
mod task_section_tests;

pub use config::{make_task, ControlMode, EeController, EeFrame, EnvConfig};
pub use controller::{Controller, Plan};
pub use migrate::{Deprecation, LEGACY_KEYS_REMOVED_IN};
pub use osc::{Osc, OscConfig};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{Error, Result};
use crate::physics::{SimSnapshot, Simulation, TouchReading};
use crate::robot::RobotSpec;
use crate::task::episode::{EpisodeStart, ResetOptions, StepInfo, Transition};
use crate::task::observation::{
    ObservationLayout, GRIPPER_WIDTH, JOINT_POSITIONS, JOINT_VELOCITIES, TCP_POSITION, TCP_VELOCITY,
};
use crate::task::{Task, Verdict, View};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Status {
    NeverReset,
    Running,
    /// The physics blew up; only a reset helps.
    Unstable,
}

/// Everything [`PandaEnv::restore`] needs to continue bit-identically.
#[derive(Debug, Clone)]
pub struct EnvSnapshot {
    sim: SimSnapshot,
    rng: ChaCha8Rng,
    seeded: bool,
    goal: Vec<f64>,
    elapsed: u32,
    status: Status,
    observation: Vec<f32>,
    info: StepInfo,
}

/// A Franka Panda environment running one [`Task`] (by default [`crate::task::PickAndPlace`]):
/// pick the cube up from the floor and put it down on the goal on the platform.
///
/// # Description
/// The classic tutorial's scene: a Panda on a fixed base at the origin, a 0.3 m x 0.3 m x 0.1 m
/// platform, a 5 cm, 0.1 kg cube. The robot is a rapier multibody with torque-limited joint
/// motors; the cube is held by friction between the finger pads alone.
///
/// # Action space
/// `f32`, every entry clipped to [-1, 1]; NaN or infinite values are an error.
/// - `ee` (default, 4-D): TCP displacement (x, y, z) of `ee_step` (0.05 m) at 1.0, from the
///   measured TCP position, clipped into `ee_workspace` and to at least `ee_surface_clearance`
///   above the floor or platform under it, and solved by inverse kinematics with the hand
///   pointing straight down; then the gripper command.
/// - `joints` (8-D for the Panda): target displacement of `joint_step` (0.05 rad) at 1.0 for each
///   arm joint, from the measured joint positions; then the gripper command.
///
/// Joint targets are limited by the joints' velocity limits and ramped across the control period
/// with a velocity feed-forward, so the arm moves at a steady speed
/// ([`crate::env::Controller`]). The gripper command is an absolute opening: -1 closes with
/// `robot.motors.gripper_force` (a friction grasp), +1 opens fully (0.08 m), values between ask
/// for a proportional opening.
///
/// # Observation space
/// The goal dict (`observation`, `achieved_goal`, `desired_goal`) laid out in one flat `f32`
/// vector ([`crate::task::observation`]); the pick-and-place table is in
/// [`crate::task::pick_and_place`].
///
/// # Rewards
/// The task's: for pick-and-place `sparse` (default) -1 until the cube is within
/// `success_threshold` (0.05 m) of the goal, then 0; `dense`: staged terms, see
/// [`crate::task::reward`]. Both are reproduced exactly by [`PandaEnv::compute_rewards`] from
/// the goals and the info's reward context (the task's
/// [`reward_context_keys`](crate::task::TaskDescriptor::reward_context_keys)).
///
/// # Starting state
/// The robot in its start pose ([`RobotSpec::start_configuration`], plus
/// `randomization.joint_noise`), the gripper open, the objects and the goal where the task draws
/// them.
///
/// # Episode end
/// Truncated after `max_episode_steps` (70) steps, or at once if the physics blows up (a
/// non-finite state or a body faster than the `thresholds`; the info says `physics_unstable` and
/// the last valid observation is returned). Terminated on success only with
/// `terminate_on_success`.
///
/// Why 70 and not the 50 of Fetch and panda-gym: this arm is torque-limited and its joint
/// targets respect the URDF velocity limits, and `joints` actions move each joint at most
/// `joint_step` (0.05 rad) per step. The scripted pick-and-place baseline
/// (`panda-rapier-policies`) needs a mean of 37 steps (`ee`) and 53 steps (`joints`) to place the
/// cube. Placed within the limit, over 1,000 seeded episodes (`ee` / `joints`): 50 steps
/// 96.8 % / 25.2 %, 60 steps 98.8 % / 94.8 %, 65 steps 99.0 % / 99.1 %, 70 steps 99.3 % /
/// 99.7 %. 65 is the shortest that reaches 99 % in both modes; 70 leaves a margin.
///
/// # Info
/// [`StepInfo`]: every task's entries ([`crate::task::COMMON_INFO_FIELDS`]), then the task's
/// own ([`TaskDescriptor::info_fields`](crate::task::TaskDescriptor::info_fields)).
pub struct PandaEnv {
    config: EnvConfig,
    index: u64,
    robot: RobotSpec,
    task: Box<dyn Task>,
    controller: Controller,
    sim: Simulation,
    initial: SimSnapshot,
    layout: ObservationLayout,
    rng: ChaCha8Rng,
    seeded: bool,
    status: Status,
    elapsed: u32,
    goal: Vec<f64>,
    observation: Vec<f32>,
    info: StepInfo,
    // Scratch space, so a step or reset does not allocate.
    start: EpisodeStart,
    q: Vec<f64>,
    values: Vec<f64>,
    joint_velocities: Vec<f64>,
}

impl std::fmt::Debug for PandaEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PandaEnv")
            .field("task", &self.task.name())
            .field("index", &self.index)
            .field("control_mode", &self.config.control_mode)
            .field("reward_type", &self.config.reward_type)
            .field("elapsed_steps", &self.elapsed)
            .finish_non_exhaustive()
    }
}

/// The random stream of environment `index` for `seed`: ChaCha8 keyed by the seed, one stream
/// per index, so environment `i` draws the same numbers whatever else runs beside it.
pub fn env_rng(seed: u64, index: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index);
    rng
}

impl PandaEnv {
    /// Builds environment 0 (see [`PandaEnv::with_index`]).
    pub fn new(config: EnvConfig) -> Result<Self> {
        Self::with_index(config, 0)
    }

    /// Builds the environment that draws from random stream `index` (environment `index` of a
    /// vector environment behaves exactly like this one).
    pub fn with_index(config: EnvConfig, index: u64) -> Result<Self> {
        config.validate()?;
        let sim_config = config.sim_config()?;
        let robot = RobotSpec::new(&sim_config)?;
        let mut task = make_task(&config);
        let scene = task.build_scene();
        let sim = Simulation::with_scene(sim_config, robot.model().clone(), scene)?;
        task.bind(&sim)?;
        let layout = ObservationLayout::new(
            robot.movable_joints().len(),
            task.goal_dim(),
            task.goal_descriptions(),
            task.observation_slots(),
        );
        let initial = sim.snapshot();
        let controller = Controller::new(&config, &robot);
        let num_dofs = robot.model().num_dofs();
        let num_joints = layout.num_joints();
        let flat_dim = layout.flat_dim();
        let goal_dim = layout.goal_dim();
        Ok(Self {
            config,
            index,
            robot,
            task,
            controller,
            sim,
            initial,
            layout,
            rng: env_rng(0, index),
            seeded: false,
            status: Status::NeverReset,
            elapsed: 0,
            goal: vec![0.0; goal_dim],
            observation: vec![0.0; flat_dim],
            info: StepInfo::default(),
            start: EpisodeStart::default(),
            q: vec![0.0; num_dofs],
            values: vec![0.0; flat_dim],
            joint_velocities: vec![0.0; num_joints],
        })
    }

    /// The configuration.
    pub fn config(&self) -> &EnvConfig {
        &self.config
    }

    /// Which random stream this environment draws from.
    pub fn index(&self) -> u64 {
        self.index
    }

    /// The task.
    pub fn task(&self) -> &dyn Task {
        self.task.as_ref()
    }

    /// The robot (model, gripper, start pose).
    pub fn robot(&self) -> &RobotSpec {
        &self.robot
    }

    /// Where everything sits in the observation.
    pub fn layout(&self) -> &ObservationLayout {
        &self.layout
    }

    /// Length of an action: 4 for `ee`, one per actuated joint (8 for the Panda) for `joints`.
    pub fn action_dim(&self) -> usize {
        Controller::action_dim(self.config.control_mode, &self.robot)
    }

    /// Seconds of simulated time per step (the control period).
    pub fn dt(&self) -> f64 {
        self.sim.control_period()
    }

    /// The task's reward for `n` transitions, recomputed from `n x goal_dim` goals and `n`
    /// rows of reward-context values (the task's
    /// [`reward_context_keys`](crate::task::TaskDescriptor::reward_context_keys); optional for
    /// the sparse reward): `compute_reward`.
    pub fn compute_rewards(
        &self,
        achieved: &[f32],
        desired: &[f32],
        contexts: &[f32],
        out: &mut [f32],
    ) -> Result<()> {
        self.task.compute_rewards(achieved, desired, contexts, out)
    }

    /// The current observation (flat layout).
    pub fn observation(&self) -> &[f32] {
        &self.observation
    }

    /// The info of the last reset or step.
    pub fn info(&self) -> &StepInfo {
        &self.info
    }

    /// The current goal (`goal_dim` entries; for pick-and-place the cube centre's position, m;
    /// for flip the cube's orientation, a quaternion x, y, z, w).
    pub fn goal(&self) -> &[f64] {
        &self.goal
    }

    /// Steps taken in the current episode.
    pub fn elapsed_steps(&self) -> u32 {
        self.elapsed
    }

    /// The simulation, for introspection (robot model, link states, kinematics).
    pub fn simulation(&self) -> &Simulation {
        &self.sim
    }

    /// What the hand felt over the last control step: contact forces on each finger and the
    /// wrist's force-torque reading ([`Simulation::touch`]; the `touch` observation entry is
    /// its [`TouchReading::observation`]).
    pub fn touch(&self) -> TouchReading {
        self.sim.touch()
    }

    /// The simulation, to drive the robot directly; the next [`PandaEnv::step`] overrides the
    /// joint commands. The observation follows at the next step or reset, or at once with
    /// [`PandaEnv::refresh`].
    pub fn simulation_mut(&mut self) -> &mut Simulation {
        &mut self.sim
    }

    /// Recomputes the observation and info from the simulation as it is now (after changing
    /// it through [`PandaEnv::simulation_mut`]); the step count is unchanged.
    pub fn refresh(&mut self) -> Result<&StepInfo> {
        if self.status == Status::NeverReset {
            return Err(Error::ResetNeeded {
                reason: "refresh() called before the first reset()".into(),
            });
        }
        if !(self.is_stable() && self.write_observation()) {
            self.status = Status::Unstable;
            return Err(Error::ResetNeeded {
                reason: "the simulation's state is not finite or moves faster than the blow-up thresholds".into(),
            });
        }
        let ik_error = self.info.ik_position_error;
        let opening = self.info.gripper_opening as f64;
        self.info = self.step_info(&self.judge(opening), false, ik_error, opening);
        Ok(&self.info)
    }

    /// Starts a new episode. `seed` re-seeds this environment's stream (from `(seed, index)`);
    /// without it the stream continues (the first reset without any seed draws one from the
    /// operating system).
    pub fn reset(&mut self, seed: Option<u64>, options: &ResetOptions) -> Result<&StepInfo> {
        options.validate(self.q.len())?;
        match seed {
            Some(seed) => {
                self.rng = env_rng(seed, self.index);
                self.seeded = true;
            }
            None if !self.seeded => {
                self.rng = ChaCha8Rng::from_os_rng();
                self.rng.set_stream(self.index);
                self.seeded = true;
            }
            None => {}
        }
        self.reset_episode(options)?;
        Ok(&self.info)
    }

    fn reset_episode(&mut self, options: &ResetOptions) -> Result<()> {
        // The task draws first, then the robot's joint noise: always the same draws in the same
        // order, whatever the overrides.
        self.task
            .draw_episode(&mut self.rng, options, &mut self.start);
        // The start configuration goes into the `q` scratch buffer: no allocation.
        let noise = self.config.randomization.joint_noise;
        self.q.copy_from_slice(self.robot.start_configuration());
        for &dof in self.robot.arm_dofs() {
            let u = self.rng.random::<f64>();
            self.q[dof] += noise * (2.0 * u - 1.0);
        }
        if let Some(start) = &options.joint_positions {
            self.q.copy_from_slice(start);
        }

        self.sim.restore(&self.initial)?;
        for object in &self.start.objects {
            if let Some((size, mass, friction)) = object.properties {
                self.sim
                    .set_object_properties(object.object, size, mass, friction)?;
            }
            if let Some(shape) = &object.shape {
                self.sim.set_object_shape(object.object, shape)?;
            }
            if let Some(v) = object.variant {
                self.sim.set_object_variant(
                    object.object,
                    v.index,
                    v.mass,
                    v.friction,
                    v.rolling_damping,
                )?;
            }
        }
        self.sim.set_joint_positions(&self.q)?;
        let width = self.sim.gripper_width();
        self.sim.set_gripper(width, None)?;
        for object in &self.start.objects {
            self.sim
                .set_object_pose(object.object, &object.position, &object.orientation)?;
        }
        for articulation in &self.start.articulations {
            self.sim.set_articulation(
                articulation.articulation,
                &articulation.pose,
                &articulation.joint_positions,
            )?;
        }
        self.goal.copy_from_slice(&self.start.goal);
        self.elapsed = 0;
        self.status = Status::Running;
        if !self.write_observation() {
            // Only a start pose the user chose can do this (e.g. overlapping bodies).
            self.status = Status::Unstable;
            return Err(Error::InvalidOption {
                what: "options".into(),
                reason: "give a start state that is not finite".into(),
            });
        }
        let opening = self.robot.gripper_opening(self.sim.gripper_width());
        self.info = self.step_info(&self.judge(opening), false, f64::NAN, opening);
        Ok(())
    }

    /// Checks an action: its length and that every value is finite; fails with
    /// [`Error::InvalidAction`].
    pub fn check_action(&self, action: &[f32]) -> Result<()> {
        if action.len() != self.action_dim() {
            return Err(Error::InvalidAction {
                what: "action".into(),
                reason: format!(
                    "must have {} values, got {}",
                    self.action_dim(),
                    action.len()
                ),
            });
        }
        if let Some((i, &v)) = action.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::InvalidAction {
                what: format!("action[{i}]"),
                reason: format!("must be finite, got {v}"),
            });
        }
        Ok(())
    }

    /// Whether [`PandaEnv::step`] would refuse for lack of a reset.
    pub fn needs_reset(&self) -> bool {
        self.status != Status::Running
    }

    fn check_running(&self) -> Result<()> {
        match self.status {
            Status::Running => Ok(()),
            Status::NeverReset => Err(Error::ResetNeeded {
                reason: "step() called before the first reset()".into(),
            }),
            Status::Unstable => Err(Error::ResetNeeded {
                reason: "the physics became unstable in the last step".into(),
            }),
        }
    }

    /// Applies `action` for one control period. Stepping past the time limit is allowed (the
    /// episode stays truncated); after a physics blow-up or before the first reset it is an
    /// error.
    pub fn step(&mut self, action: &[f32]) -> Result<Transition> {
        self.check_running()?;
        self.check_action(action)?;
        Ok(self.step_checked(action))
    }

    /// [`PandaEnv::step`] for an action already checked by [`PandaEnv::check_action`] on a
    /// running environment.
    pub(crate) fn step_checked(&mut self, action: &[f32]) -> Transition {
        let plan: Plan = self.controller.plan(&self.robot, &self.sim, action);
        let blocked_before = self.sim.arm_blocked_steps();
        self.controller.drive(&mut self.sim, &plan);
        self.elapsed = self.elapsed.saturating_add(1);
        let stable = self.is_stable() && self.write_observation();
        if !stable {
            self.status = Status::Unstable;
        }
        let opening = self.robot.gripper_opening(plan.gripper_width);
        let verdict = self.judge(opening);
        let mut info = self.step_info(&verdict, !stable, plan.ik_position_error, opening);
        info.arm_blocked = self.sim.arm_blocked_steps() > blocked_before;
        self.info = info;
        Transition {
            reward: verdict.reward,
            terminated: self.config.terminate_on_success && info.is_success,
            truncated: !stable
                || self
                    .config
                    .max_episode_steps
                    .is_some_and(|limit| self.elapsed >= limit),
            info,
        }
    }

    fn is_stable(&self) -> bool {
        let t = &self.config.thresholds;
        let (v, w) = self.sim.max_body_speeds();
        // NaN fails both comparisons.
        v <= t.unstable_linear_speed && w <= t.unstable_angular_speed && self.sim.is_finite()
    }

    /// Writes the observation: the goals, the robot's slots and the task's; false (and the
    /// previous observation kept) if any value is not finite.
    fn write_observation(&mut self) -> bool {
        let l = &self.layout;
        let values = &mut self.values;
        let positions = &mut values[l.robot_slot(JOINT_POSITIONS)];
        let _ = self
            .sim
            .movable_joint_states_into(positions, &mut self.joint_velocities);
        values[l.robot_slot(JOINT_VELOCITIES)].copy_from_slice(&self.joint_velocities);
        let tcp = self.sim.tcp_state();
        values[l.robot_slot(TCP_POSITION)].copy_from_slice(tcp.position.as_slice());
        values[l.robot_slot(TCP_VELOCITY)].copy_from_slice(tcp.linear_velocity.as_slice());
        values[l.robot_slot(GRIPPER_WIDTH)][0] = self.sim.gripper_width();
        values[l.desired_goal()].copy_from_slice(&self.goal);
        let (goals, rest) = values.split_at_mut(l.observation().start);
        let extras = &mut rest[l.task_slots().start - l.observation().start..];
        self.task.observe(
            &self.sim,
            &tcp,
            &self.goal,
            &mut goals[l.achieved_goal()],
            extras,
        );
        if !values.iter().all(|v| v.is_finite()) {
            return false;
        }
        for (o, v) in self.observation.iter_mut().zip(values.iter()) {
            *o = *v as f32;
        }
        true
    }

    /// The task's verdict on the current observation; `opening` is the gripper opening (0
    /// closed, 1 fully open) the last action asked for.
    fn judge(&self, opening: f64) -> Verdict {
        self.task.evaluate(&View {
            sim: &self.sim,
            robot: &self.robot,
            observation: &self.observation,
            layout: &self.layout,
            gripper_opening: opening,
        })
    }

    fn step_info(
        &self,
        verdict: &Verdict,
        unstable: bool,
        ik_error: f64,
        opening: f64,
    ) -> StepInfo {
        StepInfo {
            is_success: verdict.is_success,
            physics_unstable: unstable,
            goal_distance: verdict.goal_distance,
            gripper_opening: opening as f32,
            ik_position_error: ik_error,
            elapsed_steps: self.elapsed,
            arm_blocked: false,
            task: verdict.info,
        }
    }

    /// Copies the whole state: physics, random stream, goal, episode clock.
    pub fn snapshot(&self) -> EnvSnapshot {
        EnvSnapshot {
            sim: self.sim.snapshot(),
            rng: self.rng.clone(),
            seeded: self.seeded,
            goal: self.goal.clone(),
            elapsed: self.elapsed,
            status: self.status,
            observation: self.observation.clone(),
            info: self.info,
        }
    }

    /// Returns to a state taken with [`PandaEnv::snapshot`] (from this environment or one with
    /// an equal configuration); stepping on continues bit-identically.
    pub fn restore(&mut self, snapshot: &EnvSnapshot) -> Result<()> {
        if snapshot.observation.len() != self.observation.len()
            || snapshot.goal.len() != self.goal.len()
        {
            return Err(Error::SnapshotMismatch {
                reason: "its observation layout differs".into(),
            });
        }
        self.sim.restore(&snapshot.sim)?;
        self.rng.clone_from(&snapshot.rng);
        self.seeded = snapshot.seeded;
        self.goal.copy_from_slice(&snapshot.goal);
        self.elapsed = snapshot.elapsed;
        self.status = snapshot.status;
        self.observation.copy_from_slice(&snapshot.observation);
        self.info = snapshot.info;
        Ok(())
    }
}
