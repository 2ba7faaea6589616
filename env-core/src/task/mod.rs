//! Tasks on top of the robot and the [`crate::Simulation`]: what a task is ([`Task`]), the
//! registry of tasks, the configuration, the observation and info schema, and rewards (the
//! environment every task runs in is [`crate::env::PandaEnv`]). Nothing here touches the physics engine; it goes through
//! [`crate::Simulation`].
//!
//! A task decides the scene (platform and objects), how an episode starts, its goals, the
//! observation entries it adds after the robot's, and its reward and success predicates. The
//! robot, its action controller, episode bookkeeping, blow-up detection and snapshots are the
//! environment's, the same for every task. The tasks: [`PickAndPlace`], [`Reach`], [`Lift`],
//! [`Stack`], [`Push`], [`slide::Slide`], [`flip::Flip`]; adding one is a new file here implementing [`Task`] and
//! [`TaskSpec`] and one line in the [`registry`].

pub mod config;
pub mod episode;
pub mod flip;
pub mod lift;
pub mod migrate;
pub mod observation;
pub mod pick_and_place;
pub mod push;
pub mod reach;
pub mod registry;
pub mod reward;
pub mod slide;
pub mod stack;

use rand_chacha::ChaCha8Rng;

pub use config::{ControlMode, EnvConfig, Randomization, Region, RewardType, TaskThresholds};
pub use episode::{
    EpisodeStart, ObjectStart, ResetOptions, StepInfo, TaskInfo, Transition, TASK_INFO_CAPACITY,
};
pub use lift::{Lift, LiftConfig};
pub use migrate::{Deprecation, LEGACY_KEYS_REMOVED_IN};
pub use observation::{
    info_field, InfoField, InfoType, InfoValue, ObservationLayout, Slot, SlotSource, SlotSpec,
    COMMON_INFO_FIELDS,
};
pub use pick_and_place::{PickAndPlace, PickAndPlaceConfig};
pub use push::{Push, PushConfig};
pub use reach::{Reach, ReachConfig};
pub use registry::{make_task, TaskConfig, TaskDescriptor, TaskKind, TaskSpec};
pub use reward::{RewardContext, RewardFunction, RewardTerm, RewardTerms, RewardWeights};
pub use stack::{Stack, StackConfig};

use crate::error::Result;
use crate::physics::{BodyState, Scene, Simulation};
use crate::robot::RobotSpec;

/// How a renderer shows a goal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GoalMarker {
    /// A position to reach (a small sphere).
    Point(nalgebra::Vector3<f64>),
    /// An orientation to reach, shown as a cube of half edge `half_extent` turned to it at
    /// `pose`.
    Pose {
        /// Where the cube is drawn and how it is turned.
        pose: nalgebra::Isometry3<f64>,
        /// Half its edge (m).
        half_extent: f64,
    },
}

impl GoalMarker {
    /// A point at every position (consecutive triples) in `positions`, appended to `out`;
    /// non-finite ones are left out.
    pub fn points(positions: &[f64], out: &mut Vec<GoalMarker>) {
        out.extend(
            positions
                .chunks_exact(3)
                .filter(|g| g.iter().all(|x| x.is_finite()))
                .map(|g| GoalMarker::Point(nalgebra::Vector3::new(g[0], g[1], g[2]))),
        );
    }
}

/// What the task says about the current state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Verdict {
    /// The success predicate.
    pub is_success: bool,
    /// Distance from the achieved to the desired goal.
    pub goal_distance: f64,
    /// The reward.
    pub reward: f32,
    /// The task's own info entries ([`TaskDescriptor::info_fields`]): its predicates, its
    /// weighted reward terms and its reward's goal-free inputs.
    pub info: TaskInfo,
}

/// What a task sees of the world when it judges a step.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The world.
    pub sim: &'a Simulation,
    /// The robot.
    pub robot: &'a RobotSpec,
    /// The observation just written (flat layout).
    pub observation: &'a [f32],
    /// Where everything sits in it.
    pub layout: &'a ObservationLayout,
    /// The gripper opening the last action asked for, from 0 (closed) to 1 (open).
    pub gripper_opening: f64,
}

/// A manipulation task: everything that differs between tasks. Implementations hold their
/// configuration and the handles of their objects, never episode state (the environment keeps
/// that: the goal, the step count, the random stream), so snapshots of the environment are
/// complete.
pub trait Task: Send + Sync + std::fmt::Debug {
    /// The task's static facts ([`TaskSpec::DESCRIPTOR`]).
    fn descriptor(&self) -> &'static TaskDescriptor;

    /// The task's name in configurations (`"pick_and_place"`).
    fn name(&self) -> &'static str {
        self.descriptor().name
    }

    /// The platform and objects the world must hold.
    fn scene(&self, config: &EnvConfig) -> Scene;

    /// Finds the task's objects in the world built from [`Task::scene`].
    fn bind(&mut self, sim: &Simulation) -> Result<()>;

    /// Length of each goal.
    fn goal_dim(&self) -> usize;

    /// What `achieved_goal` and `desired_goal` hold.
    fn goal_descriptions(&self) -> [&'static str; 2];

    /// The task's slots of `observation`, after the robot's.
    fn observation_slots(&self) -> &'static [SlotSpec];

    /// Draws how the next episode starts into `start` (the goal sized [`Task::goal_dim`]),
    /// honouring the overrides in `options`. The draws from `rng` must be the same in number
    /// and order whatever the overrides and randomisation switches, so one does not shift the
    /// others.
    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart);

    /// Writes the achieved goal and the task's observation entries (`extras`, laid out as
    /// [`Task::observation_slots`]) from the world; `tcp` is the tool centre point's state.
    fn observe(
        &self,
        sim: &Simulation,
        tcp: &BodyState,
        goal: &[f64],
        achieved: &mut [f64],
        extras: &mut [f64],
    );

    /// How a renderer shows `goal` (one of the task's goals), appended to `out`: by default a
    /// point at every position (consecutive triples) in it; non-finite ones are left out.
    fn goal_markers(&self, goal: &[f64], out: &mut Vec<GoalMarker>) {
        GoalMarker::points(goal, out);
    }

    /// Judges the state just observed: predicates, reward context and reward.
    fn evaluate(&self, view: &View<'_>) -> Verdict;

    /// The reward of `n` transitions recomputed from goals (`n x goal_dim` each) and reward
    /// contexts (`n` rows of the values of [`TaskDescriptor::reward_context_keys`], flags as
    /// 0 or 1; may be empty where the reward does not read them), written into `out`.
    fn compute_rewards(
        &self,
        achieved: &[f32],
        desired: &[f32],
        contexts: &[f32],
        out: &mut [f32],
    ) -> Result<()>;
}
