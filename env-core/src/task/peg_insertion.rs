//! [`PegInsertion`]: pick up a peg lying on the floor, turn it to a hole in a box fixed on the
//! platform and insert it to the hole's bottom (ManiSkill's PegInsertionSide, with a blind hole).
//!
//! Over 600 lines: the task's observation table, configuration with its validation, geometry
//! (peg, box, goals), staged reward, and their unit tests, kept in one place.
//!
//! # Observation
//!
//! The goals are the positions of the peg's two end-face centres and where they go; for the
//! Panda `observation` has 56 entries and the flat vector 68:
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0..6 | `achieved_goal` | `achieved_goal` | 6 | centres of the peg's two end faces: its +x end, then its -x end |
//! | 6..12 | `desired_goal` | `desired_goal` | 6 | where they go: the hole's bottom, then a peg length out of the hole along its axis |
//! | 12..21 | `observation` 0..9 | `joint_positions` | 9 | arm joints 1-7 (rad), finger joints 1-2 (m) |
//! | 21..30 | `observation` 9..18 | `joint_velocities` | 9 | their velocities |
//! | 30..33 | `observation` 18..21 | `tcp_position` | 3 | tool centre point (between the fingertips) |
//! | 33..36 | `observation` 21..24 | `tcp_velocity` | 3 | its linear velocity |
//! | 36 | `observation` 24 | `gripper_width` | 1 | opening between the finger pads (m) |
//! | 37..40 | `observation` 25..28 | `peg_position` | 3 | peg centre |
//! | 40..44 | `observation` 28..32 | `peg_orientation` | 4 | unit quaternion x, y, z, w with w >= 0; the peg's length is along its x axis |
//! | 44..47 | `observation` 32..35 | `peg_linear_velocity` | 3 | peg centre velocity |
//! | 47..50 | `observation` 35..38 | `peg_angular_velocity` | 3 | peg angular velocity |
//! | 50..53 | `observation` 38..41 | `peg_relative_position` | 3 | peg centre minus TCP position |
//! | 53..56 | `observation` 41..44 | `peg_half_extents` | 3 | the peg's half length, half width and half height (m) |
//! | 56..59 | `observation` 44..47 | `hole_position` | 3 | centre of the hole's opening |
//! | 59..63 | `observation` 47..51 | `hole_orientation` | 4 | the box's orientation, x, y, z, w with w >= 0; its x axis points into the hole |
//! | 63 | `observation` 51 | `hole_half_width` | 1 | half the hole's width (m): the peg's half width plus the clearance |
//! | 64..68 | `observation` 52..56 | `tcp_orientation` | 4 | the hand's orientation, x, y, z, w with w >= 0 |
//!
//! # Starting state
//! The peg, a square bar of half length and half width drawn from `task.peg_half_length` and
//! `task.peg_half_width`, lies on the floor at a uniform position in `task.peg_region`, its
//! length turned by a uniform yaw in `task.peg_yaw_range` from the x axis. The box stands on the
//! platform, its centre uniform in `task.hole_region`, its hole's axis turned by a uniform yaw
//! in `task.hole_yaw_range` from the x axis (the opening faces the robot). The hole is square,
//! `task.clearance` wider than the peg on every side, `task.insertion_depth` deep and closed at
//! the bottom; its walls are `task.wall_thickness` thick. `reset(options=...)` takes
//! `cube_position` and `cube_yaw` for the peg's centre and yaw, and `goal` for the box's centre
//! (its height is ignored: the box stands on the platform).
//!
//! # Success
//! The peg is symmetric, so either end may go in: success when, with the ends paired to their
//! goals the nearer way, both are within `task.success_tolerance` of their goal, i.e. the peg
//! lies along the hole's axis with its leading end at the bottom (inserted `insertion_depth`,
//! less the tolerance). `goal_distance` is the larger of the two ends' distances.
//!
//! # Rewards
//! `sparse`: -1 until success, then 0. `dense`, staged as ManiSkill's: `reach` (the TCP near
//! the peg's centre), `grasp` (both fingers squeeze the peg), `align` (both ends near the hole's
//! axis line) and `insert` (the leading end near the bottom, once both ends are within
//! [`ALIGNED`] of the axis line), each in `[0, weight]`. `align` and `insert` are recomputed
//! from the goals (the axis line runs through the two desired ends), so relabelled goals get
//! exactly the reward the environment would have given.
//!
//! # Contact
//! No solver setting differs from every task's. With the scripted expert inserting the peg
//! (`examples/peg_contacts.rs`, 200 seeds, `ee_pose` control), the peg and the box overlap by
//! at most 1.3 mm (median of the episodes' deepest 1.1 mm: the solver's allowed error) at the
//! default 3 mm clearance and 1.7 mm at 2 mm; the largest normal force between them is 9.8 N
//! (median 6.8 N; 19.9 N at 2 mm), the peg weighing 0.05 kg; the leading end never goes past
//! the hole's 40 mm bottom by more than 0.2 mm (no tunnelling), and every episode ends
//! inserted (none sticks at the opening).

