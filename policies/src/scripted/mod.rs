//! The scripted experts, one per task, closed-loop and stateless, behind one policy type
//! ([`ScriptedPolicy`]) that turns an expert's [`Decision`] (where the hand goes, and how it
//! is turned) into an action in any action mode (`ee`, `ee_pose`, `joints`).
//!
//! Every action is a function of the current observation alone: the phase is recognised from
//! where the hand, the fingers and the objects are, not remembered. So the policy can take over
//! any environment at any step, and it recovers by itself when the cube slips or a grasp
//! misses (the cube is then "not in the hand" again, and the approach starts over).
//!
//! An expert is a type implementing [`Expert`] (the mirror of the core's `Task`), in a file of
//! its own: [`ReachExpert`] moves the open hand to the goal; [`PickAndPlaceExpert`] runs the
//! grasp sequence (`grasp.rs`: open, move above, descend, close, lift, carry, lower, release,
//! retreat), also for `lift`; [`StackExpert`] runs it twice with a gentler grasp;
//! [`PushExpert`] lines the closed hand up behind the cube and pushes; [`SlideExpert`] grasps
//! the cube, slides it towards the goal and lets go at the speed that carries it there;
//! [`FlipExpert`] turns the cube by pushing it with the closed fingers; [`PegInsertionExpert`]
//! picks the peg up across its width, turns it onto the hole's axis and pushes it in, steering
//! its leading end; [`PickObjectExpert`] picks an object of any shape by the grasp the task
//! plans for it and carries it to the goal; [`OpenDrawerExpert`] closes the fingers on a
//! drawer's knob and pulls it open. [`expert_for`] is the
//! list, one line per task of the core's registry (`TaskKind`; the compiler asks for a new
//! task's line).

mod flip;
mod grasp;
mod open_drawer;
mod params;
mod peg_insertion;
mod pick_and_place;
mod pick_object;
mod push;
mod reach;
mod slide;
mod stack;

pub use flip::FlipExpert;
pub use open_drawer::OpenDrawerExpert;
pub use params::ScriptedParams;
pub use peg_insertion::PegInsertionExpert;
pub use pick_and_place::PickAndPlaceExpert;
pub use pick_object::PickObjectExpert;
pub use push::PushExpert;
pub use reach::ReachExpert;
pub use slide::SlideExpert;
pub use stack::StackExpert;

use nalgebra::{Isometry3, Matrix3, UnitQuaternion, Vector3};
use panda_rapier_core::env::{make_task, ControlMode, EeFrame, EnvConfig};
use panda_rapier_core::task::observation::{
    GRIPPER_WIDTH, JOINT_POSITIONS, JOINT_VELOCITIES, TCP_POSITION, TCP_VELOCITY,
};
use panda_rapier_core::task::{ObservationLayout, TaskKind};
use panda_rapier_core::{
    Controller, CubeConfig, Error, IkOptions, IkWorkspace, Result, RobotModel, RobotSpec,
};

/// What an expert is doing, recognised from the observation: a name from an open set (each
/// expert's module adds its phases as constants, `Phase::CARRY`, `Phase::PUSH`, ...).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Phase(&'static str);

impl Phase {
    /// A phase called `name` (snake case).
    pub const fn new(name: &'static str) -> Self {
        Self(name)
    }

    /// The phase's name in snake case.
    pub fn as_str(self) -> &'static str {
        self.0
    }
}

/// The part of the scripted policy that differs between tasks, the mirror of the core's
/// `Task`: where the hand goes for an observation. Experts are stateless (the phase is
/// recognised, not remembered).
pub trait Expert: Send + Sync + std::fmt::Debug {
    /// The decision for one observation, already checked for its length and finite values.
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision>;
}

