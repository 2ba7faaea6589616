//! [`Reach`]: move the tool centre point to a goal in the air (panda-gym's PandaReach).
//!
//! # Observation
//!
//! No objects: for the Panda `observation` has the robot's 25 entries and the flat vector 31.
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0..3 | `achieved_goal` | `achieved_goal` | 3 | tool centre point position |
//! | 3..6 | `desired_goal` | `desired_goal` | 3 | goal position for the tool centre point |
//! | 6..15 | `observation` 0..9 | `joint_positions` | 9 | arm joints 1-7 (rad), finger joints 1-2 (m) |
//! | 15..24 | `observation` 9..18 | `joint_velocities` | 9 | their velocities |
//! | 24..27 | `observation` 18..21 | `tcp_position` | 3 | tool centre point (between the fingertips) |
//! | 27..30 | `observation` 21..24 | `tcp_velocity` | 3 | its linear velocity |
//! | 30 | `observation` 24 | `gripper_width` | 1 | opening between the finger pads (m) |
//!
//! # Starting state
//! The robot in its start pose; the goal uniform in the box `task.goal_region` (see
//! [`ReachConfig`]). The scene is the floor alone (no platform, no objects).
//!
//! # Rewards
//! `sparse`: -1 until the tool centre point is within `success_threshold` of the goal, then 0.
//! `dense`: `reward_weights.reach * (1 - tanh(5 d))`, `d` the distance to the goal (so in
//! `[0, reach]`, 1 at the goal with the default weight). Both depend on the goals alone, so
//! relabelled goals get exactly the reward the environment would have given. The info's own
//! entry is `reward_reach` (the dense reward; 0 with the sparse one).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::config::validate_range;
use super::context::TaskContext;
use super::registry::{TaskDescriptor, TaskSpec};
use super::{EpisodeStart, ResetOptions, SlotSpec, Task, Verdict, View};
use crate::error::Result;
use crate::physics::{BodyState, Scene, Simulation};
use crate::task::base::term_field;
use crate::task::config::RewardType;
use crate::task::episode::TaskInfo;
use crate::task::observation::InfoField;
use crate::task::reward::{closeness, compute_batch_with, RewardFunction, RewardTerm, GOAL_DIM};

/// The reward's one term.
const REACH: RewardTerm = RewardTerm {
    name: "reach",
    info_key: "reward_reach",
    default_weight: 1.0,
    description: "`1 - tanh(5 d)`, `d` = distance from the TCP to the goal",
};

/// The task's own info entries: its reward term.
const INFO_FIELDS: [InfoField; 1] = [term_field(REACH)];

/// The `reach` section of the configuration (`{"task": {"name": "reach", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReachConfig {
    /// The box (m, world frame) goals are drawn in, as
    /// `[[xlow, ylow, zlow], [xhigh, yhigh, zhigh]]` (`reach_goal_region` before 0.2).
    pub goal_region: [[f64; 3]; 2],
}

impl Default for ReachConfig {
    fn default() -> Self {
        Self {
            goal_region: [[0.35, -0.25, 0.1], [0.65, 0.25, 0.4]],
        }
    }
}

impl TaskSpec for Reach {
    type Config = ReachConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "reach",
        id_stem: "Reach",
        // panda-gym's 50 steps; the scripted expert needs at most 26.
        episode_steps: 50,
        has_platform: false,
        summary: "move the tool centre point to a goal in the air",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH],
        reward_context_keys: &[],
    };

    const LEGACY_KEYS: &'static [(&'static str, &'static str)] =
        &[("reach_goal_region", "goal_region")];

    fn validate(section: &ReachConfig, _context: &TaskContext) -> Result<()> {
        let [low, high] = section.goal_region;
        for i in 0..3 {
            validate_range("task.goal_region", [low[i], high[i]], f64::NEG_INFINITY)?;
        }
        Ok(())
    }

    fn build(section: &ReachConfig, context: &TaskContext) -> Self {
        Self {
            section: section.clone(),
            context: context.clone(),
        }
    }
}

/// Move the tool centre point to the goal (see the module documentation).
#[derive(Debug, Clone)]
pub struct Reach {
    section: ReachConfig,
    context: TaskContext,
}

impl Reach {
    /// The reward for one pair of goals.
    fn reward(&self, achieved: &[f32], desired: &[f32]) -> (f64, bool, f32) {
        let distance = RewardFunction::distance(achieved, desired);
        let success = distance < self.context.success_threshold;
        let reward = match self.context.reward_type {
            RewardType::Sparse => {
                if success {
                    0.0
                } else {
                    -1.0
                }
            }
            RewardType::Dense => self.context.reward_weights.reach as f32 * closeness(distance),
        };
        (distance, success, reward)
    }
}

impl Task for Reach {
    fn descriptor(&self) -> &'static TaskDescriptor {
        &Self::DESCRIPTOR
    }

    fn build_scene(&self) -> Scene {
        // An empty world: the robot and the floor.
        Scene::default()
    }

    fn bind(&mut self, _sim: &Simulation) -> Result<()> {
        Ok(())
    }

    fn goal_dim(&self) -> usize {
        GOAL_DIM
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        [
            "tool centre point position",
            "goal position for the tool centre point",
        ]
    }

    fn observation_slots(&self) -> &'static [SlotSpec] {
        &[]
    }

    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart) {
        let [low, high] = self.section.goal_region;
        let mut goal = [0.0; 3];
        for i in 0..3 {
            goal[i] = low[i] + (high[i] - low[i]) * rng.random::<f64>();
        }
        start.set([], options.goal.unwrap_or(goal));
    }

    fn observe(
        &self,
        _sim: &Simulation,
        tcp: &BodyState,
        _goal: &[f64],
        achieved: &mut [f64],
        _extras: &mut [f64],
    ) {
        achieved.copy_from_slice(tcp.position.as_slice());
    }

    fn evaluate(&self, view: &View<'_>) -> Verdict {
        let l = view.layout;
        let obs = view.observation;
        let (distance, is_success, reward) =
            self.reward(&obs[l.achieved_goal()], &obs[l.desired_goal()]);
        let mut info = TaskInfo::new(&INFO_FIELDS);
        if self.context.reward_type == RewardType::Dense {
            info.set("reward_reach", reward);
        }
        Verdict {
            is_success,
            goal_distance: distance,
            reward,
            info,
        }
    }

    fn compute_rewards(
        &self,
        achieved: &[f32],
        desired: &[f32],
        _contexts: &[f32],
        out: &mut [f32],
    ) -> Result<()> {
        // The goals alone decide the reward: there is no context.
        compute_batch_with(
            achieved,
            desired,
            GOAL_DIM,
            &[],
            0,
            false,
            out,
            |a, d, _| self.reward(a, d).2,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panda_layout_matches_the_documented_table() {
        let task = Reach::build(
            &Default::default(),
            &TaskContext::defaults(Reach::DESCRIPTOR.reward_terms),
        );
        crate::task::observation::assert_documented_layout(&task, include_str!("reach.rs"), 31);
    }
}
