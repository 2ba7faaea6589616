//! [`PickAndPlaceEnv`]: one environment instance (reset, step, snapshot).
//!
//! Over 600 lines: episode drawing, the action controller, observation writing and rewards are
//! still together here; the architecture issue moves them into a Robot / Task split.

use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{ensure_len, Error, Result};
use crate::kinematics::{pointing_down, IkOptions, IkWorkspace};
use crate::physics::{JointControl, SimSnapshot, Simulation};
use crate::task::config::{ControlMode, EnvConfig};
use crate::task::observation::ObservationLayout;
use crate::task::reward::{closeness, RewardContext, RewardFunction, RewardTerms};

/// Overrides for one reset (Gymnasium's `options`); anything left `None` is drawn at random.
/// The random draws happen either way, so an override does not shift the rest of the episode's
/// randomness.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ResetOptions {
    /// Start position of the cube's centre (m).
    pub cube_position: Option<[f64; 3]>,
    /// Start yaw of the cube (rad).
    pub cube_yaw: Option<f64>,
    /// Goal position for the cube's centre (m).
    pub goal: Option<[f64; 3]>,
    /// Start configuration of the robot (one value per actuated joint).
    pub joint_positions: Option<Vec<f64>>,
}

impl ResetOptions {
    /// Fails with [`Error::InvalidOption`] naming the first bad value.
    fn validate(&self, num_dofs: usize) -> Result<()> {
        self.check_values(num_dofs).map_err(|e| match e {
            Error::NonFinite { what, value } => Error::InvalidOption {
                what,
                reason: format!("must be finite, got {value}"),
            },
            Error::WrongLength {
                what,
                expected,
                got,
            } => Error::InvalidOption {
                what,
                reason: format!("must have {expected} values, got {got}"),
            },
            other => other,
        })
    }

    fn check_values(&self, num_dofs: usize) -> Result<()> {
        let check = |what: &str, values: &[f64]| crate::error::ensure_all_finite(what, values);
        if let Some(p) = &self.cube_position {
            check("options.cube_position", p)?;
        }
        if let Some(y) = self.cube_yaw {
            check("options.cube_yaw", &[y])?;
        }
        if let Some(g) = &self.goal {
            check("options.goal", g)?;
        }
        if let Some(q) = &self.joint_positions {
            ensure_len("options.joint_positions", num_dofs, q.len())?;
            check("options.joint_positions", q)?;
        }
        Ok(())
    }
}

/// What a step or reset reports besides the observation (Gymnasium's `info`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepInfo {
    /// The cube is within the success threshold of the goal.
    pub is_success: bool,
    /// Both fingers squeeze the cube with at least the grasp force.
    pub is_grasped: bool,
    /// Grasped and touching neither the floor nor the platform.
    pub is_lifted: bool,
    /// Released, at rest, on the platform and within the threshold.
    pub is_placed: bool,
    /// The physics blew up in this step (non-finite state or runaway speeds): the episode is
    /// truncated and the observation is the last valid one.
    pub physics_unstable: bool,
    /// Distance from the cube to the goal (m).
    pub goal_distance: f64,
    /// Goal-free inputs of the reward (pass them back to `compute_reward`).
    pub context: RewardContext,
    /// The dense reward's weighted terms (zero for the sparse reward).
    pub terms: RewardTerms,
    /// Position error (m) the inverse kinematics left on the TCP target (`ee` control).
    pub ik_position_error: f64,
    /// Steps taken in this episode.
    pub elapsed_steps: u32,
    /// The kinematic arm ([`crate::ArmModel::Kinematic`]) refused part of this step's motion
    /// because a link would have entered the floor or the platform; always false for the
    /// dynamic arm.
    pub arm_blocked: bool,
}

/// The outcome of one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Transition {
    /// The reward.
    pub reward: f32,
    /// The episode ended by reaching the goal (only with `terminate_on_success`).
    pub terminated: bool,
    /// The episode was cut: time limit, or the physics blew up.
    pub truncated: bool,
    /// Everything else.
    pub info: StepInfo,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Status {
    NeverReset,
    Running,
    /// The physics blew up; only a reset helps.
    Unstable,
}

