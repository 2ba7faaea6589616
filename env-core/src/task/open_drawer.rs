//! [`OpenDrawer`]: pull a cabinet's drawer open by its knob to a goal opening (ManiSkill's
//! OpenCabinetDrawer, MuJoCo Playground's PandaOpenCabinet), with a goal dict: the achieved goal
//! is the drawer's opening, the desired one the opening to reach.
//!
//! # Observation
//!
//! For the Panda `observation` has 40 entries and the flat vector 42:
//!
//! | flat index | dict key / `observation` index | slot | size | meaning |
//! |---|---|---|---|---|
//! | 0 | `achieved_goal` | `achieved_goal` | 1 | the drawer's opening (m) |
//! | 1 | `desired_goal` | `desired_goal` | 1 | the opening to reach (m) |
//! | 2..11 | `observation` 0..9 | `joint_positions` | 9 | arm joints 1-7 (rad), finger joints 1-2 (m) |
//! | 11..20 | `observation` 9..18 | `joint_velocities` | 9 | their velocities |
//! | 20..23 | `observation` 18..21 | `tcp_position` | 3 | tool centre point (between the fingertips) |
//! | 23..26 | `observation` 21..24 | `tcp_velocity` | 3 | its linear velocity |
//! | 26 | `observation` 24 | `gripper_width` | 1 | opening between the finger pads (m) |
//! | 27 | `observation` 25 | `drawer_opening` | 1 | the drawer's opening (m; same as `achieved_goal`) |
//! | 28 | `observation` 26 | `drawer_velocity` | 1 | how fast it opens (m/s; negative closing) |
//! | 29..32 | `observation` 27..30 | `handle_position` | 3 | the grasp point on the knob's stem (world frame) |
//! | 32..35 | `observation` 30..33 | `handle_relative_position` | 3 | the grasp point minus the TCP position |
//! | 35..38 | `observation` 33..36 | `opening_direction` | 3 | unit vector the drawer slides out along (world frame) |
//! | 38..42 | `observation` 36..40 | `tcp_orientation` | 4 | the hand's orientation, x, y, z, w with w >= 0 |
//!
//! # Scene and starting state
//! The cabinet is the shipped `assets/cabinet/cabinet.urdf` (30 x 40 x 30 cm, one drawer on a
//! prismatic joint of 25 cm travel with 5 N s/m damping and 2 N friction, a knob on its front;
//! made by `scripts/make_cabinet.py`), standing on the floor, its root fixed. Each episode its
//! origin (the middle of its footprint) is uniform in `task.cabinet_region`, its front facing
//! the robot (yaw pi) turned by a uniform angle in `task.cabinet_yaw_range`; the drawer starts
//! open by a uniform amount in `task.drawer_start` and the goal opening is uniform in
//! `task.goal_opening`. `task.joints` chooses how the drawer's joint is simulated (a multibody
//! by default, or impulse joints). No platform, no movable object. Of the reset options only
//! `joint_positions` applies.
//!
//! # Success
//! The drawer open at least the goal opening (`achieved_goal >= desired_goal`);
//! `goal_distance` is how far short of it it is (0 once reached).
//!
//! # Rewards
//! `sparse`: -1 until success, then 0. `dense`: `reach` (the TCP near the knob's grasp point),
//! `grasp` (the fingers closed on the stem: `is_grasped`) and `open` (the opening as a fraction
//! of the goal's), each in `[0, weight]`. `open` is recomputed from the goals; `reach` and
//! `grasp` are read back from the step's info (`reward_reach`, `reward_grasp`), so relabelled
//! goals get exactly the reward the environment would have given.

use std::sync::{Arc, OnceLock};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::config::{validate_range, Range, Region};
use super::context::TaskContext;
use super::episode::TaskInfo;
use super::observation::{info_field, InfoField, InfoType};
use super::registry::{TaskDescriptor, TaskSpec};
use super::{EpisodeStart, GoalMarker, ResetOptions, SlotSpec, Task, Verdict, View};
use crate::config::invalid;
use crate::error::{Error, Result};
use crate::model::RobotModel;
use crate::physics::{
    ArticulationId, ArticulationJoints, ArticulationSpec, BodyState, Scene, Simulation,
};
use crate::task::base::{
    canonical, compute_reach_grasp_rewards, norm, term_field, REACH_GRASP_CONTEXT,
};
use crate::task::config::RewardType;
use crate::task::reward::{closeness, RewardTerm};

