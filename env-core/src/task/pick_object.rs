//! [`PickObject`]: pick one object of a set (the shipped mug, bottle, can, bowl, banana, ... or
//! the user's mesh files) up from the floor and put it down on the goal on the platform
//! (ManiSkill's PickSingleYCB, panda-gym's goal dict). Each episode draws the object from the
//! set; the observation says which by its size and its planned grasp.
//!
//! # Observation
//!
//! The goal is the position of the object's centre: the centre of its bounding box in its own
//! frame, which moves with it. For the Panda `observation` has 54 entries and the flat vector
//! 60:
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0..3 | `achieved_goal` | `achieved_goal` | 3 | object centre position |
//! | 3..6 | `desired_goal` | `desired_goal` | 3 | goal position for the object centre |
//! | 6..15 | `observation` 0..9 | `joint_positions` | 9 | arm joints 1-7 (rad), finger joints 1-2 (m) |
//! | 15..24 | `observation` 9..18 | `joint_velocities` | 9 | their velocities |
//! | 24..27 | `observation` 18..21 | `tcp_position` | 3 | tool centre point (between the fingertips) |
//! | 27..30 | `observation` 21..24 | `tcp_velocity` | 3 | its linear velocity |
//! | 30 | `observation` 24 | `gripper_width` | 1 | opening between the finger pads (m) |
//! | 31..34 | `observation` 25..28 | `object_position` | 3 | object centre (same as `achieved_goal`) |
//! | 34..38 | `observation` 28..32 | `object_orientation` | 4 | unit quaternion x, y, z, w with w >= 0 |
//! | 38..41 | `observation` 32..35 | `object_linear_velocity` | 3 | velocity of the object's centre of mass |
//! | 41..44 | `observation` 35..38 | `object_angular_velocity` | 3 | object angular velocity |
//! | 44..47 | `observation` 38..41 | `object_relative_position` | 3 | object centre minus TCP position |
//! | 47..50 | `observation` 41..44 | `object_half_extents` | 3 | half the sides of the object's bounding box in its frame (m) |
//! | 50..53 | `observation` 44..47 | `grasp_position` | 3 | where the planned top-down grasp puts the TCP (world frame) |
//! | 53..55 | `observation` 47..49 | `grasp_direction` | 2 | the planned grasp's closing direction: cos and sin of twice its yaw in the world |
//! | 55 | `observation` 49 | `grasp_width` | 1 | the object's width between the pads at the planned grasp (m) |
//! | 56..60 | `observation` 50..54 | `tcp_orientation` | 4 | the hand's orientation, x, y, z, w with w >= 0 |
//!
//! The first five object slots are laid out as the cube tasks' (`cube_*` there). The grasp is
//! planned once per object from its shape ([`crate::physics::ObjectShape::top_grasp`]: the
//! fingers come straight down and close across material narrower than they open, covering
//! the pads best and nearest above the centre of mass) for the object resting as it starts;
//! the slots move it with the object. A closing direction and its opposite are the same
//! grasp, hence twice the yaw.
//!
//! # Starting state
//! The object, drawn uniformly from `task.objects`, stands on the floor as its file has it
//! (its frame's z up, its lowest point on the floor), its centre at a uniform position in
//! `task.object_region`, turned by a uniform yaw in `task.object_yaw_range`. The goal is
//! uniform in `task.goal_region`, at the height of the object's centre when it stands on
//! the platform. `reset(options=...)` takes `cube_position` (the object's frame origin),
//! `cube_yaw` and `goal`.
//!
//! # Rewards
//! `sparse`: -1 until the object's centre is within `success_threshold` of the goal, then 0.
//! `dense`: the staged terms of the cube tasks ([`crate::task::reward`]), the object in the
//! cube's place (its reward context keeps the keys `cube_released`, `cube_at_rest` and
//! `cube_on_platform`, as every carrying task's).

use std::sync::Arc;

