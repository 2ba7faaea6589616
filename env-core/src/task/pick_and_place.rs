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
//! last five are this task's ([`PickAndPlace::observation_slots`](super::Task::observation_slots)).
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

use super::config::{validate_range, Range, Region};
use super::episode::{
    cube_orientation, CubeProperties, CUBE_REGION, CUBE_YAW_RANGE, PLATFORM_GOAL_REGION,
};
use super::registry::{TaskDescriptor, TaskSpec};
use super::{EnvConfig, EpisodeStart, ResetOptions, SlotSpec, Task, Verdict, View};
use crate::config::invalid;
use crate::config::{CubeConfig, PlatformConfig};
use crate::error::Result;
use crate::physics::{BodyState, ObjectId, ObjectSpec, Scene, Simulation};
use crate::task::episode::TaskInfo;
use crate::task::observation::{info_field, InfoField, InfoType};
use crate::task::reward::cube_terms::{CARRY, GRASP, LIFT, PLACE, REACH, RELEASE};
use crate::task::reward::{
    closeness, GoalVerdict, RewardContext, RewardFunction, RewardTerm, RewardWeights,
};

/// `is_grasped`, an info entry of the cube tasks.
pub(crate) const IS_GRASPED: InfoField = info_field(
    "is_grasped",
    InfoType::Bool,
    "both fingers squeeze the cube with at least the grasp force",
);
/// `is_lifted`, an info entry of the cube tasks.
pub(crate) const IS_LIFTED: InfoField = info_field(
    "is_lifted",
    InfoType::Bool,
    "grasped and touching neither the floor nor the platform",
);
/// `is_placed`: the "placed" predicate.
const IS_PLACED: InfoField = info_field(
    "is_placed",
    InfoType::Bool,
    "released, at rest, on the platform and within the threshold",
);

/// The info entry reporting a reward term, weighted.
pub(crate) const fn term_field(term: RewardTerm) -> InfoField {
    info_field(term.info_key, InfoType::Float, term.description)
}

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

/// The cube tasks' info: every field of `fields` from the predicates, the reward context and
/// the goal verdict (a field no cube task reports is a bug, caught in debug builds).
pub(crate) fn cube_task_info(
    fields: &'static [InfoField],
    is_grasped: bool,
    is_lifted: bool,
    context: &RewardContext,
    goal: &GoalVerdict,
) -> TaskInfo {
    let mut info = TaskInfo::new(fields);
    let t = &goal.terms;
    // Filled by position: one pass over the fields, no lookups.
    for (i, field) in fields.iter().enumerate() {
        match field.key {
            "is_grasped" => info.set_at(i, is_grasped),
            "is_lifted" => info.set_at(i, is_lifted),
            "is_placed" => info.set_at(i, goal.is_placed),
            "reward_reach" => info.set_at(i, context.reach),
            "reward_grasp" => info.set_at(i, context.grasp),
            "reward_lift" => info.set_at(i, context.lift),
            "reward_carry" => info.set_at(i, t.carry),
            "reward_place" => info.set_at(i, t.place),
            "reward_release" => info.set_at(i, t.release),
            "cube_released" => info.set_at(i, context.cube_released),
            "cube_at_rest" => info.set_at(i, context.cube_at_rest),
            "cube_on_platform" => info.set_at(i, context.cube_on_platform),
            other => debug_assert!(false, "no cube info entry {other:?}"),
        }
    }
    info
}

/// The task's observation slots, after the robot's.
const SLOTS: [SlotSpec; 5] = [
    SlotSpec {
        name: "cube_position",
        size: Some(3),
        description: "cube centre (same as achieved_goal)",
    },
    SlotSpec {
        name: "cube_orientation",
        size: Some(4),
        description: "unit quaternion x, y, z, w with w >= 0",
    },
    SlotSpec {
        name: "cube_linear_velocity",
        size: Some(3),
        description: "cube centre velocity",
    },
    SlotSpec {
        name: "cube_angular_velocity",
        size: Some(3),
        description: "cube angular velocity",
    },
    SlotSpec {
        name: "cube_relative_position",
        size: Some(3),
        description: "cube centre minus TCP position",
    },
];
const LINEAR_VELOCITY: usize = 2;
const ANGULAR_VELOCITY: usize = 3;
const RELATIVE_POSITION: usize = 4;

