//! [`Push`]: push the cube along the floor to a goal on the floor (panda-gym's PandaPush,
//! Gymnasium-Robotics' FetchPush).
//!
//! # Observation
//!
//! Pick-and-place's slots (for the Panda `observation` has 41 entries and the flat vector 47):
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0..3 | `achieved_goal` | `achieved_goal` | 3 | cube centre position |
//! | 3..6 | `desired_goal` | `desired_goal` | 3 | goal position for the cube centre, on the floor |
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
//! # Starting state
//! The cube on the floor at a uniform position in `task.cube_region` with a uniform yaw in
//! `task.cube_yaw_range`; the goal uniform in `task.goal_region`, at the height of the centre
//! of a cube resting on the floor (see [`PushConfig`]). The defaults keep the two regions 5 cm apart, so no episode starts
//! solved. The scene has no platform (and `ee` targets keep `ee_surface_clearance` above the
//! floor everywhere).
//!
//! # The gripper
//! The action spaces are every task's (4-D `ee`, 8-D `joints`, the last entry the gripper
//! command); the task does not lock the fingers, unlike panda-gym's Push. Pushing is meant with
//! the fingers closed (command -1), as the scripted expert does; a policy that opens them may
//! also grasp the cube, which the rewards neither ask for nor pay.
//!
//! # Rewards
//! `sparse`: -1 until the cube is within `success_threshold` of the goal, then 0. `dense`:
//! pick-and-place's terms ([`crate::task::reward`]) without the ones that pay for holding the
//! cube: `reach` (the TCP near the cube) plus `carry` (the cube near the goal); `grasp`, `lift`
//! and `place` are 0 (the info's `grasp` and `lift` reward inputs too), `release` pays as in
//! pick-and-place (off by default). `reach` and the gripper opening do not depend on the goal,
//! `carry` and `release` are recomputed from the goals, so relabelled goals get exactly the
//! reward the environment would have given. `is_success` is the only predicate that matters
//! here; `is_grasped` and `is_lifted` are reported as in pick-and-place, `is_placed` is never
//! true (there is no platform).

use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::base::cube::{judged_as_cube_task, CubeTask, IS_GRASPED, IS_LIFTED};
use super::base::term_field;
use super::config::{validate_cube_start, Range, Region};
use super::context::TaskContext;
use super::episode::{cube_orientation, CubeProperties, CUBE_REGION, CUBE_YAW_RANGE};
use super::registry::{TaskDescriptor, TaskSpec};
use super::{EpisodeStart, ResetOptions, Task};
use crate::config::{CubeConfig, PlatformConfig};
use crate::error::Result;
use crate::physics::{ObjectSpec, Scene};
use crate::task::observation::InfoField;
use crate::task::reward::cube_terms::{CARRY, REACH, RELEASE};

/// The task's own info entries.
const INFO_FIELDS: [InfoField; 5] = [
    IS_GRASPED,
    IS_LIFTED,
    term_field(REACH),
    term_field(CARRY),
    term_field(RELEASE),
];

/// The `push` section of the configuration (`{"task": {"name": "push", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PushConfig {
    /// The cube (`sim.cube` before 0.2).
    pub cube: CubeConfig,
    /// Where the cube's centre starts, on the floor (`pick_region` before 0.2).
    pub cube_region: Region,
    /// Range of the cube's start yaw (rad).
    pub cube_yaw_range: Range,
    /// Where goals are drawn, on the floor (`push_goal_region` before 0.2). The default lies
    /// beside `cube_region` (towards +y) and 5 cm clear of it, so the cube starts at least
    /// `success_threshold` from the goal and is pushed 0.05 to 0.49 m (0.26 m on average).
    pub goal_region: Region,
}

impl Default for PushConfig {
    fn default() -> Self {
        Self {
            cube: CubeConfig::default(),
            cube_region: CUBE_REGION,
            cube_yaw_range: CUBE_YAW_RANGE,
            goal_region: Region {
                low: [0.4, 0.05],
                high: [0.6, 0.25],
            },
        }
    }
}

