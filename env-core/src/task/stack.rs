//! [`Stack`]: put one cube on the goal on the platform and the other on top of it (panda-gym's
//! PandaStack, with the platform as the base).
//!
//! Over 600 lines: the task's observation table, start, success and its reward with the
//! `stage` term's reasoning, and their unit tests, kept in one place.
//!
//! # Observation
//!
//! Two cubes, `cube1` (the bottom one) and `cube2`: for the Panda `observation` has 57 entries
//! and the flat vector 69.
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0..6 | `achieved_goal` | `achieved_goal` | 6 | centres of cube1 and cube2 |
//! | 6..12 | `desired_goal` | `desired_goal` | 6 | their goals: on the platform, and on top of that |
//! | 12..21 | `observation` 0..9 | `joint_positions` | 9 | arm joints 1-7 (rad), finger joints 1-2 (m) |
//! | 21..30 | `observation` 9..18 | `joint_velocities` | 9 | their velocities |
//! | 30..33 | `observation` 18..21 | `tcp_position` | 3 | tool centre point (between the fingertips) |
//! | 33..36 | `observation` 21..24 | `tcp_velocity` | 3 | its linear velocity |
//! | 36 | `observation` 24 | `gripper_width` | 1 | opening between the finger pads (m) |
//! | 37..40 | `observation` 25..28 | `cube1_position` | 3 | cube1's centre |
//! | 40..44 | `observation` 28..32 | `cube1_orientation` | 4 | unit quaternion x, y, z, w with w >= 0 |
//! | 44..47 | `observation` 32..35 | `cube1_linear_velocity` | 3 | cube1's centre velocity |
//! | 47..50 | `observation` 35..38 | `cube1_angular_velocity` | 3 | cube1's angular velocity |
//! | 50..53 | `observation` 38..41 | `cube1_relative_position` | 3 | cube1's centre minus TCP position |
//! | 53..56 | `observation` 41..44 | `cube2_position` | 3 | cube2's centre |
//! | 56..60 | `observation` 44..48 | `cube2_orientation` | 4 | unit quaternion x, y, z, w with w >= 0 |
//! | 60..63 | `observation` 48..51 | `cube2_linear_velocity` | 3 | cube2's centre velocity |
//! | 63..66 | `observation` 51..54 | `cube2_angular_velocity` | 3 | cube2's angular velocity |
//! | 66..69 | `observation` 54..57 | `cube2_relative_position` | 3 | cube2's centre minus TCP position |
//!
//! # Starting state
//! Both cubes on the floor in `task.cube_region`, one in each half along y with 0.1 m between
//! the halves (which cube gets which half is drawn), each with a uniform yaw in
//! `task.cube_yaw_range` (see [`StackConfig`]). cube1's goal is uniform in `task.goal_region`
//! resting on the platform; cube2's is straight above
//! it, resting on cube1. With probability `task.cube1_on_goal_probability` (0 unless set)
//! cube1 starts resting on its goal instead, so that only cube2 is left to stack: a
//! start-state curriculum for learning the second pick and place from scratch (its draw comes
//! after all the others, and is made only when the probability is above 0, so the ids'
//! episodes are unchanged). The reset options `cube_position` and `goal` set cube1's start
//! and goal; `cube_yaw` both yaws.
//!
//! # Success and rewards
//! `is_success`: both cubes within `success_threshold` of their goals (`goal_distance` is the
//! larger of the two distances). `is_placed`: besides, no robot link touches either cube, both
//! are at rest, cube1 touches the platform and cube2 touches cube1. `sparse`: -1 until success,
//! then 0. `dense`: `reach` (`1 - tanh(k d)`, `d` from the TCP to the first cube not at its
//! goal, `k` the rate `task.reward_distance_rate`, 5 per metre by default) + `grasp` (either
//! cube squeezed by both fingers) + `lift` (that cube's height above its floor resting height
//! over the platform's height, clipped to [0, 1]; weight 0 unless `reward_weights` sets
//! one) + `carry` times the mean of `1 - tanh(k d_i)` over the two cubes + `place` once
//! placed + `stage` times the milestones reached (weight 0 unless `reward_weights` sets one,
//! below) + `release`, the gripper opening the action commands while cube2 is ready to be let
//! go (weight 0 unless set, below), each with its `reward_weights` entry. Without `lift`,
//! lifting a cube pays only through its distance to a goal 0.2-0.5 m away: PPO from scratch
//! carried cube1 to its goal in at most 4 % of episodes without it, 14 % with it
//! (`docs/training.md`, 2026-11-27; neither stacked). The info's `cube_*` flags describe the
//! pair (released: neither cube touched; at rest: both; on platform: stacked as above);
//! `cube1_grasped` is cube1's own grasp.
//!
//! ## The `stage` term
//! Without it the dense reward falls when cube1 reaches its goal: `reach` and `lift` turn to
//! cube2, still on the floor, and letting cube1 go then loses `grasp`. Along the scripted
//! expert's stack (seed 0, `lift` 1) the reward falls from 3.7 to 1.8 as cube1 arrives and to
//! 0.95 as it is let go, and the released stack pays less than carrying cube2. A policy that
//! climbs the reward learns to hold cube1 just outside the threshold. `stage` pays its weight
//! once for each milestone reached, in order:
//!
//! 1. cube1 within the threshold of its goal;
//! 2. and not grasped (`cube1_grasped` false);
//! 3. and cube2 within the threshold of its goal;
//! 4. and neither cube touched by the robot (`cube_released`).
//!
//! With `task.stage_at_rest` a milestone comes between the last two: and both cubes at rest
//! (`cube_at_rest`, below the `thresholds.rest_*` speeds), so that cube2 held still on cube1
//! pays before it is let go (below). With `task.stage_let_go` one comes after that (or after
//! the third without rest): and neither cube grasped (`is_grasped` false), so that loosening
//! the grip on cube2 pays before the fingers are clear of it (below).
//!
//! With a weight above about 2 (with `lift` 1; the other terms at their defaults), each
//! milestone pays more than the step to it costs, so every step of the stack, letting go
//! included, raises the reward (with 3, the expert's is 4.8, 7.0, 13.7 and 15.8 at the four
//! milestones, from at most 3.7 before the first). Its inputs are `cube1_grasped`,
//! `cube_released` and the two distances, so `compute_reward` recomputes it for relabelled
//! goals.
//! PPO from scratch with it placed cube1 and let it go in 95-99 % of episodes within 2-4 M
//! steps, where without it cube1 reached its goal in at most 14 %; none of those runs stacked
//! cube2 (`docs/training.md`, 2026-12-01).
//!
//! ## The distance rate
//! `reach` and `carry` at the default rate (5 per metre) are nearly flat beyond 0.4 m: 0.013 at
//! 0.5 m, sloping 10 times less at 0.45 m than at 0.2 m. Pick-and-place's distances lie within
//! the steep part; Stack's second pick does not: once cube1 is placed the hand is 0.3-0.45 m
//! from cube2, and cube2 0.4-0.6 m from its goal. In the runs above the hand stayed by cube1 for
//! the rest of the episode. `task.reward_distance_rate` 2 pays 0.28 at 0.45 m and slopes
//! from there, at most 4 times less than at the goal, out to 0.6 m.
//!
//! ## The hover height
//! With the rate at 2, the hand let cube1 go and then pressed down on the platform beside it
//! for the rest of the episode: cube2 is on the floor, 0.1 m below the platform's top, so
//! `reach` pulls the hand down onto the platform, and pressed there it does not slide.
//! `task.reach_hover_height` `h` makes `reach` aim at the point `min(h, horizontal distance)`
//! above the handled cube's centre: from afar, `h` above it (for `h` 0.1, level with the
//! platform's top), and down onto it as the hand comes over it.
//!
//! With rate 2 and `h` 0.2 PPO from scratch stopped pressing on the platform within 4 M steps,
//! and by 19 M (75 minutes) came within 0.09-0.22 m of cube2 after letting cube1 go, without
//! grasping it yet. From where the policy stops, the scripted expert's way to cube2 raises this
//! reward at almost every step, by about 0.03 a step until the grasp, small beside the `stage`
//! weights (`docs/training.md`, 2026-12-01, the morning session).
//!
//! ## The rest milestone
//! PPO from scratch with the four milestones brought cube2 within 2 cm of its goal but never
//! let it go: its hand swung through the goal at 85-95 cm/s, and a release there left cube2 on
//! cube1 in only 21-24 % of episodes, against 62 % after the hand had been still for 5 steps
//! (`docs/training.md`, 2026-12-02). Nothing in the reward paid for holding still.
//! `task.stage_at_rest` (off by default) pays the weight once more for both cubes at rest
//! while cube2 is within the threshold, before the last milestone, which then also needs them
//! at rest. Its input is `cube_at_rest`, already a context key, so `compute_reward` recomputes
//! it; a training run can loosen the rest speed with `thresholds.rest_linear_speed`.
//!
//! ## The let-go milestone
//! With the rest milestone PPO from scratch held cube2 still on cube1 (1.5-2.6 cm/s at its
//! slowest) but never let it go, in 20 M steps (`docs/training.md`, 2026-12-02, the morning
//! session). cube1's release was learnt through its own "not grasped" milestone, which pays at
//! the first step the squeeze loosens; cube2's last milestone pays only once no robot link
//! touches either cube, several steps of opening later, with nothing paying on the way.
//! `task.stage_let_go` (off by default) pays the weight once more for neither cube grasped
//! (after the milestones before it), mirroring cube1's. Its input is `is_grasped`, an info
//! entry of every id, read back as a context key.
//!
//! ## The release term
//! With the let-go milestone PPO from scratch still never opened its hand on the stack, in
//! 32 M steps: cube2 loosened only by slipping, with the gripper commanded shut, and was
//! gripped again (`docs/training.md`, 2026-12-02). The gripper's drive saturates at its force
//! limit for any command below about -0.2, so the squeeze, and every term that reads it, is
//! the same from -1 to there: nothing rewards a command slightly less shut, and the fingers
//! let go only when it is well above 0 for two steps, several standard deviations from where
//! the policy's squeeze sits. `release`, pick-and-place's term (off by default), pays its
//! weight times the gripper opening the action commands (0 closed, 1 fully open) while cube2
//! is ready to be let go: within the threshold with cube1 placed and let go, and both cubes at
//! rest with `task.stage_at_rest` (the milestones before the let-go one), grasped or not. It
//! rewards every step of the command towards opening there. Its input is the info's
//! `gripper_opening`, read back as a context key. From the let-go run's 32 M-step policy,
//! 4 M steps with `release` 10 opened the hand fully wherever cube2 was ready, and every
//! success was then placed (validation 0.305 placed); with 3 the command rose only to -0.41,
//! still shut (`docs/training.md`, 2026-12-02, the afternoon session).