/// Size of the goal: a position.
const GOAL_DIM: usize = 3;

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

    fn validate(section: &PickAndPlaceConfig, config: &EnvConfig) -> Result<()> {
        EnvConfig::validate_cube_start(&section.cube_region, section.cube_yaw_range)?;
        section.goal_region.validate("task.goal_region")?;
        validate_range("task.goal_air_height", section.goal_air_height, 0.0)?;
        let p = section.goal_air_probability;
        if !(0.0..=1.0).contains(&p) {
            return Err(invalid(
                "task.goal_air_probability",
                format!("must be in [0, 1], got {p}"),
            ));
        }
        config.validate_platform_regions(
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

    fn build(section: &PickAndPlaceConfig, config: &EnvConfig) -> Self {
        Self::cube_task(section, config, &Self::DESCRIPTOR)
    }
}

/// Pick the cube up from the floor and put it on the goal (see the module documentation).
#[derive(Debug, Clone)]
pub struct PickAndPlace {
    section: PickAndPlaceConfig,
    config: EnvConfig,
    descriptor: &'static TaskDescriptor,
    reward: RewardFunction,
    cube: Option<ObjectId>,
}

/// The [`Task`] methods of a task that observes, judges and rewards as pick-and-place does
/// (lift, push, slide), each handed to its `cube_task` field (a [`PickAndPlace`] made by
/// [`PickAndPlace::cube_task`]): `bind`, `goal_dim`, `observation_slots`, `observe`,
/// `evaluate` and `compute_rewards`. Invoked inside the task's `impl Task`, which adds the
/// rest (its descriptor, scene, goal descriptions and episode draw).
macro_rules! judged_as_pick_and_place {
    () => {
        fn bind(&mut self, sim: &$crate::physics::Simulation) -> $crate::error::Result<()> {
            self.cube_task.bind(sim)
        }

        fn goal_dim(&self) -> usize {
            self.cube_task.goal_dim()
        }

        fn observation_slots(&self) -> &'static [$crate::task::SlotSpec] {
            self.cube_task.observation_slots()
        }

        fn observe(
            &self,
            sim: &$crate::physics::Simulation,
            tcp: &$crate::physics::BodyState,
            goal: &[f64],
            achieved: &mut [f64],
            extras: &mut [f64],
        ) {
            self.cube_task.observe(sim, tcp, goal, achieved, extras)
        }

        fn evaluate(&self, view: &$crate::task::View<'_>) -> $crate::task::Verdict {
            self.cube_task.evaluate(view)
        }

        fn compute_rewards(
            &self,
            achieved: &[f32],
            desired: &[f32],
            contexts: &[f32],
            out: &mut [f32],
        ) -> $crate::error::Result<()> {
            self.cube_task
                .compute_rewards(achieved, desired, contexts, out)
        }
    };
}
pub(crate) use judged_as_pick_and_place;

impl PickAndPlace {
    /// The task with the descriptor (info entries, reward terms and context) of `as_task`: a
    /// cube task that observes and judges as pick-and-place does ([`crate::task::Lift`],
    /// [`crate::task::Push`]).
    pub(crate) fn cube_task(
        section: &PickAndPlaceConfig,
        config: &EnvConfig,
        as_task: &'static TaskDescriptor,
    ) -> Self {
        Self {
            section: section.clone(),
            config: config.clone(),
            reward: RewardFunction {
                reward_type: config.reward_type,
                success_threshold: config.success_threshold,
                weights: RewardWeights::resolve(as_task.reward_terms, &config.reward_weights),
            },
            descriptor: as_task,
            cube: None,
        }
    }

    /// The reward function ([`RewardFunction::compute_batch`] is `compute_reward`).
    pub fn reward_function(&self) -> &RewardFunction {
        &self.reward
    }

    /// The cube's handle in the bound world.
    pub(crate) fn cube(&self) -> ObjectId {
        // `bind` runs before any episode; an unbound task reads object 0, the only object.
        self.cube.unwrap_or_else(ObjectId::first)
    }
}