/// The expert of each task: one line per task (the compiler asks for a new task's line).
pub fn expert_for(task: TaskKind) -> &'static dyn Expert {
    match task {
        TaskKind::PickAndPlace => &PickAndPlaceExpert,
        TaskKind::Reach => &ReachExpert,
        TaskKind::Lift => &PickAndPlaceExpert,
        TaskKind::Stack => &StackExpert,
        TaskKind::Push => &PushExpert,
        TaskKind::Slide => &SlideExpert,
        TaskKind::Flip => &FlipExpert,
        TaskKind::PegInsertion => &PegInsertionExpert,
        TaskKind::PickObject => &PickObjectExpert,
        TaskKind::OpenDrawer => &OpenDrawerExpert,
    }
}

/// Where the policy's inputs sit in the flat observation.
#[derive(Debug, Clone)]
struct Slots {
    achieved: std::ops::Range<usize>,
    desired: std::ops::Range<usize>,
    joint_positions: std::ops::Range<usize>,
    joint_velocities: std::ops::Range<usize>,
    tcp: std::ops::Range<usize>,
    tcp_velocity: std::ops::Range<usize>,
    width: usize,
    /// The cube's orientation, in the tasks that observe it.
    cube_orientation: Option<std::ops::Range<usize>>,
    /// `stack`: the two cubes' orientations.
    stack_orientations: Option<[std::ops::Range<usize>; 2]>,
}

impl Slots {
    fn new(layout: &ObservationLayout) -> Self {
        Self {
            achieved: layout.achieved_goal(),
            desired: layout.desired_goal(),
            joint_positions: layout.robot_slot(JOINT_POSITIONS),
            joint_velocities: layout.robot_slot(JOINT_VELOCITIES),
            tcp: layout.robot_slot(TCP_POSITION),
            tcp_velocity: layout.robot_slot(TCP_VELOCITY),
            width: layout.robot_slot(GRIPPER_WIDTH).start,
            cube_orientation: layout.slot("cube_orientation"),
            stack_orientations: layout
                .slot("cube1_orientation")
                .zip(layout.slot("cube2_orientation"))
                .map(|(a, b)| [a, b]),
        }
    }
}

/// The three values of an observation slot, as a vector.
fn vector_at(observation: &[f32], slot: &std::ops::Range<usize>) -> Vector3<f64> {
    let o = &observation[slot.start..slot.start + 3];
    Vector3::new(o[0] as f64, o[1] as f64, o[2] as f64)
}

/// The angle `a` wrapped into `(-pi/2, pi/2]`: a direction without its sense.
pub(super) fn wrap_half_turn(a: f64) -> f64 {
    use std::f64::consts::PI;
    let mut a = a.rem_euclid(PI);
    if a > PI / 2.0 {
        a -= PI;
    }
    a
}

/// What the controller decided for one observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// The recognised phase.
    pub phase: Phase,
    /// Where the tool centre point should go (world frame).
    pub tcp_target: Vector3<f64>,
    /// Largest action magnitude per axis for the motion.
    pub speed: f64,
    /// Fraction of the remaining distance to cover in one step: below 1 where the hand must
    /// arrive without overshooting (the arm carries momentum from one step into the next).
    pub gain: f64,
    /// Gripper command: +1 open, -1 squeeze.
    pub gripper: f32,
    /// The orientation the hand (the TCP frame) should turn to; `None` keeps the robot's
    /// `hand_down`. Followed in `ee_pose` and `joints` control (an `ee` action cannot turn the
    /// hand).
    pub hand: Option<UnitQuaternion<f64>>,
}

/// What every expert reads besides the observation: the configuration, the parameters, where
/// the inputs sit in the observation and the robot's facts.
#[derive(Debug, Clone)]
pub struct ExpertContext {
    config: EnvConfig,
    params: ScriptedParams,
    layout: ObservationLayout,
    slots: Slots,
    observation_dim: usize,
    cube_half: f64,
    open_width: f64,
    hand_down: UnitQuaternion<f64>,
    arm_dof_count: usize,
}

impl ExpertContext {
    /// The environment's configuration.
    pub fn config(&self) -> &EnvConfig {
        &self.config
    }

    /// The parameters in use.
    pub fn params(&self) -> &ScriptedParams {
        &self.params
    }

