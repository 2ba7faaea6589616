//! [`PickAndPlace`]: pick the cube up from the floor and put it down on the goal on the
//! platform (or hold it at a goal in the air).
//!
//! # Observation
//!
//! For the Panda (9 moving joints: 7 arm joints and 2 fingers) `observation` has 41 entries and
//! the flat vector 47:
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0..3 | `achieved_goal` | `achieved_goal` | 3 | cube centre position |
//! | 3..6 | `desired_goal` | `desired_goal` | 3 | goal position for the cube centre |
//! | 6..15 | `observation` 0..9 | `joint_positions` | 9 | arm joints 1-7 (rad), finger joints 1-2 (m) |
//! | 15..24 | `observation` 9..18 | `joint_velocities` | 9 | their velocities |
//! | 24..27 | `observation` 18..21 | `tcp_position` | 3 | tool centre point (between the fingertips) |
//! | 27..30 | `observation` 21..24 | `tcp_velocity` | 3 | its linear velocity |
//! | 30 | `observation` 24 | `gripper_width` | 1 | opening between the finger pads (m) |
//! | 31..34 | `observation` 25..28 | `cube_position` | 3 | cube centre (same as `achieved_goal`) |
//! | 34..38 | `observation` 28..32 | `cube_orientation` | 4 | unit quaternion x, y, z, w with w >= 0 |
//! | 38..41 | `observation` 32..35 | `cube_linear_velocity` | 3 | cube centre velocity |
//! | 41..44 | `observation` 35..38 | `cube_angular_velocity` | 3 | cube angular velocity |
//! | 44..47 | `observation` 38..41 | `cube_relative_position` | 3 | cube centre minus TCP position |
//!
//! The first seven rows are every task's (goals and [`super::observation::ROBOT_SLOTS`]); the
//! last five are the cube's ([`PickAndPlace::observation_slots`](super::Task::observation_slots),
//! shared with lift, push and slide).
//!
//! # Starting state
//! The cube on the floor at a uniform position in `task.cube_region` with a uniform yaw in
//! `task.cube_yaw_range`, the goal uniform in `task.goal_region` at the height of a cube
//! resting on the platform, or with probability `task.goal_air_probability` up to
//! `task.goal_air_height` above it (see [`PickAndPlaceConfig`]).
//!
//! # Rewards
//! `sparse`: -1 until the cube is within `success_threshold` of the goal, then 0. `dense`: the
//! staged terms of [`crate::task::reward`].

use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::base::cube::{judged_as_cube_task, CubeTask, IS_GRASPED, IS_LIFTED, IS_PLACED};
use super::base::term_field;
use super::config::{
    validate_cube_start, validate_platform_regions, validate_range, Range, Region,
};
use super::context::TaskContext;
use super::episode::{
    cube_orientation, CubeProperties, CUBE_REGION, CUBE_YAW_RANGE, PLATFORM_GOAL_REGION,
};
use super::observation::{info_field, InfoField, InfoType};
use super::registry::{TaskDescriptor, TaskSpec};
use super::reward::cube_terms::{CARRY, GRASP, LIFT, PLACE, REACH, RELEASE};
use super::reward::{RewardContext, RewardFunction};
use super::{EpisodeStart, ResetOptions, Task};
use crate::config::invalid;
use crate::config::{CubeConfig, PlatformConfig};
use crate::error::Result;
use crate::physics::{ObjectSpec, Scene};

/// The task's own info entries.
const INFO_FIELDS: [InfoField; 12] = [
    IS_GRASPED,
    IS_LIFTED,
    IS_PLACED,
    term_field(REACH),
    term_field(GRASP),
    term_field(LIFT),
    term_field(CARRY),
    term_field(PLACE),
    term_field(RELEASE),
    info_field(
        "cube_released",
        InfoType::Bool,
        "no robot link touches the cube",
    ),
    info_field(
        "cube_at_rest",
        InfoType::Bool,
        "the cube moves slower than the rest thresholds",
    ),
    info_field(
        "cube_on_platform",
        InfoType::Bool,
        "the cube touches the platform",
    ),
];

/// The `pick_and_place` section of the configuration (`{"task": {"name": "pick_and_place",
/// ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PickAndPlaceConfig {
    /// The cube (`sim.cube` before 0.2).
    pub cube: CubeConfig,
    /// The platform the cube is placed on (`sim.platform` before 0.2).
    pub platform: PlatformConfig,
    /// Where the cube's centre starts, on the floor clear of the platform (`pick_region`
    /// before 0.2).
    pub cube_region: Region,
    /// Range of the cube's start yaw (rad).
    pub cube_yaw_range: Range,
    /// Where goals are drawn, on the platform's top.
    pub goal_region: Region,
    /// Probability that the goal is in the air above the platform instead of on it.
    pub goal_air_probability: f64,
    /// Height range (m) of an air goal above the cube's resting height on the platform.
    pub goal_air_height: Range,
}

