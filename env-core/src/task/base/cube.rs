//! The cube a task carries: its five observation slots ([`SLOTS`], written by
//! [`write_cube_slots`]), its predicates' info entries ([`IS_GRASPED`], [`IS_LIFTED`],
//! [`IS_PLACED`]) and the judgement of the staged cube reward ([`CubeTask`]: grasp, lift,
//! release and rest predicates, the reward context and the verdict), which pick-and-place,
//! lift, push and slide share (each with its own descriptor, so its own info entries and
//! reward terms), and which stack builds on for its two cubes.

use crate::error::Result;
use crate::physics::{BodyState, ObjectId, Simulation};
use crate::task::config::TaskThresholds;
use crate::task::context::TaskContext;
use crate::task::episode::TaskInfo;
use crate::task::observation::{info_field, InfoField, InfoType, SlotSpec};
use crate::task::registry::TaskDescriptor;
use crate::task::reward::{closeness, GoalVerdict, RewardContext, RewardFunction};
use crate::task::{Verdict, View};

use super::{canonical, norm};

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
pub(crate) const IS_PLACED: InfoField = info_field(
    "is_placed",
    InfoType::Bool,
    "released, at rest, on the platform and within the threshold",
);

/// The cube's observation slots, after the robot's.
pub(crate) const SLOTS: [SlotSpec; 5] = [
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
/// Index of the linear velocity among [`SLOTS`].
pub(crate) const LINEAR_VELOCITY: usize = 2;
/// Index of the angular velocity among [`SLOTS`].
pub(crate) const ANGULAR_VELOCITY: usize = 3;
/// Index of the position relative to the TCP among [`SLOTS`].
pub(crate) const RELATIVE_POSITION: usize = 4;

/// Size of the goal of a [`CubeTask`]: the cube centre's position.
pub(crate) const GOAL_DIM: usize = 3;

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
            "reward_stage" => info.set_at(i, t.stage),
            "cube_released" => info.set_at(i, context.cube_released),
            "cube_at_rest" => info.set_at(i, context.cube_at_rest),
            "cube_on_platform" => info.set_at(i, context.cube_on_platform),
            // Stack's own entry, which it sets itself.
            "cube1_grasped" => {}
            other => debug_assert!(false, "no cube info entry {other:?}"),
        }
    }
    info
}

/// One cube to carry to a goal position, judged by the staged cube reward
/// ([`RewardFunction`]): what pick-and-place, lift, push and slide observe and judge alike.
/// Each task keeps its own descriptor (its info entries, reward terms and context keys), so
/// the terms it does not declare weigh 0 and the entries it does not list are not reported.
#[derive(Debug, Clone)]
pub(crate) struct CubeTask {
    descriptor: &'static TaskDescriptor,
    reward: RewardFunction,
    thresholds: TaskThresholds,
    /// The platform's height (m) that scales the `lift` term.
    platform_height: f64,
    /// The carried object's name in the scene (`"cube"`).
    object_name: &'static str,
    cube: Option<ObjectId>,
}

impl CubeTask {
    /// The cube of the task `descriptor` describes, judged under `context`, its `lift` term
    /// scaled by `platform_height` (m).
    pub(crate) fn new(
        descriptor: &'static TaskDescriptor,
        context: &TaskContext,
        platform_height: f64,
    ) -> Self {
        Self {
            descriptor,
            reward: RewardFunction {
                reward_type: context.reward_type,
                success_threshold: context.success_threshold,
                weights: context.reward_weights,
            },
            thresholds: context.thresholds.clone(),
            platform_height,
            object_name: "cube",
            cube: None,
        }
    }

    /// Judges the scene object called `name` instead of `"cube"` (a task whose object is drawn
    /// from a set: [`CubeTask::evaluate_resting`] is told its resting half height).
    pub(crate) fn named(mut self, name: &'static str) -> Self {
        self.object_name = name;
        self
    }

    /// The reward function ([`RewardFunction::compute_batch`] is `compute_reward`).
    pub(crate) fn reward_function(&self) -> &RewardFunction {
        &self.reward
    }

    /// The cube's handle in the bound world.
    pub(crate) fn cube(&self) -> ObjectId {
        // `bind` runs before any episode; an unbound task reads object 0, the only object.
        self.cube.unwrap_or_else(ObjectId::first)
    }

    /// Finds the cube (the object called `"cube"`, or the name given to
    /// [`CubeTask::named`]) in the world.
    pub(crate) fn bind(&mut self, sim: &Simulation) -> Result<()> {
        self.cube = Some(sim.object(self.object_name)?);
        Ok(())
    }

    /// Writes the cube's position as the achieved goal and its [`SLOTS`] as `extras`.
    pub(crate) fn observe(
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

    /// The predicates, the reward context and the verdict of the state `view` shows.
    pub(crate) fn evaluate(&self, view: &View<'_>) -> Verdict {
        let (size, _, _) = view.sim.object_properties(self.cube());
        self.evaluate_resting(view, size / 2.0)
    }

    /// [`CubeTask::evaluate`] of an object whose centre (the achieved goal) rests `half_height`
    /// (m) above what it stands on: the `lift` term measures its lowest point's height.
    pub(crate) fn evaluate_resting(&self, view: &View<'_>, half_height: f64) -> Verdict {
        let size = 2.0 * half_height;
        let t = &self.thresholds;
        let cube = self.cube();
        let touch = view.sim.object_touch(cube);
        let l = view.layout;
        let obs = view.observation;
        let cube_speed = norm(&obs[l.task_slot(LINEAR_VELOCITY)]);
        let cube_spin = norm(&obs[l.task_slot(ANGULAR_VELOCITY)]);
        let reach_distance = norm(&obs[l.task_slot(RELATIVE_POSITION)]);
        let cube_z = obs[l.achieved_goal()][2] as f64;
        let is_grasped = touch.finger_forces.iter().all(|&f| f >= t.grasp_force);
        let lift = lift_fraction(cube_z, size, self.platform_height);
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

    /// The reward of `n` transitions recomputed from goals and reward contexts (the
    /// descriptor's `reward_context_keys`).
    pub(crate) fn compute_rewards(
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

/// The [`Task`](crate::task::Task) methods of a task that carries one cube to a goal position
/// and is judged by [`CubeTask`] (pick-and-place, lift, push, slide), each handed to its
/// `cube_task` field: `bind`, `goal_dim`, `observation_slots`, `observe`, `evaluate` and
/// `compute_rewards`. Invoked inside the task's `impl Task`, which adds the rest (its
/// descriptor, scene, goal descriptions and episode draw).
macro_rules! judged_as_cube_task {
    () => {
        fn bind(&mut self, sim: &$crate::physics::Simulation) -> $crate::error::Result<()> {
            self.cube_task.bind(sim)
        }

        fn goal_dim(&self) -> usize {
            $crate::task::base::cube::GOAL_DIM
        }

        fn observation_slots(&self) -> &'static [$crate::task::SlotSpec] {
            &$crate::task::base::cube::SLOTS
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
pub(crate) use judged_as_cube_task;