/// Size of each goal: the drawer's opening.
const GOAL_DIM: usize = 1;

/// The cabinet's drawer joint and the frame-only link on the knob's stem where a gripper
/// closes (names in `assets/cabinet/cabinet.urdf`).
pub const DRAWER_JOINT: &str = "drawer_joint";
/// See [`DRAWER_JOINT`].
pub const HANDLE_LINK: &str = "handle";

/// `is_grasped`: the TCP at most this far (m) from the knob's grasp point...
pub const GRASP_REACH: f64 = 0.02;
/// ...with the pads at most this far apart (m): closed on the 2 cm stem.
pub const GRASP_WIDTH: f64 = 0.03;

/// `reach`: the TCP near the knob.
pub const REACH: RewardTerm = RewardTerm {
    name: "reach",
    info_key: "reward_reach",
    default_weight: 1.0,
    description: "`1 - tanh(5 d)`, `d` = distance from the TCP to the knob's grasp point",
};
/// `grasp`: the fingers closed on the knob.
pub const GRASP: RewardTerm = RewardTerm {
    name: "grasp",
    info_key: "reward_grasp",
    default_weight: 1.0,
    description: "1 while the fingers are closed on the knob's stem (`is_grasped`)",
};
/// `open`: the drawer's opening towards the goal's.
pub const OPEN: RewardTerm = RewardTerm {
    name: "open",
    info_key: "reward_open",
    default_weight: 5.0,
    description: "the opening as a fraction of the goal opening, clipped to [0, 1]",
};

const IS_GRASPED: InfoField = info_field(
    "is_grasped",
    InfoType::Bool,
    "the TCP within 2 cm of the knob's grasp point with the pads closed to at most 3 cm",
);

/// The task's own info entries.
const INFO_FIELDS: [InfoField; 4] = [
    IS_GRASPED,
    term_field(REACH),
    term_field(GRASP),
    term_field(OPEN),
];

/// Where `handle_relative_position` is among the task's slots.
const HANDLE_RELATIVE_POSITION: usize = 3;

/// The task's slots, after the robot's.
const SLOTS: [SlotSpec; 6] = [
    SlotSpec {
        name: "drawer_opening",
        size: Some(1),
        description: "the drawer's opening (m; same as `achieved_goal`)",
    },
    SlotSpec {
        name: "drawer_velocity",
        size: Some(1),
        description: "how fast it opens (m/s; negative closing)",
    },
    SlotSpec {
        name: "handle_position",
        size: Some(3),
        description: "the grasp point on the knob's stem (world frame)",
    },
    SlotSpec {
        name: "handle_relative_position",
        size: Some(3),
        description: "the grasp point minus the TCP position",
    },
    SlotSpec {
        name: "opening_direction",
        size: Some(3),
        description: "unit vector the drawer slides out along (world frame)",
    },
    SlotSpec {
        name: "tcp_orientation",
        size: Some(4),
        description: "the hand's orientation, x, y, z, w with w >= 0",
    },
];

/// `task.joints` read by hand, so that a wrong value's message names the option (serde's
/// "unknown variant" names none).
fn deserialize_joints<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> std::result::Result<ArticulationJoints, D::Error> {
    let value = String::deserialize(deserializer)?;
    match value.as_str() {
        "multibody" => Ok(ArticulationJoints::Multibody),
        "impulse" => Ok(ArticulationJoints::Impulse),
        other => Err(serde::de::Error::custom(format!(
            "task.joints must be \"multibody\" or \"impulse\", got {other:?}"
        ))),
    }
}

