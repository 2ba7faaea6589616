//! [`Lift`]: grasp the cube and lift it to a goal straight above where it started (ManiSkill's
//! PickCube, with the goal above the cube).
//!
//! # Observation
//! As [`crate::task::pick_and_place`]'s: the goals are the cube centre's position and its goal,
//! then the robot's slots and the cube's (47 entries for the Panda).
//!
//! # Starting state
//! The cube on the floor at a uniform position in `task.cube_region` with a uniform yaw in
//! `task.cube_yaw_range`; the goal straight above it, `task.goal_height` above its resting
//! centre (see [`LiftConfig`]). The scene has no platform.
//!
//! # Rewards
//! Pick-and-place's ([`crate::task::reward`]): `sparse` -1 until the cube is within
//! `success_threshold` of the goal, then 0; `dense` the staged `reach`, `grasp`, `lift` and
//! `carry` terms (there is no platform to place on, so `place` and `release` stay 0).

use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::base::cube::{judged_as_cube_task, CubeTask, IS_GRASPED, IS_LIFTED};
use super::base::term_field;
use super::config::{validate_cube_start, validate_range, Range, Region};
use super::context::TaskContext;
use super::episode::{cube_orientation, CubeProperties, CUBE_REGION, CUBE_YAW_RANGE};
use super::registry::{TaskDescriptor, TaskSpec};
use super::{EpisodeStart, ResetOptions, Task};
use crate::config::{CubeConfig, PlatformConfig};
use crate::error::Result;
use crate::physics::{ObjectSpec, Scene};
use crate::task::observation::InfoField;
use crate::task::reward::cube_terms::{CARRY, GRASP, LIFT, REACH};

/// The task's own info entries.
const INFO_FIELDS: [InfoField; 6] = [
    IS_GRASPED,
    IS_LIFTED,
    term_field(REACH),
    term_field(GRASP),
    term_field(LIFT),
    term_field(CARRY),
];

/// The `lift` section of the configuration (`{"task": {"name": "lift", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LiftConfig {
    /// The cube (`sim.cube` before 0.2).
    pub cube: CubeConfig,
    /// Where the cube's centre starts, on the floor (`pick_region` before 0.2).
    pub cube_region: Region,
    /// Range of the cube's start yaw (rad).
    pub cube_yaw_range: Range,
    /// Height range (m) of the goal above the cube's resting centre, straight above where it
    /// starts (`lift_height` before 0.2).
    pub goal_height: Range,
}

impl Default for LiftConfig {
    fn default() -> Self {
        Self {
            cube: CubeConfig::default(),
            cube_region: CUBE_REGION,
            cube_yaw_range: CUBE_YAW_RANGE,
            goal_height: [0.05, 0.25],
        }
    }
}

impl TaskSpec for Lift {
    type Config = LiftConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "lift",
        id_stem: "Lift",
        episode_steps: 70,
        has_platform: false,
        summary: "grasp the cube and lift it to a goal above its start",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH, GRASP, LIFT, CARRY],
        reward_context_keys: &["reward_reach", "reward_grasp", "reward_lift"],
    };

    const LEGACY_KEYS: &'static [(&'static str, &'static str)] = &[
        ("pick_region", "cube_region"),
        ("cube_yaw_range", "cube_yaw_range"),
        ("lift_height", "goal_height"),
    ];

    fn validate(section: &LiftConfig, _context: &TaskContext) -> Result<()> {
        validate_cube_start(&section.cube_region, section.cube_yaw_range)?;
        validate_range("task.goal_height", section.goal_height, 0.0)
    }

    fn cube(section: &LiftConfig) -> Option<&CubeConfig> {
        Some(&section.cube)
    }

    fn build(section: &LiftConfig, context: &TaskContext) -> Self {
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

/// Lift the cube to a goal above its start (see the module documentation).
#[derive(Debug, Clone)]
pub struct Lift {
    section: LiftConfig,
    context: TaskContext,
    /// The cube, its observation, predicates and reward.
    cube_task: CubeTask,
}

impl Task for Lift {
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
            "goal position for the cube centre, above its start",
        ]
    }

    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart) {
        let mut draw = || rng.random::<f64>();
        // Always the same draws in the same order, whatever the overrides.
        let cube_xy = self.section.cube_region.lerp([draw(), draw()]);
        let yaw_u = draw();
        let height_u = draw();
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
        let [low, high] = self.section.goal_height;
        let lifted = properties.size / 2.0 + low + (high - low) * height_u;
        let goal = options.goal.map_or(
            Vector3::new(cube.position.x, cube.position.y, lifted),
            Vector3::from,
        );
        start.set([cube], goal.iter().copied());
    }

    // Observation, judgement and reward: pick-and-place's.
    judged_as_cube_task!();
}