use nalgebra::{UnitQuaternion, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::config::{validate_range, Range, Region};
use super::context::TaskContext;
use super::episode::{ObjectStart, TaskInfo};
use super::registry::{TaskDescriptor, TaskSpec};
use super::{EpisodeStart, ResetOptions, SlotSpec, Task, Verdict, View};
use crate::config::{invalid, PlatformConfig};
use crate::error::Result;
use crate::physics::{BodyState, ObjectId, ObjectShape, ObjectSpec, Scene, ShapePart, Simulation};
use crate::task::base::{
    canonical, compute_reach_grasp_rewards, norm, term_field, REACH_GRASP_CONTEXT,
};
use crate::task::config::RewardType;
use crate::task::observation::{info_field, InfoField, InfoType};
use crate::task::reward::{closeness, RewardTerm};

/// Size of each goal: two positions, the peg's ends.
const GOAL_DIM: usize = 6;

/// Both ends within this distance (m) of the hole's axis line count as aligned: `insert` pays
/// from there on.
pub const ALIGNED: f64 = 0.01;

/// `reach`: the TCP near the peg.
pub const REACH: RewardTerm = RewardTerm {
    name: "reach",
    info_key: "reward_reach",
    default_weight: 1.0,
    description: "`1 - tanh(5 d)`, `d` = distance from the TCP to the peg's centre",
};
/// `grasp`: both fingers squeeze the peg.
pub const GRASP: RewardTerm = RewardTerm {
    name: "grasp",
    info_key: "reward_grasp",
    default_weight: 1.0,
    description: "1 while both fingers squeeze the peg (`is_grasped`)",
};
/// `align`: the peg along the hole's axis.
pub const ALIGN: RewardTerm = RewardTerm {
    name: "align",
    info_key: "reward_align",
    default_weight: 3.0,
    description: "`1 - tanh(10 e)`, `e` = the larger distance of the peg's two ends from the \
                  hole's axis line",
};
/// `insert`: the leading end near the hole's bottom.
pub const INSERT: RewardTerm = RewardTerm {
    name: "insert",
    info_key: "reward_insert",
    default_weight: 5.0,
    description: "`1 - tanh(5 d)`, `d` = distance from the leading end to the hole's bottom, \
                  once both ends are within 1 cm of the axis line",
};

/// `is_grasped`: both fingers squeeze the peg.
const IS_GRASPED: InfoField = info_field(
    "is_grasped",
    InfoType::Bool,
    "both fingers squeeze the peg with at least the grasp force",
);
/// `insertion_depth`: how far the leading end is in.
const INSERTION_DEPTH: InfoField = info_field(
    "insertion_depth",
    InfoType::Float,
    "depth (m) of the peg's leading end past the hole's opening, along its axis (negative \
     outside)",
);
/// `peg_axis_offset`: the larger distance of the two ends from the axis line.
const AXIS_OFFSET: InfoField = info_field(
    "peg_axis_offset",
    InfoType::Float,
    "the larger distance (m) of the peg's two ends from the hole's axis line",
);

/// The task's own info entries.
const INFO_FIELDS: [InfoField; 7] = [
    IS_GRASPED,
    INSERTION_DEPTH,
    AXIS_OFFSET,
    term_field(REACH),
    term_field(GRASP),
    term_field(ALIGN),
    term_field(INSERT),
];

/// The task's slots, after the robot's.
const SLOTS: [SlotSpec; 10] = [
    SlotSpec {
        name: "peg_position",
        size: Some(3),
        description: "peg centre",
    },
    SlotSpec {
        name: "peg_orientation",
        size: Some(4),
        description: "unit quaternion x, y, z, w with w >= 0; the peg's length is along its x \
                      axis",
    },
    SlotSpec {
        name: "peg_linear_velocity",
        size: Some(3),
        description: "peg centre velocity",
    },
    SlotSpec {
        name: "peg_angular_velocity",
        size: Some(3),
        description: "peg angular velocity",
    },
    SlotSpec {
        name: "peg_relative_position",
        size: Some(3),
        description: "peg centre minus TCP position",
    },
    SlotSpec {
        name: "peg_half_extents",
        size: Some(3),
        description: "the peg's half length, half width and half height (m)",
    },
    SlotSpec {
        name: "hole_position",
        size: Some(3),
        description: "centre of the hole's opening",
    },
    SlotSpec {
        name: "hole_orientation",
        size: Some(4),
        description: "the box's orientation, x, y, z, w with w >= 0; its x axis points into \
                      the hole",
    },
    SlotSpec {
        name: "hole_half_width",
        size: Some(1),
        description: "half the hole's width (m): the peg's half width plus the clearance",
    },
    SlotSpec {
        name: "tcp_orientation",
        size: Some(4),
        description: "the hand's orientation, x, y, z, w with w >= 0",
    },
];
/// Index of `peg_relative_position` among [`SLOTS`].
const RELATIVE_POSITION: usize = 4;

/// The `peg_insertion` section of the configuration (`{"task": {"name": "peg_insertion",
/// ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PegInsertionConfig {
    /// The platform the box stands on.
    pub platform: PlatformConfig,
    /// Range of the peg's half length (m).
    pub peg_half_length: Range,
    /// Range of the peg's half width (m; its cross-section is square).
    pub peg_half_width: Range,
    /// The peg's mass (kg).
    pub peg_mass: f64,
    /// The peg's friction coefficient (the box takes the platform's).
    pub peg_friction: f64,
    /// Where the peg's centre starts, on the floor clear of the platform.
    pub peg_region: Region,
    /// Range of the peg's start yaw (rad), its length's angle from the x axis.
    pub peg_yaw_range: Range,
    /// Where the box's centre stands, on the platform's top.
    pub hole_region: Region,
    /// Range of the yaw (rad) of the hole's axis from the x axis.
    pub hole_yaw_range: Range,
    /// How much wider (m) the hole is than the peg on every side.
    pub clearance: f64,
    /// Depth (m) of the hole: where the peg's leading end goes.
    pub insertion_depth: f64,
    /// Thickness (m) of the box's walls and bottom.
    pub wall_thickness: f64,
    /// Largest distance (m) of each end from its goal that counts as inserted.
    pub success_tolerance: f64,
}