use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::config::{Range, Region};
use super::episode::{
    cube_orientation, CubeProperties, CUBE_REGION, CUBE_YAW_RANGE, PLATFORM_GOAL_REGION,
};
use super::registry::{TaskDescriptor, TaskSpec};
use super::{EpisodeStart, ResetOptions, SlotSpec, Task, Verdict, View};
use crate::config::invalid;
use crate::config::{CubeConfig, PlatformConfig};
use crate::error::Result;
use crate::physics::{BodyState, ObjectId, ObjectSpec, ObjectTouch, Scene, Simulation};
use crate::task::base::cube::{
    cube_task_info, lift_fraction, write_cube_slots, IS_GRASPED, IS_LIFTED,
};
use crate::task::base::{norm, term_field};
use crate::task::config::RewardType;
use crate::task::config::{validate_cube_start, validate_platform_regions};
use crate::task::context::TaskContext;
use crate::task::observation::{info_field, InfoField, InfoType};
use crate::task::reward::cube_terms::{self, CARRY, GRASP, PLACE, REACH};
use crate::task::reward::{
    closeness_at_rate, compute_batch_with, GoalVerdict, RewardContext, RewardFunction, RewardTerm,
    RewardTerms, CLOSENESS_RATE,
};

/// `cube1_grasped`: cube1's own grasp, an input of the `stage` term.
const CUBE1_GRASPED: InfoField = info_field(
    "cube1_grasped",
    InfoType::Bool,
    "both fingers squeeze cube1 with at least the grasp force",
);