    /// Where the observation slot `name` (`"cube_linear_velocity"`, ...) sits in the flat
    /// observation, if the task has it.
    pub fn slot(&self, name: &str) -> Option<std::ops::Range<usize>> {
        self.layout.slot(name)
    }

    /// Positions of the finger joints among the observed joints (those driven by the
    /// gripper dof and its mimic).
    fn finger_slots(&self) -> std::ops::Range<usize> {
        self.arm_dof_count..self.slots.joint_positions.len()
    }

    /// The cube and where it goes, in the tasks with one cube.
    fn single_target(&self, cube: Vector3<f64>, goal: Vector3<f64>) -> grasp::Target {
        grasp::Target {
            cube,
            goal,
            goal_surface: self.config.surface_height(goal.x, goal.y),
            hover_height: self.params.hover_height,
            careful: false,
            rotation: None,
        }
    }

    /// Whether the cube, moved sideways by `(dx, dy)`, keeps its bottom `carry_clearance`
    /// above every surface under its footprint.
    fn clears_surfaces(&self, cube: Vector3<f64>, dx: f64, dy: f64) -> bool {
        let h = self.cube_half;
        let bottom = cube.z - h;
        let (x, y) = (cube.x + dx, cube.y + dy);
        [(-h, -h), (-h, h), (h, -h), (h, h), (0.0, 0.0)]
            .iter()
            .all(|&(ox, oy)| {
                self.config.surface_height(x + ox, y + oy) + self.params.carry_clearance < bottom
            })
    }

    /// How `rotation` (the cube's, if known) sits under the hand.
    fn grip(&self, rotation: Option<&Matrix3<f64>>) -> grasp::Grip {
        let size = 2.0 * self.cube_half;
        let Some(m) = rotation else {
            return grasp::Grip {
                upright: 1.0,
                extent: size,
            };
        };
        // The fingers close along the hand's y axis.
        let closing = self.hand_down * Vector3::y();
        grasp::Grip {
            upright: (0..3).map(|i| m[(2, i)].abs()).fold(0.0, f64::max),
            extent: size * (0..3).map(|i| m.column(i).dot(&closing).abs()).sum::<f64>(),
        }
    }
}

/// The scripted policy for one environment configuration, in any action mode: the task's
/// [`Expert`] decides, the policy acts. Actions depend on the observation only (see the
/// module documentation).
#[derive(Debug, Clone)]
pub struct ScriptedPolicy {
    cx: ExpertContext,
    expert: &'static dyn Expert,
    action_dim: usize,
    // Joint control: the robot's kinematics, where each dof's position sits among the
    // observed joints, and scratch memory so acting does not allocate.
    model: RobotModel,
    base: Isometry3<f64>,
    dof_slots: Vec<usize>,
    arm_dofs: Vec<usize>,
    ik_options: IkOptions,
    ik_workspace: IkWorkspace,
    q: Vec<f64>,
}

impl ScriptedPolicy {
    /// The policy for environments built from `config`, with the default parameters.
    pub fn new(config: &EnvConfig) -> Result<Self> {
        Self::with_params(config, ScriptedParams::default())
    }

    /// The policy with explicit parameters.
    pub fn with_params(config: &EnvConfig, params: ScriptedParams) -> Result<Self> {
        config.validate()?;
        // The robot's facts (kinematics, base pose, start pose, joint order) exactly as the
        // environment sees them, without building a world.
        let robot = RobotSpec::new(&config.sim_config()?)?;
        let model = robot.model().clone();
        let movable = robot.movable_joints();
        let dof_slots = model
            .actuated_joints()
            .iter()
            .map(|j| movable.iter().position(|m| m == j).unwrap_or(0))
            .collect();
        let task = make_task(config);
        let layout = ObservationLayout::new(
            movable.len(),
            task.goal_dim(),
            task.goal_descriptions(),
            task.observation_slots(),
        );
        let action_dim = Controller::action_dim(config.control_mode, &robot);
        Ok(Self {
            cx: ExpertContext {
                config: config.clone(),
                params,
                slots: Slots::new(&layout),
                layout: layout.clone(),
                observation_dim: layout.flat_dim(),
                cube_half: config.cube().map_or(CubeConfig::default().size, |c| c.size) / 2.0,
                open_width: robot.gripper().max_width,
                hand_down: *robot.hand_down(),
                arm_dof_count: robot.arm_dofs().len(),
            },
            expert: expert_for(config.task.kind()),
            action_dim,
            base: *robot.base_pose(),
            dof_slots,
            arm_dofs: robot.arm_dofs().to_vec(),
            ik_options: IkOptions {
                max_iterations: 30,
                ..IkOptions::default()
            },
            ik_workspace: IkWorkspace::default(),
            q: robot.start_configuration().to_vec(),
            model,
        })
    }