impl Default for PegInsertionConfig {
    fn default() -> Self {
        Self {
            platform: PlatformConfig::default(),
            peg_half_length: [0.05, 0.07],
            peg_half_width: [0.015, 0.02],
            peg_mass: 0.05,
            peg_friction: 1.0,
            peg_region: Region {
                low: [0.42, -0.15],
                high: [0.58, -0.05],
            },
            peg_yaw_range: [-1.0, 1.0],
            hole_region: Region {
                low: [0.5, 0.25],
                high: [0.56, 0.35],
            },
            hole_yaw_range: [-0.39, 0.39],
            clearance: 0.003,
            insertion_depth: 0.04,
            wall_thickness: 0.01,
            success_tolerance: 0.01,
        }
    }
}

impl PegInsertionConfig {
    /// The hole's half width for a peg of half width `r`.
    fn hole_half_width(&self, r: f64) -> f64 {
        r + self.clearance
    }

    /// The box's half depth along the hole's axis (the hole and the bottom).
    fn box_half_depth(&self) -> f64 {
        (self.insertion_depth + self.wall_thickness) / 2.0
    }

    /// The box around a hole of half width `h`, in its own frame (centred, x into the hole):
    /// four walls round the hole and the bottom at +x.
    fn box_shape(&self, h: f64) -> ObjectShape {
        let t = self.wall_thickness;
        let hx = self.box_half_depth();
        let slab = |half: [f64; 3], at: [f64; 3]| {
            ShapePart::at(at, ObjectShape::Box { half_extents: half })
        };
        ObjectShape::Compound {
            parts: vec![
                // Top and bottom walls span the whole width.
                slab([hx, h + t, t / 2.0], [0.0, 0.0, h + t / 2.0]),
                slab([hx, h + t, t / 2.0], [0.0, 0.0, -h - t / 2.0]),
                // Side walls between them.
                slab([hx, t / 2.0, h], [0.0, h + t / 2.0, 0.0]),
                slab([hx, t / 2.0, h], [0.0, -h - t / 2.0, 0.0]),
                // The hole's bottom.
                slab([t / 2.0, h, h], [hx - t / 2.0, 0.0, 0.0]),
            ],
        }
    }