use nalgebra::{UnitQuaternion, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::base::cube::{CubeTask, IS_LIFTED, IS_PLACED};
use super::base::objects::{ObjectEntry, PickableObject};
use super::base::{canonical, term_field};
use super::config::{validate_range, Range, Region};
use super::context::TaskContext;
use super::episode::{ObjectStart, ObjectVariant, PLATFORM_GOAL_REGION};
use super::observation::{info_field, InfoField, InfoType};
use super::registry::{TaskDescriptor, TaskSpec};
use super::reward::cube_terms::{CARRY, GRASP, LIFT, PLACE, REACH, RELEASE};
use super::reward::RewardContext;
use super::{EpisodeStart, ResetOptions, SlotSpec, Task, Verdict, View};
use crate::config::{invalid, PlatformConfig};
use crate::error::{Error, Result};
use crate::physics::{BodyState, ObjectShape, ObjectSpec, Scene, Simulation};

/// Size of each goal: the object centre's position.
const GOAL_DIM: usize = 3;

/// The task's own info entries (the cube tasks' keys).
const INFO_FIELDS: [InfoField; 12] = [
    info_field(
        "is_grasped",
        InfoType::Bool,
        "both fingers squeeze the object with at least the grasp force",
    ),
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
        "no robot link touches the object",
    ),
    info_field(
        "cube_at_rest",
        InfoType::Bool,
        "the object moves slower than the rest thresholds",
    ),
    info_field(
        "cube_on_platform",
        InfoType::Bool,
        "the object touches the platform",
    ),
];

/// The task's slots, after the robot's.
const SLOTS: [SlotSpec; 10] = [
    SlotSpec {
        name: "object_position",
        size: Some(3),
        description: "object centre (same as achieved_goal)",
    },
    SlotSpec {
        name: "object_orientation",
        size: Some(4),
        description: "unit quaternion x, y, z, w with w >= 0",
    },
    SlotSpec {
        name: "object_linear_velocity",
        size: Some(3),
        description: "velocity of the object's centre of mass",
    },
    SlotSpec {
        name: "object_angular_velocity",
        size: Some(3),
        description: "object angular velocity",
    },
    SlotSpec {
        name: "object_relative_position",
        size: Some(3),
        description: "object centre minus TCP position",
    },
    SlotSpec {
        name: "object_half_extents",
        size: Some(3),
        description: "half the sides of the object's bounding box in its frame (m)",
    },
    SlotSpec {
        name: "grasp_position",
        size: Some(3),
        description: "where the planned top-down grasp puts the TCP (world frame)",
    },
    SlotSpec {
        name: "grasp_direction",
        size: Some(2),
        description: "the planned grasp's closing direction: cos and sin of twice its yaw in \
                      the world",
    },
    SlotSpec {
        name: "grasp_width",
        size: Some(1),
        description: "the object's width between the pads at the planned grasp (m)",
    },
    SlotSpec {
        name: "tcp_orientation",
        size: Some(4),
        description: "the hand's orientation, x, y, z, w with w >= 0",
    },
];

/// The `pick_object` section of the configuration (`{"task": {"name": "pick_object", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PickObjectConfig {
    /// The platform the object is placed on.
    pub platform: PlatformConfig,
    /// The objects drawn from, uniformly, one per episode: shipped objects by name, mesh files
    /// by path or as maps with their mass, friction and scale ([`ObjectEntry`]). Default: the
    /// ten shipped objects.
    pub objects: Vec<ObjectEntry>,
    /// Where the object's centre starts, on the floor clear of the platform.
    pub object_region: Region,
    /// Range of the object's start yaw (rad).
    pub object_yaw_range: Range,
    /// Where goals are drawn, on the platform's top.
    pub goal_region: Region,
}

impl Default for PickObjectConfig {
    fn default() -> Self {
        Self {
            platform: PlatformConfig::default(),
            objects: ObjectEntry::shipped_set(),
            object_region: Region {
                low: [0.42, -0.16],
                high: [0.58, -0.04],
            },
            object_yaw_range: [-std::f64::consts::PI, std::f64::consts::PI],
            goal_region: PLATFORM_GOAL_REGION,
        }
    }
}

impl PickObjectConfig {
    /// Every object loaded (once per process), errors naming `task.objects[i]`.
    fn load(&self) -> Result<Vec<Arc<PickableObject>>> {
        if self.objects.is_empty() {
            return Err(invalid(
                "task.objects",
                "must name at least one object (a shipped object's name or a mesh file)",
            ));
        }
        self.objects
            .iter()
            .enumerate()
            .map(|(i, entry)| entry.load(&format!("task.objects[{i}]")))
            .collect()
    }
}