/// The `open_drawer` section of the configuration (`{"task": {"name": "open_drawer", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OpenDrawerConfig {
    /// Where the cabinet's origin (the middle of its footprint) is drawn (m, world frame).
    pub cabinet_region: Region,
    /// Range (rad) of the cabinet's turn from facing the robot (yaw pi).
    pub cabinet_yaw_range: Range,
    /// Range (m) of the drawer's opening at the start.
    pub drawer_start: Range,
    /// Range (m) the goal opening is drawn from.
    pub goal_opening: Range,
    /// How the drawer's joint is simulated: `"multibody"` (default) or `"impulse"`.
    #[serde(deserialize_with = "deserialize_joints")]
    pub joints: ArticulationJoints,
}

impl Default for OpenDrawerConfig {
    fn default() -> Self {
        Self {
            cabinet_region: Region {
                low: [0.72, -0.12],
                high: [0.80, 0.12],
            },
            cabinet_yaw_range: [-0.3, 0.3],
            drawer_start: [0.0, 0.05],
            goal_opening: [0.15, 0.2],
            joints: ArticulationJoints::Multibody,
        }
    }
}

/// The shipped cabinet, read once per process.
fn cabinet() -> Result<Arc<RobotModel>> {
    static CABINET: OnceLock<std::result::Result<Arc<RobotModel>, String>> = OnceLock::new();
    CABINET
        .get_or_init(|| {
            RobotModel::cabinet()
                .map(Arc::new)
                .map_err(|e| e.to_string())
        })
        .clone()
        .map_err(|reason| Error::InvalidConfig {
            field: "task".into(),
            reason,
        })
}

/// The cabinet's facts the task needs: its model, the drawer's joint and its travel, the
/// knob's link, the root link and the drawer's way out in the root's frame.
#[derive(Debug, Clone)]
struct Cabinet {
    model: Arc<RobotModel>,
    joint: usize,
    handle: usize,
    root: usize,
    out: Vector3<f64>,
    travel: f64,
}

impl Cabinet {
    fn load() -> Result<Self> {
        let model = cabinet()?;
        let joint = model.joint_index(DRAWER_JOINT)?;
        let handle = model.link_index(HANDLE_LINK)?;
        let info = &model.joints()[joint];
        let travel = info.upper;
        // The drawer's joint hangs off the root link.
        let out = info.origin.rotation * info.axis;
        let root = model.root_link();
        Ok(Self {
            model,
            joint,
            handle,
            root,
            out,
            travel,
        })
    }
}

impl TaskSpec for OpenDrawer {
    type Config = OpenDrawerConfig;

    const DESCRIPTOR: TaskDescriptor = TaskDescriptor {
        name: "open_drawer",
        id_stem: "OpenDrawer",
        // 4 s at 25 Hz.
        episode_steps: 100,
        has_platform: false,
        summary: "pull a cabinet's drawer open by its knob to a goal opening",
        info_fields: &INFO_FIELDS,
        reward_terms: &[REACH, GRASP, OPEN],
        reward_context_keys: &REACH_GRASP_CONTEXT,
    };

    // The cabinet is turned: the end-effector ids turn the hand to its knob.
    const ID_POSE_ACTIONS: bool = true;
    const ID_JOINT_STEP: Option<f64> = Some(0.1);

    fn validate(section: &OpenDrawerConfig, _context: &TaskContext) -> Result<()> {
        section.cabinet_region.validate("task.cabinet_region")?;
        validate_range(
            "task.cabinet_yaw_range",
            section.cabinet_yaw_range,
            f64::NEG_INFINITY,
        )?;
        let cabinet = Cabinet::load()?;
        validate_range("task.drawer_start", section.drawer_start, 0.0)?;
        validate_range("task.goal_opening", section.goal_opening, 1e-3)?;
        for (field, range) in [
            ("task.drawer_start", section.drawer_start),
            ("task.goal_opening", section.goal_opening),
        ] {
            if range[1] > cabinet.travel {
                return Err(invalid(
                    field,
                    format!(
                        "must lie within the drawer's travel, [0, {}] m, got [{}, {}]",
                        cabinet.travel, range[0], range[1]
                    ),
                ));
            }
        }
        if section.drawer_start[1] >= section.goal_opening[0] {
            return Err(invalid(
                "task.drawer_start",
                format!(
                    "must end below the smallest goal opening ({} m): an episode would start \
                     solved",
                    section.goal_opening[0]
                ),
            ));
        }
        Ok(())
    }