/// The task's own info entries.
const INFO_FIELDS: [InfoField; 14] = [
    IS_GRASPED,
    IS_LIFTED,
    info_field(
        "is_placed",
        InfoType::Bool,
        "both cubes within the threshold, released, at rest and stacked on the platform",
    ),
    term_field(REACH),
    term_field(GRASP),
    term_field(LIFT),
    term_field(CARRY),
    term_field(PLACE),
    term_field(STAGE),
    term_field(RELEASE),
    CUBE1_GRASPED,
    info_field(
        "cube_released",
        InfoType::Bool,
        "no robot link touches either cube",
    ),
    info_field(
        "cube_at_rest",
        InfoType::Bool,
        "both cubes move slower than the rest thresholds",
    ),
    info_field(
        "cube_on_platform",
        InfoType::Bool,
        "cube1 touches the platform and cube2 touches cube1",
    ),
];

/// `lift`: pick-and-place's term for the cube being handled (the first not at its goal); off
/// by default, so the dense ids' default reward is the one their version was given with.
const LIFT: RewardTerm = RewardTerm {
    default_weight: 0.0,
    description: "height above its floor resting height of the first cube not at its goal, \
                  over the platform's height, clipped to [0, 1] (off by default)",
    ..cube_terms::LIFT
};

/// `stage`: the milestones of the stack reached, each paying the weight (off by default;
/// the module documentation).
const STAGE: RewardTerm = RewardTerm {
    name: "stage",
    info_key: "reward_stage",
    default_weight: 0.0,
    description: "the weight times the milestones reached, 0 to 4: cube1 within the threshold \
                  of its goal; and not grasped; and cube2 within the threshold of its goal; and \
                  neither cube touched by the robot (one more before the last with \
                  task.stage_at_rest, both cubes at rest, and with task.stage_let_go, neither \
                  cube grasped; off by default)",
};

/// `release`: pick-and-place's term for opening the hand, paid while cube2 is held on the stack
/// ready to be let go (off by default; the module documentation).
const RELEASE: RewardTerm = RewardTerm {
    description: "the gripper opening the action commands (0 closed, 1 fully open) while cube2 \
                  is within the threshold of its goal with cube1 placed and let go (and both \
                  cubes at rest with task.stage_at_rest; off by default)",
    ..cube_terms::RELEASE
};

/// The reward's inputs that `compute_reward` reads back.
const CONTEXT_KEYS: [&str; 9] = [
    "reward_reach",
    "reward_grasp",
    "reward_lift",
    "cube_released",
    "cube_at_rest",
    "cube_on_platform",
    "cube1_grasped",
    "is_grasped",
    "gripper_opening",
];
/// Where `cube1_grasped` is among [`CONTEXT_KEYS`].
const CUBE1_GRASPED_KEY: usize = 6;
/// Where `is_grasped` is among [`CONTEXT_KEYS`].
const IS_GRASPED_KEY: usize = 7;

/// The grasps the `stage` term reads.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Grasps {
    /// cube1 squeezed by both fingers (`cube1_grasped`).
    cube1: bool,
    /// Either cube squeezed by both fingers (`is_grasped`).
    either: bool,
}

impl Grasps {
    /// The grasps of a `compute_reward` context row (absent entries: not grasped).
    fn from_row(row: &[f32]) -> Self {
        let flag = |k: usize| row.get(k).is_some_and(|&v| v != 0.0);
        Self {
            cube1: flag(CUBE1_GRASPED_KEY),
            either: flag(IS_GRASPED_KEY),
        }
    }
}