    /// Length of one action (4 for `ee`, 8 for `joints` control).
    pub fn action_dim(&self) -> usize {
        self.action_dim
    }

    /// Length of one observation.
    pub fn observation_dim(&self) -> usize {
        self.cx.observation_dim
    }

    /// The parameters in use.
    pub fn params(&self) -> &ScriptedParams {
        &self.cx.params
    }

    /// What the expert reads besides the observation.
    pub fn context(&self) -> &ExpertContext {
        &self.cx
    }

    /// Recognises the phase and picks the hand's target for one flat observation.
    pub fn decide(&self, observation: &[f32]) -> Result<Decision> {
        self.check(observation)?;
        self.expert.decide(&self.cx, observation)
    }

    /// Writes the action for one observation into `action` (length [`Self::action_dim`]) and
    /// returns the recognised phase.
    pub fn act(&mut self, observation: &[f32], action: &mut [f32]) -> Result<Phase> {
        let decision = self.decide(observation)?;
        if action.len() != self.action_dim() {
            return Err(Error::WrongLength {
                what: "action buffer".into(),
                expected: self.action_dim(),
                got: action.len(),
            });
        }
        let cx = &self.cx;
        let tcp = vector_at(observation, &cx.slots.tcp);
        let lead = cx.params.velocity_lead / cx.config.control_frequency;
        let ahead = tcp + vector_at(observation, &cx.slots.tcp_velocity) * lead;
        let ee_step = cx.config.ee_step;
        let limit = decision.speed;
        let gain = decision.gain;
        let delta =
            (decision.tcp_target - ahead).map(|d| (gain * d / ee_step).clamp(-limit, limit));
        let hand = decision.hand.unwrap_or(cx.hand_down);
        for (d, &slot) in self.dof_slots.iter().enumerate() {
            self.q[d] = observation[cx.slots.joint_positions.start + slot] as f64;
        }
        match cx.config.control_mode {
            ControlMode::Ee => {
                for i in 0..3 {
                    action[i] = delta[i] as f32;
                }
            }
            ControlMode::EePose => {
                // The rotation from the hand's measured orientation to the wanted one, in the
                // frame the actions are given in.
                let now = self
                    .model
                    .tcp_pose(&self.q, &self.base)
                    .map_or(hand, |pose| pose.rotation);
                let (delta, rotation) = match cx.config.ee_frame {
                    EeFrame::Base => (delta, (hand * now.inverse()).scaled_axis()),
                    EeFrame::Hand => (now.inverse() * delta, (now.inverse() * hand).scaled_axis()),
                };
                let rot_step = cx.config.ee_rot_step;
                for i in 0..3 {
                    action[i] = delta[i] as f32;
                    action[3 + i] = (rotation[i] / rot_step).clamp(-1.0, 1.0) as f32;
                }
            }
            ControlMode::Joints => {
                let target = tcp + delta * ee_step;
                let joint_step = cx.config.joint_step;
                let solved = self.model.inverse_kinematics_in(
                    &target,
                    Some(&hand),
                    &self.q,
                    &self.base,
                    &self.ik_options,
                    &mut self.ik_workspace,
                );
                let change = |dof: usize| match solved {
                    Ok(_) => (self.ik_workspace.q[dof] - self.q[dof]) / joint_step,
                    Err(_) => 0.0,
                };
                // Scale all joints together so the hand keeps its direction when some joint
                // would need more than one full step.
                let largest = self
                    .arm_dofs
                    .iter()
                    .map(|&dof| change(dof).abs())
                    .fold(1.0, f64::max);
                for (i, &dof) in self.arm_dofs.iter().enumerate() {
                    action[i] = (change(dof) / largest) as f32;
                }
            }
        }
        let last = action.len() - 1;
        action[last] = decision.gripper;
        Ok(decision.phase)
    }