    /// The peg of half length `l` and half width `r`.
    fn peg_shape(l: f64, r: f64) -> ObjectShape {
        ObjectShape::Box {
            half_extents: [l, r, r],
        }
    }

    /// The middle of a range.
    fn mid(r: Range) -> f64 {
        0.5 * (r[0] + r[1])
    }
}

impl TaskSpec for PegInsertion {
    type Config = PegInsertionConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "peg_insertion",
        id_stem: "PegInsertion",
        // ManiSkill's PegInsertionSide takes 100 steps at 20 Hz.
        episode_steps: 100,
        has_platform: true,
        summary: "pick up the peg, turn it to the hole in the box and insert it",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH, GRASP, ALIGN, INSERT],
        reward_context_keys: &REACH_GRASP_CONTEXT,
    };

    // The peg lies at any yaw and the hole's axis is turned: its end-effector ids turn the hand.
    const ID_POSE_ACTIONS: bool = true;

    // Turning the hand as well as carrying the peg across takes the joints faster than 0.05 rad
    // per step allows within the episode (the expert's `joints` success on 200 seeds: 79.0 %
    // at 0.05, 88.5 % at 0.1).
    const ID_JOINT_STEP: Option<f64> = Some(0.1);

    fn validate(section: &PegInsertionConfig, _context: &TaskContext) -> Result<()> {
        validate_range("task.peg_half_length", section.peg_half_length, 1e-3)?;
        validate_range("task.peg_half_width", section.peg_half_width, 1e-3)?;
        validate_range(
            "task.peg_yaw_range",
            section.peg_yaw_range,
            f64::NEG_INFINITY,
        )?;
        validate_range(
            "task.hole_yaw_range",
            section.hole_yaw_range,
            f64::NEG_INFINITY,
        )?;
        section.peg_region.validate("task.peg_region")?;
        section.hole_region.validate("task.hole_region")?;
        let positive = |field: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(invalid(field, format!("must be finite and > 0, got {v}")))
            }
        };
        positive("task.peg_mass", section.peg_mass)?;
        positive("task.clearance", section.clearance)?;
        positive("task.insertion_depth", section.insertion_depth)?;
        positive("task.wall_thickness", section.wall_thickness)?;
        positive("task.success_tolerance", section.success_tolerance)?;
        let f = section.peg_friction;
        if !(f.is_finite() && f >= 0.0) {
            return Err(invalid(
                "task.peg_friction",
                format!("must be finite and >= 0, got {f}"),
            ));
        }
        let shortest = 2.0 * section.peg_half_length[0];
        if section.insertion_depth >= shortest {
            return Err(invalid(
                "task.insertion_depth",
                format!(
                    "must be shorter than the shortest peg ({shortest} m), got {}",
                    section.insertion_depth
                ),
            ));
        }
        // The box stands on the platform's top wherever it is drawn, at any yaw.
        let (low, high) = section.platform.top_face();
        let h = section.hole_half_width(section.peg_half_width[1]);
        let reach = section.box_half_depth().hypot(h + section.wall_thickness);
        let r = &section.hole_region;
        let inside = (0..2).all(|i| r.low[i] - reach >= low[i] && r.high[i] + reach <= high[i]);
        if !inside {
            return Err(invalid(
                "task.hole_region",
                format!(
                    "the box ({reach:.3} m from its centre to a corner) must stand on the \
                     platform's top, x in [{}, {}] and y in [{}, {}], wherever it is drawn",
                    low[0], high[0], low[1], high[1]
                ),
            ));
        }
        Ok(())
    }

    fn platform(section: &PegInsertionConfig) -> Option<&PlatformConfig> {
        Some(&section.platform)
    }

    fn build(section: &PegInsertionConfig, context: &TaskContext) -> Self {
        Self {
            section: section.clone(),
            context: context.clone(),
            peg: None,
            hole_box: None,
        }
    }
}