impl Task for PickAndPlace {
    fn descriptor(&self) -> &'static TaskDescriptor {
        self.descriptor
    }

    fn scene(&self, _config: &EnvConfig) -> Scene {
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

    fn bind(&mut self, sim: &Simulation) -> Result<()> {
        self.cube = Some(sim.object("cube")?);
        Ok(())
    }

    fn goal_dim(&self) -> usize {
        GOAL_DIM
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        ["cube centre position", "goal position for the cube centre"]
    }

    fn observation_slots(&self) -> &'static [SlotSpec] {
        &SLOTS
    }

    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart) {
        let config = &self.config;
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
            &config.randomization,
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
            self.cube(),
            cube_xy,
            options.cube_position,
            cube_orientation(section.cube_yaw_range, yaw_u, options),
        );
        start.set([cube], goal.iter().copied());
    }

    fn observe(
        &self,
        sim: &Simulation,
        tcp: &BodyState,
        _goal: &[f64],
        achieved: &mut [f64],
        extras: &mut [f64],
    ) {
        let cube = sim.object_state(self.cube());
        achieved.copy_from_slice(cube.position.as_slice());
        write_cube_slots(&cube, tcp, extras);
    }

    fn evaluate(&self, view: &View<'_>) -> Verdict {
        let t = &self.config.thresholds;
        let cube = self.cube();
        let touch = view.sim.object_touch(cube);
        let l = view.layout;
        let obs = view.observation;
        let cube_speed = norm(&obs[l.task_slot(LINEAR_VELOCITY)]);
        let cube_spin = norm(&obs[l.task_slot(ANGULAR_VELOCITY)]);
        let reach_distance = norm(&obs[l.task_slot(RELATIVE_POSITION)]);
        let cube_z = obs[l.achieved_goal()][2] as f64;
        let (size, _, _) = view.sim.object_properties(cube);
        let platform_height = self.section.platform.top_center[2];
        let is_grasped = touch.finger_forces.iter().all(|&f| f >= t.grasp_force);
        let lift = lift_fraction(cube_z, size, platform_height);
        let w = &self.reward.weights;
        let context = RewardContext {
            reach: w.reach as f32 * closeness(reach_distance),
            grasp: if is_grasped { w.grasp as f32 } else { 0.0 },
            lift: w.lift as f32 * lift as f32,
            cube_released: !touch.robot_touching(),
            cube_at_rest: cube_speed < t.rest_linear_speed && cube_spin < t.rest_angular_speed,
            cube_on_platform: touch.platform,
            gripper_opening: view.gripper_opening as f32,
        };
        let verdict =
            self.reward
                .evaluate(&obs[l.achieved_goal()], &obs[l.desired_goal()], &context);
        let is_lifted = is_grasped && !touch.floor && !touch.platform;
        Verdict {
            is_success: verdict.is_success,
            goal_distance: verdict.distance,
            reward: verdict.reward,
            info: cube_task_info(
                self.descriptor.info_fields,
                is_grasped,
                is_lifted,
                &context,
                &verdict,
            ),
        }
    }

    fn compute_rewards(
        &self,
        achieved: &[f32],
        desired: &[f32],
        contexts: &[f32],
        out: &mut [f32],
    ) -> Result<()> {
        let keys = self.descriptor.reward_context_keys;
        self.reward
            .compute_batch(achieved, desired, keys, contexts, out)
    }
}

/// Writes a cube's five observation slots ([`SLOTS`]: position, orientation as x, y, z, w with
/// w >= 0, linear and angular velocity, position relative to the TCP) into `out`.
pub(crate) fn write_cube_slots(cube: &BodyState, tcp: &BodyState, out: &mut [f64]) {
    let relative = cube.position - tcp.position;
    let values: [&[f64]; 5] = [
        cube.position.as_slice(),
        &canonical(&cube.orientation),
        cube.linear_velocity.as_slice(),
        cube.angular_velocity.as_slice(),
        relative.as_slice(),
    ];
    for (o, v) in out.iter_mut().zip(values.iter().flat_map(|s| s.iter())) {
        *o = *v;
    }
}

/// `q` as x, y, z, w with w >= 0, as observations carry orientations.
pub(crate) fn canonical(q: &nalgebra::UnitQuaternion<f64>) -> [f64; 4] {
    let c = if q.w < 0.0 { -q.coords } else { q.coords };
    [c.x, c.y, c.z, c.w]
}

/// The `lift` term before its weight: the height of a cube (centre `cube_z`, edge `size`)
/// above its floor resting height over the platform's height, clipped to [0, 1]; 0 without a
/// platform.
pub(crate) fn lift_fraction(cube_z: f64, size: f64, platform_height: f64) -> f64 {
    if platform_height > 0.0 {
        ((cube_z - size / 2.0) / platform_height).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The Euclidean norm of an observation slot, computed in f64 from its f32 values.
pub(crate) fn norm(v: &[f32]) -> f64 {
    v.iter()
        .map(|&x| (x as f64) * (x as f64))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panda_layout_matches_the_documented_table() {
        let task = PickAndPlace::build(&Default::default(), &EnvConfig::default());
        crate::task::observation::assert_documented_layout(
            &task,
            include_str!("pick_and_place.rs"),
            47,
        );
    }
}