impl Default for PickAndPlaceConfig {
    fn default() -> Self {
        Self {
            cube: CubeConfig::default(),
            platform: PlatformConfig::default(),
            cube_region: CUBE_REGION,
            cube_yaw_range: CUBE_YAW_RANGE,
            goal_region: PLATFORM_GOAL_REGION,
            goal_air_probability: 0.0,
            goal_air_height: [0.05, 0.2],
        }
    }
}

impl TaskSpec for PickAndPlace {
    type Config = PickAndPlaceConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "pick_and_place",
        id_stem: "PickAndPlace",
        // 2.8 s at 25 Hz: the scripted expert places the cube in at least 99 % of episodes
        // in both action modes.
        episode_steps: 70,
        has_platform: true,
        summary: "pick the cube up from the floor and place it on the goal on the platform",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH, GRASP, LIFT, CARRY, PLACE, RELEASE],
        reward_context_keys: &RewardContext::KEYS,
    };

    const LEGACY_KEYS: &'static [(&'static str, &'static str)] = &[
        ("pick_region", "cube_region"),
        ("cube_yaw_range", "cube_yaw_range"),
        ("goal_region", "goal_region"),
        ("goal_air_probability", "goal_air_probability"),
        ("goal_air_height", "goal_air_height"),
    ];

    fn validate(section: &PickAndPlaceConfig, context: &TaskContext) -> Result<()> {
        validate_cube_start(&section.cube_region, section.cube_yaw_range)?;
        section.goal_region.validate("task.goal_region")?;
        validate_range("task.goal_air_height", section.goal_air_height, 0.0)?;
        let p = section.goal_air_probability;
        if !(0.0..=1.0).contains(&p) {
            return Err(invalid(
                "task.goal_air_probability",
                format!("must be in [0, 1], got {p}"),
            ));
        }
        validate_platform_regions(
            &context.randomization,
            &section.platform,
            &section.cube,
            &section.cube_region,
            &section.goal_region,
        )
    }

    fn cube(section: &PickAndPlaceConfig) -> Option<&CubeConfig> {
        Some(&section.cube)
    }

    fn platform(section: &PickAndPlaceConfig) -> Option<&PlatformConfig> {
        Some(&section.platform)
    }

    fn build(section: &PickAndPlaceConfig, context: &TaskContext) -> Self {
        Self {
            section: section.clone(),
            context: context.clone(),
            cube_task: CubeTask::new(&Self::DESCRIPTOR, context, section.platform.top_center[2]),
        }
    }
}

/// Pick the cube up from the floor and put it on the goal (see the module documentation).
#[derive(Debug, Clone)]
pub struct PickAndPlace {
    section: PickAndPlaceConfig,
    context: TaskContext,
    /// The cube, its observation, predicates and reward.
    cube_task: CubeTask,
}

impl PickAndPlace {
    /// The reward function ([`RewardFunction::compute_batch`] is `compute_reward`).
    pub fn reward_function(&self) -> &RewardFunction {
        self.cube_task.reward_function()
    }
}

impl Task for PickAndPlace {
    fn descriptor(&self) -> &'static TaskDescriptor {
        &Self::DESCRIPTOR
    }

    fn build_scene(&self) -> Scene {
        Scene {
            platform: Some(self.section.platform.clone()),
            objects: vec![ObjectSpec::cube(
                "cube",
                &self.section.cube,
                Scene::TUTORIAL_CUBE_POSITION,
            )],
            ..Scene::default()
        }
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        ["cube centre position", "goal position for the cube centre"]
    }

    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart) {
        let section = &self.section;
        let mut draw = || rng.random::<f64>();
        // Always the same draws in the same order: overrides and switched-off randomisation do
        // not shift the others.
        let cube_xy = section.cube_region.lerp([draw(), draw()]);
        let yaw_u = draw();
        let goal_xy = section.goal_region.lerp([draw(), draw()]);
        let air_u = draw();
        let air_height_u = draw();
        let size_u = draw();
        let mass_u = draw();
        let friction_u = draw();
        let properties = CubeProperties::draw(
            &section.cube,
            &self.context.randomization,
            [size_u, mass_u, friction_u],
        );
        let size = properties.size;
        let platform_top = section.platform.top_center[2];
        let mut goal = Vector3::new(goal_xy[0], goal_xy[1], platform_top + size / 2.0);
        if air_u < section.goal_air_probability {
            let [low, high] = section.goal_air_height;
            goal.z += low + (high - low) * air_height_u;
        }
        if let Some(g) = options.goal {
            goal = Vector3::from(g);
        }
        let cube = properties.resting(
            self.cube_task.cube(),
            cube_xy,
            options.cube_position,
            cube_orientation(section.cube_yaw_range, yaw_u, options),
        );
        start.set([cube], goal.iter().copied());
    }

    // Observation, judgement and reward: the cube task's, with this task's terms.
    judged_as_cube_task!();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panda_layout_matches_the_documented_table() {
        let task = PickAndPlace::build(
            &Default::default(),
            &TaskContext::defaults(PickAndPlace::DESCRIPTOR.reward_terms),
        );
        crate::task::observation::assert_documented_layout(
            &task,
            include_str!("pick_and_place.rs"),
            47,
        );
    }
}