/// Insert a peg into a hole (see the module documentation).
#[derive(Debug, Clone)]
pub struct PegInsertion {
    section: PegInsertionConfig,
    context: TaskContext,
    peg: Option<ObjectId>,
    hole_box: Option<ObjectId>,
}

/// What a transition's goals say: success, the distance, the terms and the geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Judgement {
    is_success: bool,
    distance: f64,
    reward: f32,
    align: f32,
    insert: f32,
    /// The larger distance of the ends from the axis line.
    axis_offset: f64,
    /// How far the leading end is short of the bottom, along the axis (m).
    short_of_bottom: f64,
}

fn at(v: &[f32], i: usize) -> Vector3<f64> {
    Vector3::new(v[i] as f64, v[i + 1] as f64, v[i + 2] as f64)
}

impl PegInsertion {
    fn peg(&self) -> ObjectId {
        self.peg.unwrap_or_else(ObjectId::first)
    }

    fn hole_box(&self) -> ObjectId {
        self.hole_box.unwrap_or_else(ObjectId::first)
    }

    /// Success, distance, reward and terms of one transition's goals; `reach` and `grasp` are
    /// the weighted goal-free terms.
    fn judge(&self, achieved: &[f32], desired: &[f32], reach: f32, grasp: f32) -> Judgement {
        let (a, b) = (at(achieved, 0), at(achieved, 3));
        let (bottom, outside) = (at(desired, 0), at(desired, 3));
        let axis = (bottom - outside)
            .try_normalize(1e-9)
            .unwrap_or_else(Vector3::x);
        // The nearer pairing of the ends with their goals.
        let straight = (a - bottom).norm().max((b - outside).norm());
        let swapped = (b - bottom).norm().max((a - outside).norm());
        let (distance, lead, tail) = if straight <= swapped {
            (straight, a, b)
        } else {
            (swapped, b, a)
        };
        let off_axis = |p: Vector3<f64>| {
            let d = p - bottom;
            (d - axis * d.dot(&axis)).norm()
        };
        let axis_offset = off_axis(lead).max(off_axis(tail));
        let short_of_bottom = (bottom - lead).dot(&axis);
        let is_success = distance <= self.section.success_tolerance;
        let w = &self.context.reward_weights;
        let align = (w.align * (1.0 - (10.0 * axis_offset).tanh())) as f32;
        let insert = if axis_offset < ALIGNED {
            w.insert as f32 * closeness((lead - bottom).norm())
        } else {
            0.0
        };
        let reward = match self.context.reward_type {
            RewardType::Sparse => {
                if is_success {
                    0.0
                } else {
                    -1.0
                }
            }
            RewardType::Dense => reach + grasp + align + insert,
        };
        Judgement {
            is_success,
            distance,
            reward,
            align,
            insert,
            axis_offset,
            short_of_bottom,
        }
    }
}