impl TaskSpec for Push {
    type Config = PushConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "push",
        id_stem: "Push",
        // The scripted expert succeeds in 99.6 to 99.9 % of 1,000 episodes in 70 steps in each
        // action mode and arm, its 95th percentile at 43 to 57 steps.
        episode_steps: 70,
        has_platform: false,
        summary: "push the cube along the floor to a goal on the floor",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH, CARRY, RELEASE],
        reward_context_keys: &["reward_reach", "gripper_opening"],
    };

    const LEGACY_KEYS: &'static [(&'static str, &'static str)] = &[
        ("pick_region", "cube_region"),
        ("cube_yaw_range", "cube_yaw_range"),
        ("push_goal_region", "goal_region"),
    ];

    fn validate(section: &PushConfig, _context: &TaskContext) -> Result<()> {
        validate_cube_start(&section.cube_region, section.cube_yaw_range)?;
        section.goal_region.validate("task.goal_region")
    }

    fn cube(section: &PushConfig) -> Option<&CubeConfig> {
        Some(&section.cube)
    }

    fn build(section: &PushConfig, context: &TaskContext) -> Self {
        Self {
            section: section.clone(),
            context: context.clone(),
            // The cube task's observation, predicates and reward with this task's terms (its
            // `lift` term keeps pick-and-place's default platform height as its scale).
            cube_task: CubeTask::new(
                &Self::DESCRIPTOR,
                context,
                PlatformConfig::default().top_center[2],
            ),
        }
    }
}

/// Push the cube to a goal on the floor (see the module documentation).
#[derive(Debug, Clone)]
pub struct Push {
    section: PushConfig,
    context: TaskContext,
    /// The cube, its observation, predicates and reward.
    cube_task: CubeTask,
}

impl Task for Push {
    fn descriptor(&self) -> &'static TaskDescriptor {
        &Self::DESCRIPTOR
    }

    fn build_scene(&self) -> Scene {
        // The section's cube, without the platform.
        Scene {
            platform: None,
            objects: vec![ObjectSpec::cube(
                "cube",
                &self.section.cube,
                Scene::TUTORIAL_CUBE_POSITION,
            )],
            ..Scene::default()
        }
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        [
            "cube centre position",
            "goal position for the cube centre, on the floor",
        ]
    }

    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart) {
        let mut draw = || rng.random::<f64>();
        // Always the same draws in the same order, whatever the overrides.
        let cube_xy = self.section.cube_region.lerp([draw(), draw()]);
        let yaw_u = draw();
        let goal_xy = self.section.goal_region.lerp([draw(), draw()]);
        let size_u = draw();
        let mass_u = draw();
        let friction_u = draw();
        let properties = CubeProperties::draw(
            &self.section.cube,
            &self.context.randomization,
            [size_u, mass_u, friction_u],
        );
        let cube = properties.resting(
            self.cube_task.cube(),
            cube_xy,
            options.cube_position,
            cube_orientation(self.section.cube_yaw_range, yaw_u, options),
        );
        let goal = options.goal.map_or(
            Vector3::new(goal_xy[0], goal_xy[1], properties.size / 2.0),
            Vector3::from,
        );
        start.set([cube], goal.iter().copied());
    }

    // Pick-and-place's judgement with this task's terms: nothing is paid for holding the
    // cube (`grasp` and `lift` weigh 0) and there is no platform to place it on.
    judged_as_cube_task!();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panda_layout_matches_the_documented_table() {
        let task = Push::build(
            &Default::default(),
            &TaskContext::defaults(Push::DESCRIPTOR.reward_terms),
        );
        crate::task::observation::assert_documented_layout(&task, include_str!("push.rs"), 47);
    }

    #[test]
    fn goals_lie_on_the_floor_clear_of_the_start() {
        use rand::SeedableRng;
        let context = TaskContext::defaults(Push::DESCRIPTOR.reward_terms);
        let task = Push::build(&Default::default(), &context);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut start = EpisodeStart::default();
        for _ in 0..200 {
            task.draw_episode(&mut rng, &ResetOptions::default(), &mut start);
            let cube = start.objects[0].position;
            let goal = Vector3::from_column_slice(&start.goal);
            assert_eq!(goal.z, CubeConfig::default().size / 2.0);
            assert_eq!(cube.z, goal.z);
            assert!((goal - cube).norm() >= context.success_threshold);
        }
    }
}