impl TaskSpec for PickObject {
    type Config = PickObjectConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "pick_object",
        id_stem: "PickObject",
        // 4 s at 25 Hz: the expert turns the hand to the grasp as it comes in.
        episode_steps: 100,
        has_platform: true,
        summary: "pick an object of a set up from the floor and place it on the goal on the \
                  platform",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH, GRASP, LIFT, CARRY, PLACE, RELEASE],
        reward_context_keys: &RewardContext::KEYS,
    };

    // The hand turns to each object's grasp.
    const ID_POSE_ACTIONS: bool = true;
    const ID_JOINT_STEP: Option<f64> = Some(0.1);

    fn validate(section: &PickObjectConfig, _context: &TaskContext) -> Result<()> {
        section.object_region.validate("task.object_region")?;
        section.goal_region.validate("task.goal_region")?;
        validate_range(
            "task.object_yaw_range",
            section.object_yaw_range,
            f64::NEG_INFINITY,
        )?;
        let objects = section.load()?;
        // Every object, at any yaw, starts clear of the platform.
        let reach = objects
            .iter()
            .map(|o| {
                let g = &o.geometry;
                let c = o.centre();
                [g.low, g.high]
                    .iter()
                    .flat_map(|x| [g.low, g.high].map(|y| (x.x - c.x).hypot(y.y - c.y)))
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        let (low, high) = section.platform.top_face();
        let r = &section.object_region;
        let apart = (0..2).any(|i| r.high[i] + reach <= low[i] || r.low[i] - reach >= high[i]);
        if !apart {
            return Err(invalid(
                "task.object_region",
                format!(
                    "the objects ({reach:.3} m from their centres to their farthest corners) \
                     must start clear of the platform (x in [{}, {}], y in [{}, {}]) wherever \
                     they are drawn",
                    low[0], high[0], low[1], high[1]
                ),
            ));
        }
        let inside = (0..2).all(|i| {
            section.goal_region.low[i] >= low[i] && section.goal_region.high[i] <= high[i]
        });
        if !inside {
            return Err(invalid(
                "task.goal_region",
                format!(
                    "must lie on the platform's top, x in [{}, {}] and y in [{}, {}]",
                    low[0], high[0], low[1], high[1]
                ),
            ));
        }
        Ok(())
    }

    fn platform(section: &PickObjectConfig) -> Option<&PlatformConfig> {
        Some(&section.platform)
    }

    fn build(section: &PickObjectConfig, context: &TaskContext) -> Self {
        // Loaded once per process: after `validate`, this shares what it loaded. An error
        // (a task built without validating) is reported by `bind`.
        let (objects, error) = match section.load() {
            Ok(objects) => (objects, None),
            Err(e) => (Vec::new(), Some(e.to_string())),
        };
        Self {
            section: section.clone(),
            objects,
            error,
            carry: CubeTask::new(&Self::DESCRIPTOR, context, section.platform.top_center[2])
                .named("object"),
        }
    }
}

/// Pick an object of a set up and put it on the goal (see the module documentation).
#[derive(Debug, Clone)]
pub struct PickObject {
    section: PickObjectConfig,
    /// The set, loaded.
    objects: Vec<Arc<PickableObject>>,
    /// Why the set could not be loaded.
    error: Option<String>,
    /// The object's predicates and staged reward, as a carried cube's.
    carry: CubeTask,
}

impl PickObject {
    /// The labels of the objects drawn from (shipped names, file stems), in the set's order.
    pub fn object_labels(&self) -> Vec<String> {
        self.objects.iter().map(|o| o.label.clone()).collect()
    }

    /// The object of the current episode in `sim`.
    fn current(&self, sim: &Simulation) -> &PickableObject {
        let i = sim.object_variant(self.carry.cube()) as usize;
        &self.objects[i.min(self.objects.len().saturating_sub(1))]
    }
}

impl Task for PickObject {
    fn descriptor(&self) -> &'static TaskDescriptor {
        &Self::DESCRIPTOR
    }

    fn build_scene(&self) -> Scene {
        let (shape, mass, friction) = match self.objects.first() {
            Some(o) => (o.geometry.shape.clone(), o.mass, o.friction),
            None => (ObjectShape::cube(0.05), 0.1, 1.0),
        };
        Scene {
            platform: Some(self.section.platform.clone()),
            objects: vec![ObjectSpec {
                name: "object".into(),
                shape,
                mass,
                friction,
                position: [0.5, -0.1, 0.0],
                fixed: false,
                // By variant: the set's objects in order (draw_episode's variant index).
                visuals: self
                    .objects
                    .iter()
                    .map(|o| o.geometry.visual.clone())
                    .collect(),
            }],
            ..Scene::default()
        }
    }

    fn bind(&mut self, sim: &Simulation) -> Result<()> {
        if let Some(reason) = &self.error {
            return Err(Error::InvalidConfig {
                field: "task.objects".into(),
                reason: reason.clone(),
            });
        }
        self.carry.bind(sim)
    }

    fn goal_dim(&self) -> usize {
        GOAL_DIM
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        [
            "object centre position (its bounding box's centre)",
            "goal position for the object centre",
        ]
    }

    fn observation_slots(&self) -> &'static [SlotSpec] {
        &SLOTS
    }

    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart) {
        let s = &self.section;
        let mut draw = || rng.random::<f64>();
        // Always the same draws in the same order, whatever the overrides.
        let which_u = draw();
        let object_xy = s.object_region.lerp([draw(), draw()]);
        let yaw_u = draw();
        let goal_xy = s.goal_region.lerp([draw(), draw()]);
        let n = self.objects.len().max(1);
        let index = ((which_u * n as f64) as usize).min(n - 1);
        let Some(object) = self.objects.get(index) else {
            return;
        };
        let centre = object.centre();
        let [low, high] = s.object_yaw_range;
        let yaw = options.cube_yaw.unwrap_or(low + (high - low) * yaw_u);
        let orientation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
        // The frame origin that puts the centre over `object_xy` and the lowest point on the
        // floor.
        let offset = orientation * Vector3::new(centre.x, centre.y, 0.0);
        let position = options.cube_position.map_or(
            Vector3::new(
                object_xy[0] - offset.x,
                object_xy[1] - offset.y,
                -object.geometry.low.z,
            ),
            Vector3::from,
        );
        let half_height = object.half_extents().z;
        let goal = options.goal.map_or(
            Vector3::new(
                goal_xy[0],
                goal_xy[1],
                s.platform.top_center[2] + half_height,
            ),
            Vector3::from,
        );
        start.set(
            [ObjectStart {
                object: self.carry.cube(),
                position,
                orientation,
                properties: None,
                shape: Some(object.geometry.shape.clone()),
                variant: Some(ObjectVariant {
                    index: index as u32,
                    mass: object.mass,
                    friction: object.friction,
                    rolling_damping: object.rolling_damping,
                }),
            }],
            goal.iter().copied(),
        );
    }

    fn observe(
        &self,
        sim: &Simulation,
        tcp: &BodyState,
        _goal: &[f64],
        achieved: &mut [f64],
        extras: &mut [f64],
    ) {
        let object = self.current(sim);
        let state = sim.object_state(self.carry.cube());
        let pose = |p: Vector3<f64>| state.position + state.orientation * p;
        let centre = pose(object.centre());
        achieved.copy_from_slice(centre.as_slice());
        let grasp = &object.geometry.grasp;
        let grasp_position = pose(grasp.position);
        let closing = state.orientation * Vector3::new(grasp.yaw.cos(), grasp.yaw.sin(), 0.0);
        let twice = 2.0 * closing.y.atan2(closing.x);
        let relative = centre - tcp.position;
        let half = object.half_extents();
        let values: [&[f64]; 10] = [
            centre.as_slice(),
            &canonical(&state.orientation),
            state.linear_velocity.as_slice(),
            state.angular_velocity.as_slice(),
            relative.as_slice(),
            half.as_slice(),
            grasp_position.as_slice(),
            &[twice.cos(), twice.sin()],
            &[grasp.width],
            &canonical(&tcp.orientation),
        ];
        for (o, v) in extras.iter_mut().zip(values.iter().flat_map(|s| s.iter())) {
            *o = *v;
        }
    }

    fn evaluate(&self, view: &View<'_>) -> Verdict {
        let half_height = self.current(view.sim).half_extents().z;
        self.carry.evaluate_resting(view, half_height)
    }

    fn compute_rewards(
        &self,
        achieved: &[f32],
        desired: &[f32],
        contexts: &[f32],
        out: &mut [f32],
    ) -> Result<()> {
        self.carry.compute_rewards(achieved, desired, contexts, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn task() -> PickObject {
        PickObject::build(
            &Default::default(),
            &TaskContext::defaults(PickObject::DESCRIPTOR.reward_terms),
        )
    }

    #[test]
    fn panda_layout_matches_the_documented_table() {
        crate::task::observation::assert_documented_layout(
            &task(),
            include_str!("pick_object.rs"),
            60,
        );
    }

    #[test]
    fn the_whole_shipped_set_loads_with_a_grasp() {
        let task = task();
        assert!(task.error.is_none(), "{:?}", task.error);
        assert_eq!(task.objects.len(), 10);
        for o in &task.objects {
            let g = &o.geometry.grasp;
            assert!(g.width > 0.0 && g.width < 0.08, "{}: {g:?}", o.label);
        }
    }
}