impl Task for PegInsertion {
    fn descriptor(&self) -> &'static TaskDescriptor {
        &Self::DESCRIPTOR
    }

    fn build_scene(&self) -> Scene {
        let s = &self.section;
        let l = PegInsertionConfig::mid(s.peg_half_length);
        let r = PegInsertionConfig::mid(s.peg_half_width);
        let h = s.hole_half_width(r);
        let top = s.platform.top_center;
        Scene {
            platform: Some(s.platform.clone()),
            objects: vec![
                ObjectSpec {
                    name: "peg".into(),
                    shape: PegInsertionConfig::peg_shape(l, r),
                    mass: s.peg_mass,
                    friction: s.peg_friction,
                    position: [0.5, -0.1, r],
                    fixed: false,
                    visuals: Vec::new(),
                },
                ObjectSpec {
                    name: "hole_box".into(),
                    shape: s.box_shape(h),
                    mass: 1.0,
                    friction: s.platform.friction,
                    position: [top[0], top[1], top[2] + h + s.wall_thickness],
                    fixed: true,
                    visuals: Vec::new(),
                },
            ],
            ..Scene::default()
        }
    }

    fn bind(&mut self, sim: &Simulation) -> Result<()> {
        self.peg = Some(sim.object("peg")?);
        self.hole_box = Some(sim.object("hole_box")?);
        Ok(())
    }

    fn goal_dim(&self) -> usize {
        GOAL_DIM
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        [
            "centres of the peg's two end faces: its +x end, then its -x end",
            "where they go: the hole's bottom, then a peg length out of the hole along its axis",
        ]
    }

    fn observation_slots(&self) -> &'static [SlotSpec] {
        &SLOTS
    }

    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart) {
        let s = &self.section;
        let mut draw = || rng.random::<f64>();
        // Always the same draws in the same order, whatever the overrides.
        let peg_xy = s.peg_region.lerp([draw(), draw()]);
        let peg_yaw_u = draw();
        let length_u = draw();
        let width_u = draw();
        let box_xy = s.hole_region.lerp([draw(), draw()]);
        let box_yaw_u = draw();
        let lerp = |r: Range, u: f64| r[0] + (r[1] - r[0]) * u;
        let l = lerp(s.peg_half_length, length_u);
        let r = lerp(s.peg_half_width, width_u);
        let h = s.hole_half_width(r);
        let peg_yaw = options
            .cube_yaw
            .unwrap_or_else(|| lerp(s.peg_yaw_range, peg_yaw_u));
        let peg_position = options
            .cube_position
            .map_or(Vector3::new(peg_xy[0], peg_xy[1], r), Vector3::from);
        let box_xy = options.goal.map_or(box_xy, |g| [g[0], g[1]]);
        let box_yaw = lerp(s.hole_yaw_range, box_yaw_u);
        let box_rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), box_yaw);
        let box_center = Vector3::new(
            box_xy[0],
            box_xy[1],
            s.platform.top_center[2] + h + s.wall_thickness,
        );
        let axis = box_rotation * Vector3::x();
        let bottom = box_center + axis * (s.box_half_depth() - s.wall_thickness);
        let outside = bottom - axis * (2.0 * l);
        start.set(
            [
                ObjectStart {
                    object: self.peg(),
                    position: peg_position,
                    orientation: UnitQuaternion::from_axis_angle(&Vector3::z_axis(), peg_yaw),
                    properties: None,
                    shape: Some(PegInsertionConfig::peg_shape(l, r)),
                    variant: None,
                },
                ObjectStart {
                    object: self.hole_box(),
                    position: box_center,
                    orientation: box_rotation,
                    properties: None,
                    shape: Some(s.box_shape(h)),
                    variant: None,
                },
            ],
            bottom.iter().chain(outside.iter()).copied(),
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
        let peg = sim.object_state(self.peg());
        let half = sim.object_half_extents(self.peg());
        let along = peg.orientation * Vector3::x() * half.x;
        let (plus, minus) = (peg.position + along, peg.position - along);
        achieved[..3].copy_from_slice(plus.as_slice());
        achieved[3..].copy_from_slice(minus.as_slice());
        let hole = sim.object_state(self.hole_box());
        let hole_half = sim.object_half_extents(self.hole_box());
        let opening = hole.position - hole.orientation * Vector3::x() * hole_half.x;
        // The hole's half width: the box's half width less a wall.
        let hole_half_width = [hole_half.y - self.section.wall_thickness];
        let relative = peg.position - tcp.position;
        let values: [&[f64]; 10] = [
            peg.position.as_slice(),
            &canonical(&peg.orientation),
            peg.linear_velocity.as_slice(),
            peg.angular_velocity.as_slice(),
            relative.as_slice(),
            half.as_slice(),
            opening.as_slice(),
            &canonical(&hole.orientation),
            &hole_half_width,
            &canonical(&tcp.orientation),
        ];
        for (o, v) in extras.iter_mut().zip(values.iter().flat_map(|s| s.iter())) {
            *o = *v;
        }
    }

    fn evaluate(&self, view: &View<'_>) -> Verdict {
        let l = view.layout;
        let obs = view.observation;
        let w = &self.context.reward_weights;
        let touch = view.sim.object_touch(self.peg());
        let is_grasped = touch
            .finger_forces
            .iter()
            .all(|&f| f >= self.context.thresholds.grasp_force);
        let reach = w.reach as f32 * closeness(norm(&obs[l.task_slot(RELATIVE_POSITION)]));
        let grasp = if is_grasped { w.grasp as f32 } else { 0.0 };
        let j = self.judge(
            &obs[l.achieved_goal()],
            &obs[l.desired_goal()],
            reach,
            grasp,
        );
        let mut info = TaskInfo::new(&INFO_FIELDS);
        info.set(IS_GRASPED.key, is_grasped);
        info.set(
            INSERTION_DEPTH.key,
            self.section.insertion_depth - j.short_of_bottom,
        );
        info.set(AXIS_OFFSET.key, j.axis_offset);
        info.set(REACH.info_key, reach);
        info.set(GRASP.info_key, grasp);
        if self.context.reward_type == RewardType::Dense {
            info.set(ALIGN.info_key, j.align);
            info.set(INSERT.info_key, j.insert);
        }
        Verdict {
            is_success: j.is_success,
            goal_distance: j.distance,
            reward: j.reward,
            info,
        }
    }

    fn compute_rewards(
        &self,
        achieved: &[f32],
        desired: &[f32],
        contexts: &[f32],
        out: &mut [f32],
    ) -> Result<()> {
        compute_reach_grasp_rewards(
            self.context.reward_type,
            GOAL_DIM,
            (achieved, desired, contexts),
            out,
            |a, d, reach, grasp| self.judge(a, d, reach, grasp).reward,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn task() -> PegInsertion {
        PegInsertion::build(
            &Default::default(),
            &TaskContext::defaults(PegInsertion::DESCRIPTOR.reward_terms),
        )
    }

    #[test]
    fn panda_layout_matches_the_documented_table() {
        crate::task::observation::assert_documented_layout(
            &task(),
            include_str!("peg_insertion.rs"),
            68,
        );
    }

    #[test]
    fn either_end_may_go_in_and_success_needs_both_ends_at_their_goals() {
        let task = task();
        let desired = [0.5f32, 0.3, 0.13, 0.38, 0.3, 0.13];
        let inserted = [0.5f32, 0.3, 0.13, 0.38, 0.3, 0.13];
        let reversed = [0.38f32, 0.3, 0.13, 0.5, 0.3, 0.13];
        for achieved in [inserted, reversed] {
            let j = task.judge(&achieved, &desired, 0.0, 0.0);
            assert!(j.is_success && j.distance < 1e-6, "{j:?}");
        }
        // Lying across the opening, its centre where an inserted peg's would be: no success.
        let across = [0.44f32, 0.24, 0.13, 0.44, 0.36, 0.13];
        let j = task.judge(&across, &desired, 0.0, 0.0);
        assert!(!j.is_success && j.axis_offset > 0.05, "{j:?}");
        // Half way in: aligned, 2 cm short.
        let half = [0.48f32, 0.3, 0.13, 0.36, 0.3, 0.13];
        let j = task.judge(&half, &desired, 0.0, 0.0);
        assert!(!j.is_success && j.axis_offset < 1e-6);
        assert!((j.short_of_bottom - 0.02).abs() < 1e-6, "{j:?}");
    }

    #[test]
    fn the_goal_is_the_hole_s_bottom_a_peg_length_along_its_axis() {
        let task = task();
        let s = &task.section;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut start = EpisodeStart::default();
        for _ in 0..200 {
            task.draw_episode(&mut rng, &ResetOptions::default(), &mut start);
            let g = &start.goal;
            let (bottom, outside) = (
                Vector3::new(g[0], g[1], g[2]),
                Vector3::new(g[3], g[4], g[5]),
            );
            let Some(ObjectShape::Box { half_extents }) = &start.objects[0].shape else {
                panic!("the peg is a box");
            };
            assert!((bottom - outside).norm() - 2.0 * half_extents[0] < 1e-12);
            let box_start = &start.objects[1];
            let axis = box_start.orientation * Vector3::x();
            // The bottom lies insertion_depth in from the opening, at the hole's centre.
            let opening = box_start.position - axis * s.box_half_depth();
            assert!(((bottom - opening).dot(&axis) - s.insertion_depth).abs() < 1e-12);
            assert!((bottom.z - box_start.position.z).abs() < 1e-12);
            let yaw = axis.y.atan2(axis.x);
            assert!(yaw >= s.hole_yaw_range[0] && yaw <= s.hole_yaw_range[1]);
        }
    }
}