/// The task's observation slots, after the robot's: five per cube.
const SLOTS: [SlotSpec; 10] = [
    cube_slot("cube1_position", 3, "cube1's centre"),
    cube_slot(
        "cube1_orientation",
        4,
        "unit quaternion x, y, z, w with w >= 0",
    ),
    cube_slot("cube1_linear_velocity", 3, "cube1's centre velocity"),
    cube_slot("cube1_angular_velocity", 3, "cube1's angular velocity"),
    cube_slot(
        "cube1_relative_position",
        3,
        "cube1's centre minus TCP position",
    ),
    cube_slot("cube2_position", 3, "cube2's centre"),
    cube_slot(
        "cube2_orientation",
        4,
        "unit quaternion x, y, z, w with w >= 0",
    ),
    cube_slot("cube2_linear_velocity", 3, "cube2's centre velocity"),
    cube_slot("cube2_angular_velocity", 3, "cube2's angular velocity"),
    cube_slot(
        "cube2_relative_position",
        3,
        "cube2's centre minus TCP position",
    ),
];
/// Slots per cube, and the offsets of the ones the task reads.
const PER_CUBE: usize = 5;
const LINEAR_VELOCITY: usize = 2;
const ANGULAR_VELOCITY: usize = 3;
const RELATIVE_POSITION: usize = 4;

const fn cube_slot(name: &'static str, size: usize, description: &'static str) -> SlotSpec {
    SlotSpec {
        name,
        size: Some(size),
        description,
    }
}

/// One position per cube.
const GOAL_DIM: usize = 6;
/// Gap (m) along y between the halves of `task.cube_region` the two cubes start in.
const START_GAP: f64 = 0.1;

/// The `stack` section of the configuration (`{"task": {"name": "stack", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StackConfig {
    /// The two cubes, alike (`sim.cube` before 0.2).
    pub cube: CubeConfig,
    /// The platform they are stacked on (`sim.platform` before 0.2).
    pub platform: PlatformConfig,
    /// Where the cubes' centres start, on the floor clear of the platform, one in each half
    /// along y (`pick_region` before 0.2).
    pub cube_region: Region,
    /// Range of the cubes' start yaws (rad).
    pub cube_yaw_range: Range,
    /// Where the bottom cube's goal is drawn, on the platform's top.
    pub goal_region: Region,
    /// Probability that an episode starts with cube1 resting on its goal (0: never, the ids'
    /// setting).
    pub cube1_on_goal_probability: f64,
    /// The rate `k` (per metre) of the dense `reach` and `carry` terms, `1 - tanh(k d)`: 5
    /// (panda-gym's, the ids' setting) by default. A smaller rate pays, and slopes, from
    /// farther away (the module documentation).
    pub reward_distance_rate: f64,
    /// How high (m) above the handled cube `reach` aims while the hand is away from it: the
    /// point `min(h, horizontal distance)` above the cube's centre (0, the cube's centre
    /// itself: the ids' setting; the module documentation).
    pub reach_hover_height: f64,
    /// Whether the `stage` term counts both cubes at rest as a milestone, between cube2 within
    /// the threshold and neither cube touched (false: the four milestones, the ids' setting;
    /// the module documentation).
    pub stage_at_rest: bool,
    /// Whether the `stage` term counts neither cube grasped as a milestone, just before
    /// neither cube touched (false: the ids' setting; the module documentation).
    pub stage_let_go: bool,
}

impl Default for StackConfig {
    fn default() -> Self {
        Self {
            cube: CubeConfig::default(),
            platform: PlatformConfig::default(),
            cube_region: CUBE_REGION,
            cube_yaw_range: CUBE_YAW_RANGE,
            goal_region: PLATFORM_GOAL_REGION,
            cube1_on_goal_probability: 0.0,
            reward_distance_rate: CLOSENESS_RATE,
            reach_hover_height: 0.0,
            stage_at_rest: false,
            stage_let_go: false,
        }
    }
}