    fn build(section: &OpenDrawerConfig, context: &TaskContext) -> Self {
        let (cabinet, error) = match Cabinet::load() {
            Ok(c) => (Some(c), None),
            Err(e) => (None, Some(e.to_string())),
        };
        Self {
            section: section.clone(),
            context: context.clone(),
            cabinet,
            error,
            id: None,
        }
    }
}

/// Pull a drawer open (see the module documentation).
#[derive(Debug, Clone)]
pub struct OpenDrawer {
    section: OpenDrawerConfig,
    context: TaskContext,
    cabinet: Option<Cabinet>,
    /// Why the cabinet could not be read.
    error: Option<String>,
    id: Option<ArticulationId>,
}

/// What the reward of one transition is made of.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Judgement {
    is_success: bool,
    distance: f64,
    open: f32,
    reward: f32,
}

impl OpenDrawer {
    fn id(&self) -> ArticulationId {
        self.id.unwrap_or_else(ArticulationId::first)
    }

    /// The reward from the goals and the weighted `reach` and `grasp` terms.
    fn judge(&self, achieved: &[f32], desired: &[f32], reach: f32, grasp: f32) -> Judgement {
        let (opening, goal) = (achieved[0] as f64, desired[0] as f64);
        let is_success = opening >= goal;
        let open = self.context.reward_weights.open as f32
            * (opening / goal.max(1e-6)).clamp(0.0, 1.0) as f32;
        let reward = match self.context.reward_type {
            RewardType::Sparse => {
                if is_success {
                    0.0
                } else {
                    -1.0
                }
            }
            RewardType::Dense => reach + grasp + open,
        };
        Judgement {
            is_success,
            distance: (goal - opening).max(0.0),
            open,
            reward,
        }
    }
}