/// Everything [`PickAndPlaceEnv::restore`] needs to continue bit-identically.
#[derive(Debug, Clone)]
pub struct EnvSnapshot {
    sim: SimSnapshot,
    rng: ChaCha8Rng,
    seeded: bool,
    goal: Vector3<f64>,
    elapsed: u32,
    status: Status,
    observation: Vec<f32>,
    info: StepInfo,
}

/// Franka Panda pick-and-place: pick the cube up from the floor and put it down on the goal on
/// the platform (or hold it at a goal in the air).
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
/// with a velocity feed-forward, so the arm moves at a steady speed. The gripper command is an
/// absolute opening: -1 closes with `sim.motors.gripper_force` (a friction grasp), +1 opens fully
/// (0.08 m), values between ask for a proportional opening.
///
/// # Observation space
/// The goal dict (`observation`, `achieved_goal`, `desired_goal`) laid out in one flat `f32`
/// vector; every slot is listed in [`crate::task::observation`].
///
/// # Rewards
/// `sparse` (default): -1 until the cube is within `success_threshold` (0.05 m) of the goal, then
/// 0. `dense`: staged terms, see [`crate::task::reward`]. Both are reproduced exactly by
/// [`RewardFunction::compute_batch`] from the goals and the info's [`RewardContext`].
///
/// # Starting state
/// The robot in its ready pose (plus `randomization.joint_noise`), the gripper open, the cube on
/// the floor at a uniform position in `pick_region` with a uniform yaw in `cube_yaw_range`, the
/// goal uniform in `goal_region` at the height of a cube resting on the platform, or with
/// probability `goal_air_probability` up to `goal_air_height` above it.
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
/// [`StepInfo`]: `is_success`, `is_grasped`, `is_lifted`, `is_placed`, `physics_unstable`, the goal
/// distance, the reward terms, the IK error and the step count.
pub struct PickAndPlaceEnv {
    config: EnvConfig,
    index: u64,
    sim: Simulation,
    initial: SimSnapshot,
    layout: ObservationLayout,
    reward_fn: RewardFunction,
    rng: ChaCha8Rng,
    seeded: bool,
    status: Status,
    elapsed: u32,
    goal: Vector3<f64>,
    ready: Vec<f64>,
    /// The dofs an action drives besides the gripper, in order.
    arm_dofs: Vec<usize>,
    hand_down: UnitQuaternion<f64>,
    ik_options: IkOptions,
    ik_workspace: IkWorkspace,
    slots: SlotRanges,
    observation: Vec<f32>,
    info: StepInfo,
    // Scratch buffers, so a step does not allocate.
    q: Vec<f64>,
    targets: Vec<f64>,
    controls: Vec<JointControl>,
    joint_positions: Vec<f64>,
    joint_velocities: Vec<f64>,
}

impl std::fmt::Debug for PickAndPlaceEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PickAndPlaceEnv")
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

impl PickAndPlaceEnv {
    /// Builds environment 0 (see [`PickAndPlaceEnv::with_index`]).
    pub fn new(config: EnvConfig) -> Result<Self> {
        Self::with_index(config, 0)
    }