impl TaskSpec for Stack {
    type Config = StackConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "stack",
        id_stem: "Stack",
        // Two pick-and-places: the expert's `joints` episodes take 101 to 108 steps on
        // average, 139 at most.
        episode_steps: 150,
        has_platform: true,
        summary: "stack two cubes on the goal on the platform",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH, GRASP, LIFT, CARRY, PLACE, STAGE, RELEASE],
        reward_context_keys: &CONTEXT_KEYS,
    };

    const LEGACY_KEYS: &'static [(&'static str, &'static str)] = &[
        ("pick_region", "cube_region"),
        ("cube_yaw_range", "cube_yaw_range"),
        ("goal_region", "goal_region"),
    ];

    // Stack's reward took no `lift` term before 0.2 (it is off by default now).
    const TERMS_ADDED_AFTER_0_2: &'static [&'static str] = &["lift"];

    fn validate(section: &StackConfig, context: &TaskContext) -> Result<()> {
        validate_cube_start(&section.cube_region, section.cube_yaw_range)?;
        section.goal_region.validate("task.goal_region")?;
        let p = section.cube1_on_goal_probability;
        if !(0.0..=1.0).contains(&p) {
            return Err(invalid(
                "task.cube1_on_goal_probability",
                format!("must be in [0, 1], got {p}"),
            ));
        }
        let rate = section.reward_distance_rate;
        if !(rate.is_finite() && rate > 0.0) {
            return Err(invalid(
                "task.reward_distance_rate",
                format!("must be a finite number above 0 (per metre), got {rate}"),
            ));
        }
        let hover = section.reach_hover_height;
        if !(hover.is_finite() && hover >= 0.0) {
            return Err(invalid(
                "task.reach_hover_height",
                format!("must be a finite number of metres, 0 or more, got {hover}"),
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

    fn cube(section: &StackConfig) -> Option<&CubeConfig> {
        Some(&section.cube)
    }

    fn platform(section: &StackConfig) -> Option<&PlatformConfig> {
        Some(&section.platform)
    }

    fn build(section: &StackConfig, context: &TaskContext) -> Self {
        Self {
            section: section.clone(),
            context: context.clone(),
            cubes: None,
        }
    }
}

/// Stack the two cubes on the platform (see the module documentation).
#[derive(Debug, Clone)]
pub struct Stack {
    section: StackConfig,
    context: TaskContext,
    cubes: Option<[ObjectId; 2]>,
}

impl Stack {
    fn cubes(&self) -> [ObjectId; 2] {
        // `bind` runs before any episode; unbound, the scene's objects are in order.
        self.cubes
            .unwrap_or_else(|| [ObjectId::first(), ObjectId::first()])
    }

    /// The optional milestones the section turns on.
    fn stages(&self) -> Stages {
        Stages {
            at_rest: self.section.stage_at_rest,
            let_go: self.section.stage_let_go,
        }
    }

    /// `reach` and `carry`'s `1 - tanh(k d)`, `k` the section's `reward_distance_rate`.
    fn closeness(&self, distance: f64) -> f32 {
        closeness_at_rate(distance, self.section.reward_distance_rate)
    }

    /// Distances of the two cubes to their goals, success and the reward for one transition
    /// (`grasps`: inputs of `stage`).
    fn judge(
        &self,
        achieved: &[f32],
        desired: &[f32],
        context: &RewardContext,
        grasps: Grasps,
    ) -> GoalVerdict {
        let d = [
            RewardFunction::distance(&achieved[..3], &desired[..3]),
            RewardFunction::distance(&achieved[3..], &desired[3..]),
        ];
        let threshold = self.context.success_threshold;
        let is_success = d[0] < threshold && d[1] < threshold;
        let is_placed =
            is_success && context.cube_released && context.cube_at_rest && context.cube_on_platform;
        let w = &self.context.reward_weights;
        let progress = progress(d, threshold, grasps, self.stages(), context);
        let (reward, terms) = match self.context.reward_type {
            RewardType::Sparse => (if is_success { 0.0 } else { -1.0 }, RewardTerms::default()),
            RewardType::Dense => {
                let terms = RewardTerms {
                    reach: context.reach,
                    grasp: context.grasp,
                    lift: context.lift,
                    carry: w.carry as f32 * (self.closeness(d[0]) + self.closeness(d[1])) / 2.0,
                    place: if is_placed { w.place as f32 } else { 0.0 },
                    release: if progress.ready {
                        context.release(w.release)
                    } else {
                        0.0
                    },
                    stage: w.stage as f32 * progress.reached,
                };
                (terms.total(), terms)
            }
        };
        GoalVerdict {
            distance: d[0].max(d[1]),
            is_success,
            is_placed,
            reward,
            terms,
        }
    }
}

/// The `stage` term's optional milestones (`task.stage_at_rest`, `task.stage_let_go`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Stages {
    /// Both cubes at rest, after cube2 within the threshold.
    at_rest: bool,
    /// Neither cube grasped, just before neither cube touched.
    let_go: bool,
}

/// How far along the `stage` term's chain of milestones (the module documentation) a state is.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Progress {
    /// How many milestones are reached.
    reached: f32,
    /// Whether cube2 is held on the stack ready to be let go: the milestones before the
    /// let-go one reached (cube2 within the threshold with cube1 placed and let go, and both
    /// cubes at rest with `task.stage_at_rest`), grasped or not. Where `release` pays.
    ready: bool,
}

/// The `stage` chain's [`Progress`], given the cubes' distances `d` to their goals and the
/// optional milestones `stages` counts.
fn progress(
    d: [f64; 2],
    threshold: f64,
    grasps: Grasps,
    stages: Stages,
    context: &RewardContext,
) -> Progress {
    let first = d[0] < threshold;
    let let_go = first && !grasps.cube1;
    let second = let_go && d[1] < threshold;
    // Each milestone counts only with the ones before it: `last` is the latest reached.
    let mut reached = [first, let_go, second]
        .into_iter()
        .map(f32::from)
        .sum::<f32>();
    let mut last = second;
    if stages.at_rest {
        last &= context.cube_at_rest;
        reached += f32::from(last);
    }
    let ready = last;
    if stages.let_go {
        last &= !grasps.either;
        reached += f32::from(last);
    }
    Progress {
        reached: reached + f32::from(last && context.cube_released),
        ready,
    }
}

/// The distance `reach` measures, given the handled cube's centre minus the TCP position: to
/// the centre, or with a hover height `h` above 0 to the point `min(h, horizontal distance)`
/// above it.
fn reach_distance(relative: &[f32], hover: f64) -> f64 {
    // The ids' own arithmetic at 0, so that their rewards stay bit for bit.
    if hover == 0.0 {
        return norm(relative);
    }
    let horizontal = norm(&relative[..2]);
    let up = relative[2] as f64 + hover.min(horizontal);
    horizontal.hypot(up)
}

impl Task for Stack {
    fn descriptor(&self) -> &'static TaskDescriptor {
        &Self::DESCRIPTOR
    }

    fn build_scene(&self) -> Scene {
        let cube = &self.section.cube;
        let [x, y, z] = Scene::TUTORIAL_CUBE_POSITION;
        Scene {
            platform: Some(self.section.platform.clone()),
            objects: vec![
                ObjectSpec::cube("cube1", cube, [x, y, z]),
                ObjectSpec::cube("cube2", cube, [x, y + 2.0 * cube.size, z]),
            ],
            ..Scene::default()
        }
    }

    fn bind(&mut self, sim: &Simulation) -> Result<()> {
        self.cubes = Some([sim.object("cube1")?, sim.object("cube2")?]);
        Ok(())
    }

    fn goal_dim(&self) -> usize {
        GOAL_DIM
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        [
            "centres of cube1 and cube2",
            "their goals: on the platform, and on top of that",
        ]
    }

    fn observation_slots(&self) -> &'static [SlotSpec] {
        &SLOTS
    }

    fn draw_episode(&self, rng: &mut ChaCha8Rng, options: &ResetOptions, start: &mut EpisodeStart) {
        let mut draw = || rng.random::<f64>();
        // Always the same draws in the same order, whatever the overrides.
        let swap_u = draw();
        let first_u = [draw(), draw()];
        let second_u = [draw(), draw()];
        let yaw_u = [draw(), draw()];
        let goal_xy = self.section.goal_region.lerp([draw(), draw()]);
        let size_u = draw();
        let mass_u = draw();
        let friction_u = draw();
        // Last, and only when it can come true: the ids' draws are the ones above.
        let p = self.section.cube1_on_goal_probability;
        let on_goal = p > 0.0 && draw() < p;
        let properties = CubeProperties::draw(
            &self.section.cube,
            &self.context.randomization,
            [size_u, mass_u, friction_u],
        );
        let size = properties.size;
        // The two halves of the pick region along y, a gap between them.
        let region = self.section.cube_region;
        let middle = (region.low[1] + region.high[1]) / 2.0;
        let half_gap = START_GAP.min(region.high[1] - region.low[1]) / 2.0;
        let low_half = |u: [f64; 2]| {
            [
                region.low[0] + (region.high[0] - region.low[0]) * u[0],
                region.low[1] + (middle - half_gap - region.low[1]) * u[1],
            ]
        };
        let high_half = |u: [f64; 2]| {
            [
                region.low[0] + (region.high[0] - region.low[0]) * u[0],
                middle + half_gap + (region.high[1] - middle - half_gap) * u[1],
            ]
        };
        let (first, second) = if swap_u < 0.5 {
            (low_half(first_u), high_half(second_u))
        } else {
            (high_half(first_u), low_half(second_u))
        };
        let yaw = |u: f64| cube_orientation(self.section.cube_yaw_range, u, options);
        let platform_top = self.section.platform.top_center[2];
        let bottom_goal = options.goal.map_or(
            Vector3::new(goal_xy[0], goal_xy[1], platform_top + size / 2.0),
            Vector3::from,
        );
        let top_goal = bottom_goal + Vector3::new(0.0, 0.0, size);
        let [c1, c2] = self.cubes();
        let cube1_at = options
            .cube_position
            .or_else(|| on_goal.then(|| bottom_goal.into()));
        start.set(
            [
                properties.resting(c1, first, cube1_at, yaw(yaw_u[0])),
                properties.resting(c2, second, None, yaw(yaw_u[1])),
            ],
            bottom_goal.iter().chain(top_goal.iter()).copied(),
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
        let per_cube = extras.len() / 2;
        for (k, cube) in self.cubes().into_iter().enumerate() {
            let state = sim.object_state(cube);
            achieved[3 * k..3 * k + 3].copy_from_slice(state.position.as_slice());
            write_cube_slots(&state, tcp, &mut extras[k * per_cube..(k + 1) * per_cube]);
        }
    }

    fn evaluate(&self, view: &View<'_>) -> Verdict {
        let t = &self.context.thresholds;
        let [c1, c2] = self.cubes();
        let touch = [view.sim.object_touch(c1), view.sim.object_touch(c2)];
        let l = view.layout;
        let obs = view.observation;
        let slot = |cube: usize, which: usize| &obs[l.task_slot(cube * PER_CUBE + which)];
        let grasped = |touch: &ObjectTouch| touch.finger_forces.iter().all(|&f| f >= t.grasp_force);
        let at_rest = |cube: usize| {
            norm(slot(cube, LINEAR_VELOCITY)) < t.rest_linear_speed
                && norm(slot(cube, ANGULAR_VELOCITY)) < t.rest_angular_speed
        };
        let is_grasped = grasped(&touch[0]) || grasped(&touch[1]);
        let is_lifted = (0..2).any(|k| {
            grasped(&touch[k]) && !touch[k].floor && !touch[k].platform && touch[k].objects == 0
        });
        // Reach for the first cube that is not at its goal yet.
        let achieved = &obs[l.achieved_goal()];
        let desired = &obs[l.desired_goal()];
        let first_done = RewardFunction::distance(&achieved[..3], &desired[..3])
            < self.context.success_threshold;
        let handled = usize::from(first_done);
        let reach_distance = reach_distance(
            slot(handled, RELATIVE_POSITION),
            self.section.reach_hover_height,
        );
        let (size, _, _) = view.sim.object_properties([c1, c2][handled]);
        let lift = lift_fraction(
            achieved[3 * handled + 2] as f64,
            size,
            self.section.platform.top_center[2],
        );
        let w = &self.context.reward_weights;
        let context = RewardContext {
            reach: w.reach as f32 * self.closeness(reach_distance),
            grasp: if is_grasped { w.grasp as f32 } else { 0.0 },
            lift: w.lift as f32 * lift as f32,
            cube_released: !touch[0].robot_touching() && !touch[1].robot_touching(),
            cube_at_rest: at_rest(0) && at_rest(1),
            cube_on_platform: touch[0].platform && touch[1].touches(c1),
            gripper_opening: view.gripper_opening as f32,
        };
        let grasps = Grasps {
            cube1: grasped(&touch[0]),
            either: is_grasped,
        };
        let judgement = self.judge(achieved, desired, &context, grasps);
        let mut info = cube_task_info(&INFO_FIELDS, is_grasped, is_lifted, &context, &judgement);
        info.set(CUBE1_GRASPED.key, grasps.cube1);
        Verdict {
            is_success: judgement.is_success,
            goal_distance: judgement.distance,
            reward: judgement.reward,
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
        let needs_context = self.context.reward_type == RewardType::Dense;
        compute_batch_with(
            achieved,
            desired,
            GOAL_DIM,
            contexts,
            CONTEXT_KEYS.len(),
            needs_context,
            out,
            |a, d, row| {
                let context = RewardContext::from_row(&CONTEXT_KEYS, row);
                self.judge(a, d, &context, Grasps::from_row(row)).reward
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// How many of the `stage` term's milestones are reached ([`progress`]).
    fn milestones(
        d: [f64; 2],
        threshold: f64,
        grasps: Grasps,
        stages: Stages,
        context: &RewardContext,
    ) -> f32 {
        progress(d, threshold, grasps, stages, context).reached
    }

    #[test]
    fn panda_layout_matches_the_documented_table() {
        let task = Stack::build(
            &Default::default(),
            &TaskContext::defaults(Stack::DESCRIPTOR.reward_terms),
        );
        crate::task::observation::assert_documented_layout(&task, include_str!("stack.rs"), 69);
    }

    #[test]
    fn the_grasp_inputs_are_read_back_from_their_context_keys() {
        assert_eq!(CONTEXT_KEYS[CUBE1_GRASPED_KEY], CUBE1_GRASPED.key);
        assert_eq!(CONTEXT_KEYS[IS_GRASPED_KEY], IS_GRASPED.key);
        let mut row = [0.0; CONTEXT_KEYS.len()];
        assert_eq!(Grasps::from_row(&row), Grasps::default());
        row[IS_GRASPED_KEY] = 1.0;
        let either = Grasps {
            cube1: false,
            either: true,
        };
        assert_eq!(Grasps::from_row(&row), either);
        row[CUBE1_GRASPED_KEY] = 1.0;
        assert_eq!(
            Grasps::from_row(&row),
            Grasps {
                cube1: true,
                ..either
            }
        );
        // A shorter row (an older context layout) reads as not grasped.
        assert_eq!(
            Grasps::from_row(&row[..7]),
            Grasps {
                cube1: true,
                either: false
            }
        );
    }

    /// Grasps with cube1 held (`cube1`) or not, and cube2 held when cube1 is not (`cube2`).
    fn grasps(cube1: bool, cube2: bool) -> Grasps {
        Grasps {
            cube1,
            either: cube1 || cube2,
        }
    }

    #[test]
    fn the_stage_milestones_count_in_order() {
        let released = RewardContext {
            cube_released: true,
            ..RewardContext::default()
        };
        let held = RewardContext::default();
        let (near, far) = (0.01, 0.2);
        let none = Stages::default();
        let (free, cube1, cube2) = (
            grasps(false, false),
            grasps(true, false),
            grasps(false, true),
        );
        // Each milestone counts only with the ones before it.
        assert_eq!(milestones([far, near], 0.05, free, none, &released), 0.0);
        assert_eq!(milestones([near, far], 0.05, cube1, none, &held), 1.0);
        assert_eq!(milestones([near, near], 0.05, cube1, none, &released), 1.0);
        assert_eq!(milestones([near, far], 0.05, free, none, &released), 2.0);
        assert_eq!(milestones([near, near], 0.05, cube2, none, &held), 3.0);
        assert_eq!(milestones([near, near], 0.05, free, none, &held), 3.0);
        assert_eq!(milestones([near, near], 0.05, free, none, &released), 4.0);
        // Rest does not count without the option.
        let at_rest = |cube_released| RewardContext {
            cube_released,
            cube_at_rest: true,
            ..RewardContext::default()
        };
        assert_eq!(
            milestones([near, near], 0.05, cube2, none, &at_rest(false)),
            3.0
        );
        assert_eq!(
            milestones([near, near], 0.05, free, none, &at_rest(true)),
            4.0
        );
    }

    #[test]
    fn the_rest_milestone_comes_before_the_release() {
        let context = |cube_released, cube_at_rest| RewardContext {
            cube_released,
            cube_at_rest,
            ..RewardContext::default()
        };
        let (near, far) = (0.01, 0.2);
        let stages = Stages {
            at_rest: true,
            let_go: false,
        };
        let count = |d, g, c: &RewardContext| milestones(d, 0.05, g, stages, c);
        let (free, cube1, cube2) = (
            grasps(false, false),
            grasps(true, false),
            grasps(false, true),
        );
        // Rest counts only once cube2 is within the threshold, cube1 placed and let go.
        assert_eq!(count([near, far], free, &context(false, true)), 2.0);
        assert_eq!(count([near, near], cube1, &context(false, true)), 1.0);
        assert_eq!(count([near, near], cube2, &context(false, false)), 3.0);
        assert_eq!(count([near, near], cube2, &context(false, true)), 4.0);
        // Let go while still moving: the release does not count without rest.
        assert_eq!(count([near, near], free, &context(true, false)), 3.0);
        assert_eq!(count([near, near], free, &context(true, true)), 5.0);
    }

    #[test]
    fn the_let_go_milestone_comes_just_before_the_release() {
        let (near, far) = (0.01, 0.2);
        let (free, cube1, cube2) = (
            grasps(false, false),
            grasps(true, false),
            grasps(false, true),
        );
        let let_go = Stages {
            at_rest: false,
            let_go: true,
        };
        let both = Stages {
            at_rest: true,
            let_go: true,
        };
        // (stages, distances, grasps, released, at rest): milestones.
        let cases = [
            // Without rest: after cube2 within the threshold.
            (let_go, [near, far], free, true, true, 2.0),
            (let_go, [near, near], cube1, false, false, 1.0),
            (let_go, [near, near], cube2, false, false, 3.0),
            // Loosened, the fingers still touching: pays before the release.
            (let_go, [near, near], free, false, false, 4.0),
            (let_go, [near, near], free, true, false, 5.0),
            // With rest: after it, so that a cube let go while moving pays neither.
            (both, [near, near], cube2, false, true, 4.0),
            (both, [near, near], free, false, false, 3.0),
            (both, [near, near], free, true, false, 3.0),
            (both, [near, near], free, false, true, 5.0),
            (both, [near, near], free, true, true, 6.0),
        ];
        for (stages, d, g, cube_released, cube_at_rest, expected) in cases {
            let context = RewardContext {
                cube_released,
                cube_at_rest,
                ..RewardContext::default()
            };
            assert_eq!(
                milestones(d, 0.05, g, stages, &context),
                expected,
                "{stages:?} {d:?} {g:?} released {cube_released} at rest {cube_at_rest}"
            );
        }
    }

    #[test]
    fn the_release_term_pays_the_commanded_opening_once_cube2_is_ready() {
        let mut context = TaskContext {
            reward_type: RewardType::Dense,
            ..TaskContext::defaults(Stack::DESCRIPTOR.reward_terms)
        };
        context.reward_weights.release = 2.0;
        let section = StackConfig {
            stage_at_rest: true,
            ..StackConfig::default()
        };
        let task = Stack::build(&section, &context);
        let goals = [0.0f32, 0.0, 0.0, 0.0, 0.0, 0.05];
        let cube2_off = [0.0f32, 0.0, 0.0, 0.0, 0.0, 0.2];
        let reward = |achieved: &[f32], grasps, cube_at_rest| {
            let inputs = RewardContext {
                cube_at_rest,
                gripper_opening: 0.75,
                ..RewardContext::default()
            };
            task.judge(achieved, &goals, &inputs, grasps).terms.release
        };
        let (free, cube1, cube2) = (
            grasps(false, false),
            grasps(true, false),
            grasps(false, true),
        );
        // Held on the stack, still: the opening pays, grasped or not.
        assert_eq!(reward(&goals, cube2, true), 1.5);
        assert_eq!(reward(&goals, free, true), 1.5);
        // Not while moving (with the rest milestone), cube1 held or cube2 off its goal.
        assert_eq!(reward(&goals, cube2, false), 0.0);
        assert_eq!(reward(&goals, cube1, true), 0.0);
        assert_eq!(reward(&cube2_off, cube2, true), 0.0);
        // Without the rest milestone, moving does not matter; off unless weighted.
        let task = Stack::build(&StackConfig::default(), &context);
        let inputs = RewardContext {
            gripper_opening: 0.75,
            ..RewardContext::default()
        };
        assert_eq!(
            task.judge(&goals, &goals, &inputs, cube2).terms.release,
            1.5
        );
        context.reward_weights.release = 0.0;
        let task = Stack::build(&section, &context);
        assert_eq!(task.judge(&goals, &goals, &inputs, free).terms.release, 0.0);
    }

    #[test]
    fn the_stage_term_is_off_unless_weighted() {
        let context = TaskContext {
            reward_type: RewardType::Dense,
            ..TaskContext::defaults(Stack::DESCRIPTOR.reward_terms)
        };
        let free = Grasps::default();
        let task = Stack::build(&Default::default(), &context);
        let goals = [0.0f32, 0.0, 0.0, 0.0, 0.0, 0.05];
        let verdict = task.judge(&goals, &goals, &RewardContext::default(), free);
        assert_eq!(verdict.terms.stage, 0.0);
        let mut weighted = context.clone();
        weighted.reward_weights.stage = 3.0;
        let task = Stack::build(&Default::default(), &weighted);
        let verdict = task.judge(&goals, &goals, &RewardContext::default(), free);
        assert_eq!(verdict.terms.stage, 9.0);
        // With the rest milestone: cube2 held still at its goal pays once more.
        let still = RewardContext {
            cube_at_rest: true,
            ..RewardContext::default()
        };
        let section = StackConfig {
            stage_at_rest: true,
            ..StackConfig::default()
        };
        let task = Stack::build(&section, &weighted);
        assert_eq!(task.judge(&goals, &goals, &still, free).terms.stage, 12.0);
        let released = RewardContext {
            cube_released: true,
            ..still
        };
        assert_eq!(
            task.judge(&goals, &goals, &released, free).terms.stage,
            15.0
        );
        // With the let-go milestone too: cube2 let go, still, once more again.
        let section = StackConfig {
            stage_let_go: true,
            ..section
        };
        let task = Stack::build(&section, &weighted);
        let held = grasps(false, true);
        assert_eq!(task.judge(&goals, &goals, &still, held).terms.stage, 12.0);
        assert_eq!(task.judge(&goals, &goals, &still, free).terms.stage, 15.0);
        assert_eq!(
            task.judge(&goals, &goals, &released, free).terms.stage,
            18.0
        );
    }
}