impl Task for OpenDrawer {
    fn descriptor(&self) -> &'static TaskDescriptor {
        &Self::DESCRIPTOR
    }

    fn build_scene(&self) -> Scene {
        let Some(cabinet) = &self.cabinet else {
            return Scene::default();
        };
        let r = &self.section.cabinet_region;
        Scene {
            articulations: vec![ArticulationSpec {
                name: "cabinet".into(),
                model: Arc::clone(&cabinet.model),
                pose: Isometry3::from_parts(
                    Translation3::new(
                        0.5 * (r.low[0] + r.high[0]),
                        0.5 * (r.low[1] + r.high[1]),
                        0.0,
                    ),
                    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI),
                ),
                friction: 1.0,
                joints: self.section.joints,
            }],
            ..Scene::default()
        }
    }

    fn bind(&mut self, sim: &Simulation) -> Result<()> {
        if let Some(reason) = &self.error {
            return Err(Error::InvalidConfig {
                field: "task".into(),
                reason: reason.clone(),
            });
        }
        self.id = Some(sim.articulation("cabinet")?);
        Ok(())
    }

    fn goal_dim(&self) -> usize {
        GOAL_DIM
    }

    fn goal_descriptions(&self) -> [&'static str; 2] {
        ["the drawer's opening (m)", "the opening to reach (m)"]
    }

    fn observation_slots(&self) -> &'static [SlotSpec] {
        &SLOTS
    }

    fn draw_episode(
        &self,
        rng: &mut ChaCha8Rng,
        _options: &ResetOptions,
        start: &mut EpisodeStart,
    ) {
        let s = &self.section;
        let mut draw = || rng.random::<f64>();
        let xy = s.cabinet_region.lerp([draw(), draw()]);
        let yaw_u = draw();
        let start_u = draw();
        let goal_u = draw();
        let lerp = |r: Range, u: f64| r[0] + (r[1] - r[0]) * u;
        let yaw = std::f64::consts::PI + lerp(s.cabinet_yaw_range, yaw_u);
        let pose = Isometry3::from_parts(
            Translation3::new(xy[0], xy[1], 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
        );
        start.set([], [lerp(s.goal_opening, goal_u)]);
        start.set_articulations([(self.id(), pose, &[lerp(s.drawer_start, start_u)][..])]);
    }

    fn observe(
        &self,
        sim: &Simulation,
        tcp: &BodyState,
        _goal: &[f64],
        achieved: &mut [f64],
        extras: &mut [f64],
    ) {
        let Some(cabinet) = &self.cabinet else {
            return;
        };
        let id = self.id();
        let nan = f64::NAN;
        let drawer = sim
            .articulation_joint_state(id, cabinet.joint)
            .map_or((nan, nan), |s| (s.position, s.velocity));
        let knob = sim
            .articulation_link_state(id, cabinet.handle)
            .unwrap_or_else(|_| BodyState::nan());
        let root = sim
            .articulation_link_state(id, cabinet.root)
            .unwrap_or_else(|_| BodyState::nan());
        achieved[0] = drawer.0;
        let direction = root.orientation * cabinet.out;
        let relative = knob.position - tcp.position;
        let values: [&[f64]; 6] = [
            &[drawer.0],
            &[drawer.1],
            knob.position.as_slice(),
            relative.as_slice(),
            direction.as_slice(),
            &canonical(&tcp.orientation),
        ];
        for (o, v) in extras.iter_mut().zip(values.iter().flat_map(|s| s.iter())) {
            *o = *v;
        }
    }

    fn goal_markers(&self, _goal: &[f64], _out: &mut Vec<GoalMarker>) {
        // The goal is an opening, not a place: nothing to mark.
    }

    fn evaluate(&self, view: &View<'_>) -> Verdict {
        let obs = view.observation;
        let l = view.layout;
        let w = &self.context.reward_weights;
        let distance = norm(&obs[l.task_slot(HANDLE_RELATIVE_POSITION)]);
        let width = obs[l.robot_slot(crate::task::observation::GRIPPER_WIDTH).start] as f64;
        let is_grasped = distance <= GRASP_REACH && width <= GRASP_WIDTH;
        let reach = w.reach as f32 * closeness(distance);
        let grasp = if is_grasped { w.grasp as f32 } else { 0.0 };
        let j = self.judge(
            &obs[l.achieved_goal()],
            &obs[l.desired_goal()],
            reach,
            grasp,
        );
        let mut info = TaskInfo::new(&INFO_FIELDS);
        info.set(IS_GRASPED.key, is_grasped);
        info.set(REACH.info_key, reach);
        info.set(GRASP.info_key, grasp);
        if self.context.reward_type == RewardType::Dense {
            info.set(OPEN.info_key, j.open);
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

    fn task() -> OpenDrawer {
        OpenDrawer::build(
            &Default::default(),
            &TaskContext::defaults(OpenDrawer::DESCRIPTOR.reward_terms),
        )
    }

    #[test]
    fn panda_layout_matches_the_documented_table() {
        crate::task::observation::assert_documented_layout(
            &task(),
            include_str!("open_drawer.rs"),
            42,
        );
    }

    #[test]
    fn the_relative_position_index_names_its_slot() {
        assert_eq!(
            SLOTS[HANDLE_RELATIVE_POSITION].name,
            "handle_relative_position"
        );
    }

    #[test]
    fn the_shipped_cabinet_has_its_drawer_and_knob() {
        let task = task();
        assert!(task.error.is_none(), "{:?}", task.error);
        let cabinet = task.cabinet.unwrap();
        assert_eq!(cabinet.travel, 0.25);
        assert_eq!(cabinet.model.num_dofs(), 1);
    }

    #[test]
    fn a_drawer_start_that_would_be_solved_is_refused() {
        let section = OpenDrawerConfig {
            drawer_start: [0.0, 0.2],
            ..Default::default()
        };
        let context = TaskContext::defaults(OpenDrawer::DESCRIPTOR.reward_terms);
        let err = OpenDrawer::validate(&section, &context).unwrap_err();
        assert!(err.to_string().contains("task.drawer_start"), "{err}");
        let past = OpenDrawerConfig {
            goal_opening: [0.2, 0.3],
            ..Default::default()
        };
        let err = OpenDrawer::validate(&past, &context).unwrap_err();
        assert!(err.to_string().contains("travel"), "{err}");
    }
}
