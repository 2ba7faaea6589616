//! Tasks on top of the robot and the [`crate::Simulation`]: what a task is ([`Task`]), the
//! registry of tasks, the task side of the configuration, the observation and info schema, and
//! rewards (the environment every task runs in, and its configuration, are [`crate::env`]'s).
//! Nothing here touches the physics engine; it goes through [`crate::Simulation`].
//!
//! A task decides the scene (platform and objects), how an episode starts, its goals, the
//! observation entries it adds after the robot's, and its reward and success predicates. The
//! robot, its action controller, episode bookkeeping, blow-up detection and snapshots are the
//! environment's, the same for every task. A task is built from its own section of the
//! configuration and a [`TaskContext`] (the options it reads), never the whole configuration.
//!
//! The tasks are the [`registry`]'s list ([`TaskKind::ALL`], one file each here); adding one is a
//! new file implementing [`Task`] and [`TaskSpec`] and one line in the registry. What several
//! tasks share (a cube to carry, its observation slots, predicates and judgement; helpers of
//! observations and info; objects drawn from a set) is in `base`, which names no task; no task
//! file names another.
//!
//! Module layout (imports point down this list; the registry names every task, and tasks name
//! the registry's descriptor types):
//!
//! - [`registry`]: the tasks, their descriptors and configuration sections;
//! - one file per task ([`pick_and_place`], [`reach`], [`lift`], [`stack`], [`push`],
//!   [`slide`], [`flip`], [`peg_insertion`], [`pick_object`], [`open_drawer`]);
//! - `base`: what tasks share;
//! - [`context`], [`config`], [`episode`], [`observation`], [`reward`]: the types tasks are
//!   made of.

pub(crate) mod base;
pub mod config;
pub mod context;
pub mod episode;
pub mod flip;
pub mod lift;
pub mod observation;
pub mod open_drawer;
pub mod peg_insertion;
pub mod pick_and_place;
pub mod pick_object;
pub mod push;
pub mod reach;
pub mod registry;
pub mod reward;
pub mod slide;
pub mod stack;

use rand_chacha::ChaCha8Rng;

pub use base::objects::{ObjectEntry, ObjectFile};
pub use config::{Randomization, Region, RewardType, TaskThresholds};
pub use context::TaskContext;
pub use episode::{
    ArticulationStart, EpisodeStart, ObjectStart, ObjectVariant, ResetOptions, StepInfo, TaskInfo,
    Transition, TASK_INFO_CAPACITY,
};
pub use flip::{Flip, FlipConfig};
pub use lift::{Lift, LiftConfig};
pub use observation::{
    info_field, InfoField, InfoType, InfoValue, ObservationLayout, Slot, SlotSource, SlotSpec,
    COMMON_INFO_FIELDS,
};
pub use open_drawer::{OpenDrawer, OpenDrawerConfig};
pub use peg_insertion::{PegInsertion, PegInsertionConfig};
pub use pick_and_place::{PickAndPlace, PickAndPlaceConfig};
pub use pick_object::{PickObject, PickObjectConfig};
pub use push::{Push, PushConfig};
pub use reach::{Reach, ReachConfig};
pub use registry::{TaskConfig, TaskDescriptor, TaskKind, TaskSpec};
pub use reward::{RewardContext, RewardFunction, RewardTerm, RewardTerms, RewardWeights};
pub use slide::{Slide, SlideConfig};
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

    /// The platform and objects the world must hold, from the task's own section (the
    /// environment also offers it as `scene(&config)` on a `dyn Task`).
    fn build_scene(&self) -> Scene;

    /// Finds the task's objects in the world built from [`Task::build_scene`].
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
