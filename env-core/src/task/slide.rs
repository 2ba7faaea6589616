//! [`Slide`]: slide the cube over a slippery floor to a goal beyond the arm's reach
//! (panda-gym's PandaSlide, with a cube for its puck).
//!
//! # Observation
//!
//! Pick-and-place's slots (for the Panda `observation` has 41 entries and the flat vector 47):
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0..3 | `achieved_goal` | `achieved_goal` | 3 | cube centre position |
//! | 3..6 | `desired_goal` | `desired_goal` | 3 | goal position for the cube centre, on the floor beyond reach |
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
//! `task.cube_yaw_range`; the goal uniform in `task.goal_region`, on the floor beyond what the
//! hand reaches (`ee_workspace` ends at x = 0.85 m). The floor is slippery: its friction is
//! `task.floor_friction` (panda-gym's puck: 0.04) and the smaller coefficient of a contact
//! counts, so the cube (friction `task.cube.friction` against the fingers) slides on it as a
//! puck on ice, decelerating at about `floor_friction * g` once let go. The scene has no
//! platform.
//!
//! # Success
//! The cube's centre within `success_threshold` of the goal. An episode succeeds when it ends
//! there (Gymnasium-Robotics' criterion, the last step's `is_success`): a cube that slides
//! through the goal and on does not count.
//!
//! # Rewards
//! `sparse`: -1 until the cube is within `success_threshold` of the goal, then 0. `dense`:
//! `reach` (the TCP near the cube) plus `carry` (the cube near the goal), pick-and-place's
//! terms ([`crate::task::reward`]). `reach` does not depend on the goal, `carry` is
//! recomputed from the goals, so relabelled goals get exactly the reward the environment
//! would have given. `is_grasped` and `is_lifted` are reported as in pick-and-place.

use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::base::cube::{judged_as_cube_task, CubeTask, IS_GRASPED, IS_LIFTED};
use super::base::term_field;
use super::config::{validate_cube_start, Range, Region};
use super::context::TaskContext;
use super::episode::{cube_orientation, CubeProperties, CUBE_YAW_RANGE};
use super::registry::{TaskDescriptor, TaskSpec};
use super::{EpisodeStart, ResetOptions, Task};
use crate::config::{invalid, CubeConfig, PlatformConfig};
use crate::error::Result;
use crate::physics::{ObjectSpec, Scene};
use crate::task::observation::InfoField;
use crate::task::reward::cube_terms::{CARRY, REACH};

/// The task's own info entries.
const INFO_FIELDS: [InfoField; 4] = [IS_GRASPED, IS_LIFTED, term_field(REACH), term_field(CARRY)];

/// The `slide` section of the configuration (`{"task": {"name": "slide", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlideConfig {
    /// The cube (its friction acts against the fingers; the floor's, smaller, against the
    /// floor).
    pub cube: CubeConfig,
    /// Where the cube's centre starts, on the floor.
    pub cube_region: Region,
    /// Range of the cube's start yaw (rad).
    pub cube_yaw_range: Range,
    /// Where goals are drawn, on the floor; it must lie at least 0.1 m beyond `cube_region`
    /// along x (away from the robot). The default starts `success_threshold` beyond where the
    /// hand stops reaching (`ee_workspace` ends at x = 0.85 m), so no goal can be met by
    /// carrying the cube there, and the cube is slid 0.4 to 0.6 m.
    pub goal_region: Region,
    /// The floor's friction coefficient; the smaller coefficient of a contact counts (panda-gym's
    /// puck: 0.04).
    pub floor_friction: f64,
}

impl Default for SlideConfig {
    fn default() -> Self {
        Self {
            cube: CubeConfig::default(),
            cube_region: Region {
                low: [0.4, -0.1],
                high: [0.5, 0.1],
            },
            cube_yaw_range: CUBE_YAW_RANGE,
            goal_region: Region {
                low: [0.9, -0.15],
                high: [1.0, 0.15],
            },
            floor_friction: 0.04,
        }
    }
}

impl TaskSpec for Slide {
    type Config = SlideConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "slide",
        id_stem: "Slide",
        episode_steps: 100,
        has_platform: false,
        summary: "slide the cube over a slippery floor to a goal beyond the arm's reach",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH, CARRY],
        reward_context_keys: &["reward_reach"],
    };

    // Letting the cube go at up to 0.6 m/s takes the hand faster than 0.05 rad per step allows
    // (the expert's `joints` slides fell 0.28 m short on average; at 0.1 rad, 93 % succeed).
    const ID_JOINT_STEP: Option<f64> = Some(0.1);

    fn validate(section: &SlideConfig, _context: &TaskContext) -> Result<()> {
        validate_cube_start(&section.cube_region, section.cube_yaw_range)?;
        section.goal_region.validate("task.goal_region")?;
        let f = section.floor_friction;
        if !(f.is_finite() && f > 0.0 && f <= 1.0) {
            return Err(invalid(
                "task.floor_friction",
                format!("must be in (0, 1], got {f}"),
            ));
        }
        if section.goal_region.low[0] < section.cube_region.high[0] + 0.1 {
            return Err(invalid(
                "task.goal_region",
                format!(
                    "must lie at least 0.1 m beyond task.cube_region along x, got {:?} and {:?}",
                    section.goal_region, section.cube_region
                ),
            ));
        }
        Ok(())
    }

    fn cube(section: &SlideConfig) -> Option<&CubeConfig> {
        Some(&section.cube)
    }

    fn build(section: &SlideConfig, context: &TaskContext) -> Self {
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

/// Slide the cube to a goal beyond reach (see the module documentation).
#[derive(Debug, Clone)]
pub struct Slide {
    section: SlideConfig,
    context: TaskContext,
    /// The cube, its observation, predicates and reward.
    cube_task: CubeTask,
}

impl Task for Slide {
    fn descriptor(&self) -> &'static TaskDescriptor {
        &Self::DESCRIPTOR
    }

    fn build_scene(&self) -> Scene {
        Scene {
            objects: vec![ObjectSpec::cube(
                "cube",
                &self.section.cube,
                Scene::TUTORIAL_CUBE_POSITION,
            )],
            floor_friction: Some(self.section.floor_friction),
            ..Scene::default()
        }
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        [
            "cube centre position",
            "goal position for the cube centre, on the floor beyond reach",
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

    // Observation, judgement and reward: pick-and-place's.
    judged_as_cube_task!();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panda_layout_matches_the_documented_table() {
        let task = Slide::build(
            &Default::default(),
            &TaskContext::defaults(Slide::DESCRIPTOR.reward_terms),
        );
        crate::task::observation::assert_documented_layout(&task, include_str!("slide.rs"), 47);
    }
}