    /// [`Self::act`] for a batch: `observations` holds `n` rows, `actions` receives `n` rows.
    pub fn act_batch(&mut self, observations: &[f32], actions: &mut [f32]) -> Result<()> {
        let dim = self.cx.observation_dim;
        let n = observations.len() / dim.max(1);
        if observations.len() != n * dim {
            return Err(Error::WrongLength {
                what: "observations (n x observation_dim)".into(),
                expected: (n + 1) * dim,
                got: observations.len(),
            });
        }
        let a = self.action_dim();
        if actions.len() != n * a {
            return Err(Error::WrongLength {
                what: "actions (n x action_dim)".into(),
                expected: n * a,
                got: actions.len(),
            });
        }
        for (obs, action) in observations.chunks(dim).zip(actions.chunks_mut(a)) {
            self.act(obs, action)?;
        }
        Ok(())
    }

    fn check(&self, observation: &[f32]) -> Result<()> {
        if observation.len() != self.cx.observation_dim {
            return Err(Error::WrongLength {
                what: "observation".into(),
                expected: self.cx.observation_dim,
                got: observation.len(),
            });
        }
        if let Some((i, &v)) = observation.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: format!("observation[{i}]"),
                value: v as f64,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use panda_rapier_core::PlatformConfig;

    fn policy() -> ScriptedPolicy {
        ScriptedPolicy::new(&EnvConfig::default()).unwrap()
    }

    #[test]
    fn phase_names_are_distinct() {
        let phases = [
            Phase::APPROACH,
            Phase::DESCEND,
            Phase::CLOSE,
            Phase::LIFT,
            Phase::CARRY,
            Phase::LOWER,
            Phase::RELEASE,
            Phase::RETREAT,
            Phase::HOLD,
            Phase::REACH,
            Phase::ALIGN,
            Phase::PUSH,
        ];
        let names: std::collections::HashSet<_> = phases.iter().map(|p| p.as_str()).collect();
        assert_eq!(names.len(), phases.len());
    }

    #[test]
    fn every_task_has_an_expert() {
        for &task in TaskKind::ALL {
            let policy = ScriptedPolicy::new(&EnvConfig::for_task(task)).unwrap();
            assert_eq!(
                format!("{:?}", policy.expert),
                format!("{:?}", expert_for(task))
            );
        }
    }

    #[test]
    fn a_cube_lifted_off_the_floor_clears_it_and_one_level_with_the_platform_does_not() {
        let policy = policy().cx;
        let p = PlatformConfig::default();
        let floor_cube = Vector3::new(0.5, -0.1, 0.05);
        assert!(policy.clears_surfaces(floor_cube, 0.0, 0.05));
        let near_platform = Vector3::new(p.top_center[0], p.top_center[1], p.top_center[2]);
        assert!(!policy.clears_surfaces(near_platform, 0.0, 0.0));
        let above = near_platform + Vector3::new(0.0, 0.0, 0.05);
        assert!(policy.clears_surfaces(above, 0.0, 0.0));
    }

    #[test]
    fn action_sizes_follow_the_control_mode() {
        assert_eq!(policy().action_dim(), 4);
        let joints = EnvConfig {
            control_mode: ControlMode::Joints,
            ..EnvConfig::default()
        };
        assert_eq!(ScriptedPolicy::new(&joints).unwrap().action_dim(), 8);
        let pose = EnvConfig {
            control_mode: ControlMode::EePose,
            ..EnvConfig::default()
        };
        assert_eq!(ScriptedPolicy::new(&pose).unwrap().action_dim(), 7);
        assert_eq!(policy().observation_dim(), 47);
    }
}