    /// Builds the environment that draws from random stream `index` (environment `index` of a
    /// vector environment behaves exactly like this one).
    pub fn with_index(config: EnvConfig, index: u64) -> Result<Self> {
        config.validate()?;
        let sim = Simulation::new(config.sim_config()?)?;
        let gripper_dof = sim.gripper_dof().ok_or_else(|| Error::InvalidConfig {
            field: "sim.robot_urdf".into(),
            reason: "the pick-and-place task needs a robot with a prismatic gripper joint".into(),
        })?;
        let num_dofs = sim.model().num_dofs();
        let arm_dofs: Vec<usize> = (0..num_dofs).filter(|&d| d != gripper_dof).collect();
        let ready = sim.joint_positions();
        let hand_down = pointing_down(&sim.model().tcp_pose(&ready, sim.base_pose())?.rotation);
        let layout = ObservationLayout::new(sim.movable_joints().len());
        let initial = sim.snapshot();
        let reward_fn = RewardFunction {
            reward_type: config.reward_type,
            success_threshold: config.success_threshold,
            weights: config.reward_weights,
        };
        let num_joints = layout.num_joints();
        let flat_dim = layout.flat_dim();
        Ok(Self {
            config,
            index,
            sim,
            initial,
            layout,
            reward_fn,
            rng: env_rng(0, index),
            seeded: false,
            status: Status::NeverReset,
            elapsed: 0,
            goal: Vector3::zeros(),
            ready,
            arm_dofs,
            hand_down,
            ik_options: IkOptions {
                max_iterations: 30,
                ..IkOptions::default()
            },
            ik_workspace: IkWorkspace::default(),
            slots: SlotRanges::new(&layout),
            observation: vec![0.0; flat_dim],
            info: StepInfo::default(),
            q: vec![0.0; num_dofs],
            targets: vec![0.0; num_dofs],
            controls: vec![JointControl::position(0.0); num_dofs],
            joint_positions: vec![0.0; num_joints],
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

    /// Where everything sits in the observation.
    pub fn layout(&self) -> &ObservationLayout {
        &self.layout
    }

    /// Length of an action: 4 for `ee`, one per actuated joint (8 for the Panda) for `joints`.
    pub fn action_dim(&self) -> usize {
        match self.config.control_mode {
            ControlMode::Ee => 4,
            ControlMode::Joints => self.arm_dofs.len() + 1,
        }
    }

    /// Seconds of simulated time per step (the control period).
    pub fn dt(&self) -> f64 {
        self.sim.control_period()
    }

    /// The reward function ([`RewardFunction::compute_batch`] is `compute_reward`).
    pub fn reward_function(&self) -> &RewardFunction {
        &self.reward_fn
    }

    /// The current observation (flat layout).
    pub fn observation(&self) -> &[f32] {
        &self.observation
    }

    /// The info of the last reset or step.
    pub fn info(&self) -> &StepInfo {
        &self.info
    }

    /// The current goal for the cube's centre (m).
    pub fn goal(&self) -> Vector3<f64> {
        self.goal
    }

    /// Steps taken in the current episode.
    pub fn elapsed_steps(&self) -> u32 {
        self.elapsed
    }

    /// The orientation the `ee` control holds the TCP at.
    pub fn hand_down(&self) -> UnitQuaternion<f64> {
        self.hand_down
    }

    /// The simulation, for introspection (robot model, link states, kinematics).
    pub fn simulation(&self) -> &Simulation {
        &self.sim
    }

    /// The simulation, to drive the robot directly; the next [`PickAndPlaceEnv::step`] overrides
    /// the joint commands. The observation follows at the next step or reset, or at once with
    /// [`PickAndPlaceEnv::refresh`].
    pub fn simulation_mut(&mut self) -> &mut Simulation {
        &mut self.sim
    }

    /// Recomputes the observation and info from the simulation as it is now (after changing
    /// it through [`PickAndPlaceEnv::simulation_mut`]); the step count is unchanged.
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
        let opening = self.info.context.gripper_opening as f64;
        self.info = self.evaluate(false, ik_error, opening).0;
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
        let config = &self.config;
        let rng = &mut self.rng;
        let mut draw = || rng.random::<f64>();
        // Always the same draws in the same order: overrides and switched-off randomisation do
        // not shift the others.
        let cube_xy = config.pick_region.lerp([draw(), draw()]);
        let yaw_u = draw();
        let goal_xy = config.goal_region.lerp([draw(), draw()]);
        let air_u = draw();
        let air_height_u = draw();
        let size_u = draw();
        let mass_u = draw();
        let friction_u = draw();
        let pick = |range: Option<[f64; 2]>, default: f64, u: f64| {
            range.map_or(default, |r| r[0] + (r[1] - r[0]) * u)
        };
        let r = &config.randomization;
        let cube = &config.sim.cube;
        let size = pick(r.cube_size, cube.size, size_u);
        let mass = pick(r.cube_mass, cube.mass, mass_u);
        let friction = pick(r.cube_friction, cube.friction, friction_u);
        // The start configuration goes into the targets scratch buffer: no allocation.
        let q = &mut self.targets;
        q.copy_from_slice(&self.ready);
        for &dof in &self.arm_dofs {
            let u = draw();
            q[dof] += r.joint_noise * (2.0 * u - 1.0);
        }
        let yaw = config.cube_yaw_range[0]
            + (config.cube_yaw_range[1] - config.cube_yaw_range[0]) * yaw_u;
        let platform_top = config.sim.platform.top_center[2];
        let mut goal = Vector3::new(goal_xy[0], goal_xy[1], platform_top + size / 2.0);
        if air_u < config.goal_air_probability {
            let [low, high] = config.goal_air_height;
            goal.z += low + (high - low) * air_height_u;
        }

        let cube_position = options.cube_position.map_or(
            Vector3::new(cube_xy[0], cube_xy[1], size / 2.0),
            Vector3::from,
        );
        let cube_yaw = options.cube_yaw.unwrap_or(yaw);
        if let Some(g) = options.goal {
            goal = Vector3::from(g);
        }
        if let Some(start) = &options.joint_positions {
            q.copy_from_slice(start);
        }

        self.sim.restore(&self.initial)?;
        if r.cube_size.is_some() || r.cube_mass.is_some() || r.cube_friction.is_some() {
            self.sim.set_cube_properties(size, mass, friction)?;
        }
        self.sim.set_joint_positions(&self.targets)?;
        let width = self.sim.gripper_width();
        self.sim.set_gripper(width, None)?;
        self.sim.set_cube_pose(
            &cube_position,
            &UnitQuaternion::from_axis_angle(&Vector3::z_axis(), cube_yaw),
        )?;
        self.goal = goal;
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
        let opening = self.gripper_opening(self.sim.gripper_width());
        self.info = self.evaluate(false, f64::NAN, opening).0;
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

    /// Whether [`PickAndPlaceEnv::step`] would refuse for lack of a reset.
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

    /// [`PickAndPlaceEnv::step`] for an action already checked by
    /// [`PickAndPlaceEnv::check_action`] on a running environment.
    pub(crate) fn step_checked(&mut self, action: &[f32]) -> Transition {
        let (ik_error, width) = self.plan_action(action);
        let blocked_before = self.sim.arm_blocked_steps();
        self.drive(width);
        self.elapsed = self.elapsed.saturating_add(1);
        let stable = self.is_stable() && self.write_observation();
        if !stable {
            self.status = Status::Unstable;
        }
        let opening = self.gripper_opening(width);
        let (mut info, reward) = self.evaluate(!stable, ik_error, opening);
        info.arm_blocked = self.sim.arm_blocked_steps() > blocked_before;
        self.info = info;
        Transition {
            reward,
            terminated: self.config.terminate_on_success && info.is_success,
            truncated: !stable
                || self
                    .config
                    .max_episode_steps
                    .is_some_and(|limit| self.elapsed >= limit),
            info,
        }
    }

    /// Turns `action` into joint targets (`self.targets`, from the measured `self.q`), limited
    /// to what the joints' velocity limits allow in one control period; returns the IK's
    /// remaining position error and the gripper opening asked for.
    fn plan_action(&mut self, action: &[f32]) -> (f64, f64) {
        let a = |i: usize| action[i].clamp(-1.0, 1.0) as f64;
        // The sim is finite here (a blow-up stops the episode), so these cannot fail.
        let _ = self.sim.joint_positions_into(&mut self.q);
        self.targets.copy_from_slice(&self.q);
        let mut ik_error = 0.0;
        let gripper_action = match self.config.control_mode {
            ControlMode::Ee => {
                let [low, high] = self.config.ee_workspace;
                let tcp = self.sim.tcp_state().position;
                let mut target = Vector3::zeros();
                for i in 0..3 {
                    target[i] = (tcp[i] + a(i) * self.config.ee_step).clamp(low[i], high[i]);
                }
                let lowest = self.config.surface_height(target.x, target.y)
                    + self.config.ee_surface_clearance;
                target.z = target.z.max(lowest);
                if let Ok(report) = self.sim.model().inverse_kinematics_in(
                    &target,
                    Some(&self.hand_down),
                    &self.q,
                    self.sim.base_pose(),
                    &self.ik_options,
                    &mut self.ik_workspace,
                ) {
                    for &dof in &self.arm_dofs {
                        self.targets[dof] = self.ik_workspace.q[dof];
                    }
                    ik_error = report.position_error;
                }
                a(3)
            }
            ControlMode::Joints => {
                for (i, &dof) in self.arm_dofs.iter().enumerate() {
                    self.targets[dof] = self.q[dof] + a(i) * self.config.joint_step;
                }
                a(self.arm_dofs.len())
            }
        };
        // Slow the whole motion down until every joint keeps within its velocity limit:
        // clamping joints one by one would bend the hand's path away from the commanded
        // direction (seen as centimetre-scale sideways swerves on fast descents).
        let period = self.sim.control_period();
        let mut slowdown = 1.0f64;
        for &dof in &self.arm_dofs {
            let joint = self.sim.model().actuated_joints()[dof];
            let limit = self.sim.model().joints()[joint].max_velocity * period;
            if limit > 0.0 {
                slowdown = slowdown.max((self.targets[dof] - self.q[dof]).abs() / limit);
            }
        }
        for &dof in &self.arm_dofs {
            self.targets[dof] = self.q[dof] + (self.targets[dof] - self.q[dof]) / slowdown;
        }
        let width = (gripper_action + 1.0) / 2.0 * self.sim.gripper_max_width();
        (ik_error, width)
    }

    /// Steps the physics through one control period, moving the arm's position targets
    /// linearly from the measured configuration to the planned one with a matching velocity
    /// feed-forward: the arm moves at a steady speed instead of lunging at a target a whole
    /// period away (which drew peaks of 2 m/s and 40 m/s^2 at the hand and shook the cube
    /// loose).
    fn drive(&mut self, gripper_width: f64) {
        let substeps = self.sim.config().solver.substeps;
        let period = self.sim.control_period();
        for k in 1..=substeps {
            let fraction = k as f64 / substeps as f64;
            for (control, (&start, &end)) in self
                .controls
                .iter_mut()
                .zip(self.q.iter().zip(self.targets.iter()))
            {
                *control = JointControl::Position {
                    target: start + fraction * (end - start),
                    target_velocity: (end - start) / period,
                    max_force: None,
                };
            }
            let _ = self.sim.set_joint_controls(&self.controls);
            let _ = self.sim.set_gripper(gripper_width, None);
            self.sim.step();
        }
    }

    fn is_stable(&self) -> bool {
        let t = &self.config.thresholds;
        let (v, w) = self.sim.max_body_speeds();
        // NaN fails both comparisons.
        v <= t.unstable_linear_speed && w <= t.unstable_angular_speed && self.sim.is_finite()
    }

    /// Writes the observation; false (and the previous observation kept) if any value is not
    /// finite.
    fn write_observation(&mut self) -> bool {
        let _ = self
            .sim
            .movable_joint_states_into(&mut self.joint_positions, &mut self.joint_velocities);
        let tcp = self.sim.tcp_state();
        let cube = self.sim.cube_state();
        let width = self.sim.gripper_width();
        let mut orientation = cube.orientation.coords;
        if orientation.w < 0.0 {
            orientation = -orientation;
        }
        let relative = cube.position - tcp.position;
        let sources: [&[f64]; 12] = [
            cube.position.as_slice(),
            self.goal.as_slice(),
            &self.joint_positions,
            &self.joint_velocities,
            tcp.position.as_slice(),
            tcp.linear_velocity.as_slice(),
            std::slice::from_ref(&width),
            cube.position.as_slice(),
            &[orientation.x, orientation.y, orientation.z, orientation.w],
            cube.linear_velocity.as_slice(),
            cube.angular_velocity.as_slice(),
            relative.as_slice(),
        ];
        if !sources.iter().all(|s| s.iter().all(|v| v.is_finite())) {
            return false;
        }
        for (o, v) in self
            .observation
            .iter_mut()
            .zip(sources.iter().flat_map(|s| s.iter()))
        {
            *o = *v as f32;
        }
        true
    }

    /// A gripper width as a fraction of the full opening, in [0, 1].
    fn gripper_opening(&self, width: f64) -> f64 {
        let max = self.sim.gripper_max_width();
        if max > 0.0 {
            (width / max).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The info and the reward for the current observation; `opening` is the gripper opening
    /// (0 closed, 1 fully open) the last action asked for.
    fn evaluate(&self, unstable: bool, ik_error: f64, opening: f64) -> (StepInfo, f32) {
        let t = &self.config.thresholds;
        let touch = self.sim.cube_touch();
        let l = &self.layout;
        let obs = &self.observation;
        let cube_speed = norm(&obs[self.slots.cube_linear_velocity.clone()]);
        let cube_spin = norm(&obs[self.slots.cube_angular_velocity.clone()]);
        let reach_distance = norm(&obs[self.slots.cube_relative_position.clone()]);
        let cube_z = obs[l.achieved_goal()][2] as f64;
        let (size, _, _) = self.sim.cube_properties();
        let platform_height = self.config.sim.platform.top_center[2];
        let is_grasped = touch.finger_forces.iter().all(|&f| f >= t.grasp_force);
        let lift = if platform_height > 0.0 {
            ((cube_z - size / 2.0) / platform_height).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let w = &self.config.reward_weights;
        let context = RewardContext {
            reach: w.reach as f32 * closeness(reach_distance),
            grasp: if is_grasped { w.grasp as f32 } else { 0.0 },
            lift: w.lift as f32 * lift as f32,
            cube_released: !touch.robot_touching(),
            cube_at_rest: cube_speed < t.rest_linear_speed && cube_spin < t.rest_angular_speed,
            cube_on_platform: touch.platform,
            gripper_opening: opening as f32,
        };
        let verdict =
            self.reward_fn
                .evaluate(&obs[l.achieved_goal()], &obs[l.desired_goal()], &context);
        let info = StepInfo {
            is_success: verdict.is_success,
            is_grasped,
            is_lifted: is_grasped && !touch.floor && !touch.platform,
            is_placed: verdict.is_placed,
            physics_unstable: unstable,
            goal_distance: verdict.distance,
            context,
            terms: verdict.terms,
            ik_position_error: ik_error,
            elapsed_steps: self.elapsed,
            arm_blocked: false,
        };
        (info, verdict.reward)
    }

    /// Copies the whole state: physics, random stream, goal, episode clock.
    pub fn snapshot(&self) -> EnvSnapshot {
        EnvSnapshot {
            sim: self.sim.snapshot(),
            rng: self.rng.clone(),
            seeded: self.seeded,
            goal: self.goal,
            elapsed: self.elapsed,
            status: self.status,
            observation: self.observation.clone(),
            info: self.info,
        }
    }

    /// Returns to a state taken with [`PickAndPlaceEnv::snapshot`] (from this environment or one
    /// with an equal configuration); stepping on continues bit-identically.
    pub fn restore(&mut self, snapshot: &EnvSnapshot) -> Result<()> {
        if snapshot.observation.len() != self.observation.len() {
            return Err(Error::SnapshotMismatch {
                reason: "its observation layout differs".into(),
            });
        }
        self.sim.restore(&snapshot.sim)?;
        self.rng.clone_from(&snapshot.rng);
        self.seeded = snapshot.seeded;
        self.goal = snapshot.goal;
        self.elapsed = snapshot.elapsed;
        self.status = snapshot.status;
        self.observation.copy_from_slice(&snapshot.observation);
        self.info = snapshot.info;
        Ok(())
    }
}

/// The observation slots the task reads every step, looked up once.
#[derive(Debug, Clone)]
struct SlotRanges {
    cube_linear_velocity: std::ops::Range<usize>,
    cube_angular_velocity: std::ops::Range<usize>,
    cube_relative_position: std::ops::Range<usize>,
}

impl SlotRanges {
    fn new(layout: &ObservationLayout) -> Self {
        let slot = |name: &str| layout.slot(name).unwrap_or(0..0);
        Self {
            cube_linear_velocity: slot("cube_linear_velocity"),
            cube_angular_velocity: slot("cube_angular_velocity"),
            cube_relative_position: slot("cube_relative_position"),
        }
    }
}

fn norm(v: &[f32]) -> f64 {
    v.iter()
        .map(|&x| (x as f64) * (x as f64))
        .sum::<f64>()
        .sqrt()
}
