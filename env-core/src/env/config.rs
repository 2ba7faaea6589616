//! Validated configuration of an environment ([`EnvConfig`]): the task's section, the robot,
//! the physics and the episode's options, and how actions drive the robot ([`ControlMode`]).
//! A task reads its own section and a [`TaskContext`] made from the rest
//! ([`EnvConfig::task_context`]).
//!
//! Over 600 lines because [`EnvConfig`]'s doc test spells out every default value (about 110
//! lines), which keeps the documented defaults true, the validation's tests name every field
//! they refuse, and the options' named values ([`ControlMode`], [`EeFrame`], [`EeController`])
//! sit beside the fields they type.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::config::{
    invalid, non_negative, positive, ArmFidelity, CubeConfig, PhysicsConfig, PlatformConfig,
    RobotConfig, SimConfig,
};
use crate::env::migrate::{migrate, Deprecation};
use crate::env::osc::OscConfig;
use crate::error::Result;
use crate::task::config::{
    validate_range, Randomization, Range, Region, RewardType, TaskThresholds,
    DEFAULT_SUCCESS_THRESHOLD,
};
use crate::task::context::TaskContext;
#[cfg(doc)]
use crate::task::registry::TaskSpec;
use crate::task::registry::{TaskConfig, TaskDescriptor, TaskKind};
use crate::task::reward::RewardWeights;
use crate::task::{ObservationLayout, Task};

/// How actions drive the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControlMode {
    /// 4-D: TCP displacement (x, y, z) through inverse kinematics with the hand pointing down,
    /// plus the gripper command.
    #[default]
    Ee,
    /// 8-D: joint target displacements of the seven arm joints, plus the gripper command.
    Joints,
    /// 7-D: TCP displacement (x, y, z) and rotation (a rotation vector), in the frame
    /// `ee_frame` names, plus the gripper command: the hand turns as well as moves.
    EePose,
}

impl ControlMode {
    /// The name used in configs and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            ControlMode::Ee => "ee",
            ControlMode::Joints => "joints",
            ControlMode::EePose => "ee_pose",
        }
    }

    /// Every mode, in the order they were added.
    pub const ALL: [ControlMode; 3] = [ControlMode::Ee, ControlMode::Joints, ControlMode::EePose];
}

/// The frame `ee_pose` actions are expressed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EeFrame {
    /// The robot base's axes (the world's: the base is only translated), about the TCP.
    #[default]
    Base,
    /// The hand's own axes (the TCP frame as it is at the start of the step): x forward
    /// between the fingers' opening, z along the fingers.
    Hand,
}

/// What turns `ee` and `ee_pose` actions into joint commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EeController {
    /// Inverse kinematics to joint targets, tracked by the joints' PD motors (the default).
    #[default]
    Ik,
    /// The operational-space controller: joint torques from the TCP's pose error through the
    /// arm's dynamics, recomputed every physics step ([`OscConfig`]; the dynamic arm only).
    Osc,
}

impl EeController {
    /// The name used in configs.
    pub fn as_str(self) -> &'static str {
        match self {
            EeController::Ik => "ik",
            EeController::Osc => "osc",
        }
    }
}

impl EeFrame {
    /// The name used in configs.
    pub fn as_str(self) -> &'static str {
        match self {
            EeFrame::Base => "base",
            EeFrame::Hand => "hand",
        }
    }
}

/// The options whose values are names, with the names they take: a wrong name is an error
/// naming the option (serde's own message names only the value).
const NAMED_OPTIONS: [(&str, &[&str]); 2] = [
    ("ee_frame", &["base", "hand"]),
    ("ee_controller", &["ik", "osc"]),
];

fn check_names(document: &serde_json::Value) -> Result<()> {
    for (option, names) in NAMED_OPTIONS {
        let Some(value) = document.get(option) else {
            continue;
        };
        if !value.as_str().is_some_and(|v| names.contains(&v)) {
            return Err(invalid(
                option,
                format!("must be one of {}, got {value}", names.join(", ")),
            ));
        }
    }
    Ok(())
}

/// Everything that defines an environment, by owner: the task (`task`: which one, with its own
/// objects, regions and ranges), the robot (`arm`, `control_mode`, `robot`: its model, joints
/// and motors) and the physics (`physics`: gravity, floor, solver), beside the episode's
/// options (reward, length, control rate, action scales). Defaults: pick-and-place, 25 Hz
/// control, 70 steps, sparse reward, end-effector control, the dynamic arm.
///
/// The physics step `physics.solver.dt` and `control_frequency` fix the number of physics
/// steps per action. Configurations from before 0.2 (a `sim` section, top-level task keys)
/// still read, with a [`Deprecation`] note per old key ([`EnvConfig::from_json_with_notes`]).
///
/// # Defaults
///
/// Every field with its default value (checked by this doc test):
///
/// ```
/// let defaults = r#"
/// {
///   "task": {
///     "name": "pick_and_place",
///     "cube": {"size": 0.05, "mass": 0.1, "friction": 1.0},
///     "platform": {
///       "top_center": [0.5, 0.3, 0.1],
///       "size": [0.3, 0.3, 0.1],
///       "friction": 1.0
///     },
///     "cube_region": {
///       "low": [0.4, -0.2],
///       "high": [0.6, 0.0]
///     },
///     "cube_yaw_range": [-0.25, 0.25],
///     "goal_region": {
///       "low": [0.42, 0.22],
///       "high": [0.58, 0.38]
///     },
///     "goal_air_probability": 0.0,
///     "goal_air_height": [0.05, 0.2]
///   },
///   "arm": "dynamic",
///   "control_mode": "ee",
///   "reward_type": "sparse",
///   "reward_weights": {},
///   "max_episode_steps": 70,
///   "control_frequency": 25.0,
///   "success_threshold": 0.05,
///   "terminate_on_success": false,
///   "ee_step": 0.05,
///   "ee_rot_step": 0.1,
///   "ee_frame": "base",
///   "ee_controller": "ik",
///   "osc": {
///     "position_stiffness": 150.0,
///     "orientation_stiffness": 150.0,
///     "damping_ratio": 1.0,
///     "null_space_stiffness": 10.0
///   },
///   "joint_step": 0.05,
///   "ee_workspace": [[0.15, -0.6, 0.0], [0.85, 0.6, 0.6]],
///   "ee_surface_clearance": 0.02,
///   "ee_surface_margin": 0.05,
///   "randomization": {
///     "cube_size": null,
///     "cube_mass": null,
///     "cube_friction": null,
///     "joint_noise": 0.0
///   },
///   "thresholds": {
///     "grasp_force": 1.0,
///     "rest_linear_speed": 0.02,
///     "rest_angular_speed": 0.3,
///     "unstable_linear_speed": 20.0,
///     "unstable_angular_speed": 200.0
///   },
///   "physics": {
///     "gravity": [0.0, 0.0, -9.81],
///     "floor_friction": 1.0,
///     "solver": {
///       "dt": 0.01,
///       "solver_iterations": 6,
///       "contact_natural_frequency": 120.0,
///       "contact_damping_ratio": 5.0,
///       "length_unit": 0.1,
///       "contact_prediction_distance": 0.002,
///       "multibody_update": "step"
///     }
///   },
///   "robot": {
///     "urdf": null,
///     "base": [0.0, 0.0, 0.0],
///     "initial_configuration": null,
///     "finger_friction": 1.0,
///     "link_friction": 0.5,
///     "joint_damping": null,
///     "joint_friction": null,
///     "motors": {
///       "stiffness": 40000.0,
///       "damping": 400.0,
///       "velocity_damping": 400.0,
///       "gripper_force": 20.0,
///       "gripper_stiffness": 5000.0,
///       "gripper_damping": 50.0,
///       "arm_armature": 0.0,
///       "finger_armature": 0.05,
///       "kinematic_acceleration": 50.0
///     }
///   }
/// }
/// "#;
/// let documented: serde_json::Value = serde_json::from_str(defaults).unwrap();
/// let actual = serde_json::to_value(panda_rapier_core::EnvConfig::default()).unwrap();
/// assert_eq!(documented, actual);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EnvConfig {
    /// The task and its own section: regions, ranges and objects (each task's module lists
    /// its fields; [`TaskConfig`]). In JSON `"reach"` or `{"name": "reach", ...}`.
    pub task: TaskConfig,
    /// Fidelity of the arm's simulation: `dynamic` (the default: a torque-limited multibody)
    /// or `kinematic` (Fetch-style: links follow the commanded trajectory, fingers and cube
    /// dynamic; several times faster). See [`ArmFidelity`].
    pub arm: ArmFidelity,
    /// How actions drive the robot.
    pub control_mode: ControlMode,
    /// Sparse or dense reward.
    pub reward_type: RewardType,
    /// Weights of the dense reward's terms by name, overriding the task's defaults
    /// ([`TaskDescriptor::reward_terms`]); a name the task's reward does not have is an error.
    /// The sparse reward does not read them.
    pub reward_weights: BTreeMap<String, f64>,
    /// Steps after which an episode is truncated; `null` (`None`): never, for when an outer
    /// wrapper keeps time (Gymnasium's `TimeLimit`, which `gym.make` adds from the registry).
    /// The default, 70 steps (2.8 s at 25 Hz), is the episode length the scripted policy needs
    /// to place the cube in at least 99 % of episodes in both action modes (see
    /// [`PandaEnv`](crate::env::PandaEnv), "Episode end").
    pub max_episode_steps: Option<u32>,
    /// Actions per simulated second (Hz); `1 / (control_frequency * physics.solver.dt)` must be a
    /// whole number of physics steps.
    pub control_frequency: f64,
    /// The cube counts as at the goal within this distance (m).
    pub success_threshold: f64,
    /// End the episode (`terminated`) on the first success instead of running to the time limit.
    pub terminate_on_success: bool,
    /// TCP displacement (m) per step at action 1.0 (`ee` and `ee_pose` control).
    pub ee_step: f64,
    /// TCP rotation (rad) per step at action 1.0, per component of the rotation vector
    /// (`ee_pose` control).
    pub ee_rot_step: f64,
    /// The frame of `ee_pose` actions: `base` (the default) or `hand`.
    pub ee_frame: EeFrame,
    /// What drives the arm to `ee` and `ee_pose` targets: `ik` (the default) or `osc`.
    pub ee_controller: EeController,
    /// Gains of the operational-space controller (`ee_controller: "osc"`).
    pub osc: OscConfig,
    /// Joint target displacement (rad) per step at action 1.0 (`joints` control).
    pub joint_step: f64,
    /// Box (m, world frame) that `ee` targets are clipped into: `[low, high]` per axis as
    /// `[[xlow, ylow, zlow], [xhigh, yhigh, zhigh]]`.
    pub ee_workspace: [[f64; 3]; 2],
    /// Lowest height (m) of an `ee` target above the surface under it (the floor, or, in a task
    /// whose scene has the platform, its top within `ee_surface_margin` of its footprint). The fingertips reach 8 mm
    /// below the TCP; fingertips dragged along a surface made a finger spike to 10-40 m/s in
    /// random-action runs (one in 20,000 steps exceeded the blow-up threshold), and 0.02 m
    /// removed that, as a real robot's workspace limits would. The physics itself still lets
    /// the hand touch surfaces, and the 5 cm cube's centre (0.025 m) stays within reach.
    pub ee_surface_clearance: f64,
    /// How far (m) around the platform's footprint its top counts as the surface under the TCP
    /// (the hand and open fingers reach about this far sideways).
    pub ee_surface_margin: f64,
    /// Domain randomisation (off by default).
    pub randomization: Randomization,
    /// Thresholds of the task predicates and of the blow-up detector.
    pub thresholds: TaskThresholds,
    /// Gravity, the floor and the solver.
    pub physics: PhysicsConfig,
    /// The robot's model, base, joints and motors.
    pub robot: RobotConfig,
}

impl Default for EnvConfig {
    fn default() -> Self {
        Self {
            task: TaskConfig::default(),
            arm: ArmFidelity::Dynamic,
            control_mode: ControlMode::Ee,
            reward_type: RewardType::Sparse,
            reward_weights: BTreeMap::new(),
            max_episode_steps: Some(70),
            control_frequency: 25.0,
            success_threshold: DEFAULT_SUCCESS_THRESHOLD,
            terminate_on_success: false,
            ee_step: 0.05,
            ee_rot_step: 0.1,
            ee_frame: EeFrame::Base,
            ee_controller: EeController::Ik,
            osc: OscConfig::default(),
            joint_step: 0.05,
            ee_workspace: [[0.15, -0.6, 0.0], [0.85, 0.6, 0.6]],
            ee_surface_clearance: 0.02,
            ee_surface_margin: 0.05,
            randomization: Randomization::default(),
            thresholds: TaskThresholds::default(),
            physics: PhysicsConfig::default(),
            robot: RobotConfig::default(),
        }
    }
}

impl EnvConfig {
    /// Parses a JSON document (unknown keys are errors) and validates it. Keys from before
    /// 0.2 are read as [`EnvConfig::from_json_with_notes`] says, silently.
    pub fn from_json(text: &str) -> Result<Self> {
        Self::from_json_with_notes(text).map(|(config, _)| config)
    }

    /// [`EnvConfig::from_json`], with a note for every top-level key from before 0.2
    /// (`pick_region`, `reach_goal_region`, ...; see [`TaskSpec::LEGACY_KEYS`]): it is moved
    /// into the task section, or, if it belongs to another task and holds its old default,
    /// dropped; another task's key with any other value is an error.
    pub fn from_json_with_notes(text: &str) -> Result<(Self, Vec<Deprecation>)> {
        let mut document: serde_json::Value =
            serde_json::from_str(text).map_err(|e| invalid("<json>", e.to_string()))?;
        let notes = migrate(&mut document)?;
        check_names(&document)?;
        let config: Self =
            serde_json::from_value(document).map_err(|e| invalid("<json>", e.to_string()))?;
        config.validate()?;
        Ok((config, notes))
    }

    /// The default configuration of `task`, with its registered episode length
    /// ([`TaskDescriptor::episode_steps`]) and joint action scale
    /// ([`TaskKind::id_joint_step`]), as its Gymnasium ids have.
    pub fn for_task(task: TaskKind) -> Self {
        let defaults = Self::default();
        Self {
            task: task.into(),
            max_episode_steps: Some(task.descriptor().episode_steps),
            joint_step: task.id_joint_step().unwrap_or(defaults.joint_step),
            ..defaults
        }
    }

    /// Physics steps per action, or an error naming the offending fields.
    pub fn substeps(&self) -> Result<u32> {
        let dt = self.physics.solver.dt;
        positive("control_frequency", self.control_frequency)?;
        positive("physics.solver.dt", dt)?;
        let ratio = 1.0 / (self.control_frequency * dt);
        let rounded = ratio.round();
        if rounded < 1.0 || (ratio - rounded).abs() > 1e-6 * rounded {
            return Err(invalid(
                "control_frequency",
                format!(
                    "{} Hz is not a whole number of physics steps of physics.solver.dt = {dt} s",
                    self.control_frequency
                ),
            ));
        }
        Ok(rounded as u32)
    }

    /// What the environment's simulation is built from: `arm`, `physics` and `robot` with
    /// the physics steps per action ([`EnvConfig::substeps`]).
    pub fn sim_config(&self) -> Result<SimConfig> {
        Ok(SimConfig {
            arm: self.arm,
            substeps: self.substeps()?,
            physics: self.physics.clone(),
            robot: self.robot.clone(),
        })
    }

    /// The task's platform, when its scene has one.
    pub fn platform(&self) -> Option<&PlatformConfig> {
        self.task.platform()
    }

    /// The task's cube, when it moves one.
    pub fn cube(&self) -> Option<&CubeConfig> {
        self.task.cube()
    }

    /// Whether the task's scene has the platform.
    pub fn has_platform(&self) -> bool {
        self.platform().is_some()
    }

    /// The height (m) of the surface under the point (x, y) as `ee` targets see it: the
    /// platform's top near its footprint (see `ee_surface_margin`) if the task has the
    /// platform, else the floor.
    pub fn surface_height(&self, x: f64, y: f64) -> f64 {
        let Some(p) = self.platform() else {
            return 0.0;
        };
        let reach_x = p.size[0] / 2.0 + self.ee_surface_margin;
        let reach_y = p.size[1] / 2.0 + self.ee_surface_margin;
        let over = (x - p.top_center[0]).abs() <= reach_x && (y - p.top_center[1]).abs() <= reach_y;
        if over {
            p.top_center[2]
        } else {
            0.0
        }
    }

    /// For the tasks with a platform: cubes drawn in `cube_region` start clear of `platform`
    /// (any yaw, the largest size drawn) and goals in `goal_region` lie on its top. Errors
    /// name `task.cube_region` or `task.goal_region`
    /// ([`validate_platform_regions`](crate::task::config::validate_platform_regions) with
    /// this configuration's `randomization`).
    pub fn validate_platform_regions(
        &self,
        platform: &PlatformConfig,
        cube: &CubeConfig,
        cube_region: &Region,
        goal_region: &Region,
    ) -> Result<()> {
        crate::task::config::validate_platform_regions(
            &self.randomization,
            platform,
            cube,
            cube_region,
            goal_region,
        )
    }

    /// Checks a task's cube start: `task.cube_region` and `task.cube_yaw_range`
    /// ([`validate_cube_start`](crate::task::config::validate_cube_start)).
    pub fn validate_cube_start(cube_region: &Region, cube_yaw_range: Range) -> Result<()> {
        crate::task::config::validate_cube_start(cube_region, cube_yaw_range)
    }

    /// What the task reads beside its own section: the reward type, randomisation, success
    /// threshold, predicate thresholds, and the reward weights resolved against the task's
    /// terms ([`TaskDescriptor::reward_terms`]). The one place `reward_weights` is resolved.
    pub fn task_context(&self) -> TaskContext {
        let terms = self.task.kind().descriptor().reward_terms;
        TaskContext {
            reward_type: self.reward_type,
            randomization: self.randomization.clone(),
            success_threshold: self.success_threshold,
            reward_weights: RewardWeights::resolve(terms, &self.reward_weights),
            thresholds: self.thresholds.clone(),
        }
    }

    /// The weights of the task's reward terms: each term's default, or what `reward_weights`
    /// sets.
    pub fn reward_weights_resolved(&self) -> BTreeMap<&'static str, f64> {
        let terms = self.task.kind().descriptor().reward_terms;
        self.task_context().reward_weights.named(terms)
    }

    /// The configuration with every default spelt out: `reward_weights` holds the weight of
    /// each of the task's terms (what `config_json` reports; it reads back as the same
    /// environment).
    pub fn resolved(&self) -> Self {
        let mut config = self.clone();
        config.reward_weights = self
            .reward_weights_resolved()
            .into_iter()
            .map(|(name, weight)| (name.to_string(), weight))
            .collect();
        config
    }

    fn validate_reward_weights(&self) -> Result<()> {
        let d: &TaskDescriptor = self.task.kind().descriptor();
        for (name, &weight) in &self.reward_weights {
            let field = format!("reward_weights.{name}");
            if !d.reward_terms.iter().any(|t| t.name == name) {
                let names: Vec<_> = d.reward_terms.iter().map(|t| t.name).collect();
                return Err(invalid(
                    &field,
                    format!(
                        "the {} task's reward has no {name:?} term; its terms: {}",
                        d.name,
                        names.join(", ")
                    ),
                ));
            }
            non_negative(&field, weight)?;
        }
        Ok(())
    }

    /// Checks every value; the first problem is returned with its field name.
    pub fn validate(&self) -> Result<()> {
        self.sim_config()?.validate()?;
        if self.max_episode_steps == Some(0) {
            return Err(invalid("max_episode_steps", "must be >= 1, got 0"));
        }
        positive("success_threshold", self.success_threshold)?;
        self.validate_reward_weights()?;
        positive("ee_step", self.ee_step)?;
        positive("ee_rot_step", self.ee_rot_step)?;
        self.osc.validate()?;
        if self.ee_controller == EeController::Osc {
            if self.control_mode == ControlMode::Joints {
                return Err(invalid(
                    "ee_controller",
                    "\"osc\" drives end-effector actions (control_mode \"ee\" or \"ee_pose\"), \
                     not \"joints\"",
                ));
            }
            if self.arm == ArmFidelity::Kinematic {
                return Err(invalid(
                    "ee_controller",
                    "\"osc\" drives the arm by joint torques: it needs arm \"dynamic\"",
                ));
            }
        }
        positive("joint_step", self.joint_step)?;
        non_negative("ee_surface_clearance", self.ee_surface_clearance)?;
        non_negative("ee_surface_margin", self.ee_surface_margin)?;
        let [low, high] = self.ee_workspace;
        for i in 0..3 {
            if !(low[i].is_finite() && high[i].is_finite()) || low[i] > high[i] {
                return Err(invalid(
                    "ee_workspace",
                    format!(
                        "must be finite with low <= high, got {:?}",
                        self.ee_workspace
                    ),
                ));
            }
        }
        let r = &self.randomization;
        if let Some(s) = r.cube_size {
            validate_range("randomization.cube_size", s, 0.0)?;
            if s[0] <= 0.0 || s[1] > 0.08 {
                return Err(invalid(
                    "randomization.cube_size",
                    format!("must lie in (0, 0.08] m (the gripper's opening), got {s:?}"),
                ));
            }
        }
        if let Some(m) = r.cube_mass {
            validate_range("randomization.cube_mass", m, 0.0)?;
            if m[0] <= 0.0 {
                return Err(invalid(
                    "randomization.cube_mass",
                    format!("must be > 0, got {m:?}"),
                ));
            }
        }
        if let Some(f) = r.cube_friction {
            validate_range("randomization.cube_friction", f, 0.0)?;
        }
        non_negative("randomization.joint_noise", r.joint_noise)?;
        if self.cube().is_none() {
            let drawn = [
                ("cube_size", r.cube_size.is_some()),
                ("cube_mass", r.cube_mass.is_some()),
                ("cube_friction", r.cube_friction.is_some()),
            ];
            if let Some((name, _)) = drawn.iter().find(|(_, set)| *set) {
                return Err(invalid(
                    &format!("randomization.{name}"),
                    format!("the {} task has no cube to draw it for", self.task.kind()),
                ));
            }
        }
        let t = &self.thresholds;
        positive("thresholds.grasp_force", t.grasp_force)?;
        positive("thresholds.rest_linear_speed", t.rest_linear_speed)?;
        positive("thresholds.rest_angular_speed", t.rest_angular_speed)?;
        positive("thresholds.unstable_linear_speed", t.unstable_linear_speed)?;
        positive(
            "thresholds.unstable_angular_speed",
            t.unstable_angular_speed,
        )?;
        self.task.validate(&self.task_context())?;
        Ok(())
    }
}

/// Builds the task `config` names, from its section and [`EnvConfig::task_context`].
pub fn make_task(config: &EnvConfig) -> Box<dyn Task> {
    config.task.build(&config.task_context())
}

impl ObservationLayout {
    /// The layout of the environments `config` builds, without building one.
    pub fn for_config(config: &EnvConfig) -> Result<Self> {
        config.validate()?;
        let robot = crate::robot::RobotSpec::new(&config.sim_config()?)?;
        let task = make_task(config);
        Ok(Self::new(
            robot.movable_joints().len(),
            task.goal_dim(),
            task.goal_descriptions(),
            task.observation_slots(),
        ))
    }
}

impl<'t> dyn Task + 't {
    /// The platform and objects the world of `config` must hold: the task's
    /// [`Task::build_scene`] (a task's scene comes from its own section).
    pub fn scene(&self, _config: &EnvConfig) -> crate::physics::Scene {
        self.build_scene()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;
    use crate::task::pick_and_place::PickAndPlaceConfig;

    fn pnp(config: &mut EnvConfig) -> &mut PickAndPlaceConfig {
        match &mut config.task {
            TaskConfig::PickAndPlace(section) => section,
            other => panic!("not pick_and_place: {other:?}"),
        }
    }

    #[test]
    fn defaults_are_valid_and_give_four_substeps() {
        let config = EnvConfig::default();
        config.validate().unwrap();
        assert_eq!(config.substeps().unwrap(), 4);
    }

    #[test]
    fn control_frequency_sets_the_substeps() {
        let mut config = EnvConfig {
            control_frequency: 50.0,
            ..EnvConfig::default()
        };
        assert_eq!(config.substeps().unwrap(), 2);
        assert_eq!(config.sim_config().unwrap().substeps, 2);
        config.physics.solver.dt = 0.002;
        assert_eq!(config.substeps().unwrap(), 10);
        config.control_frequency = 20.0;
        assert_eq!(config.substeps().unwrap(), 25);
    }

    #[test]
    fn each_bad_value_names_its_field() {
        type Mutation = Box<dyn Fn(&mut EnvConfig)>;
        let cases: Vec<(&str, Mutation)> = vec![
            (
                "control_frequency",
                Box::new(|c| c.control_frequency = 30.0),
            ),
            ("control_frequency", Box::new(|c| c.control_frequency = 0.0)),
            (
                "max_episode_steps",
                Box::new(|c| c.max_episode_steps = Some(0)),
            ),
            (
                "success_threshold",
                Box::new(|c| c.success_threshold = -0.1),
            ),
            (
                "task.cube_region",
                Box::new(|c| pnp(c).cube_region.low[0] = 0.9),
            ),
            (
                "task.cube_region",
                Box::new(|c| pnp(c).cube_region.high[1] = 0.3),
            ),
            (
                "task.goal_region",
                Box::new(|c| pnp(c).goal_region.high[0] = 2.0),
            ),
            (
                "task.goal_air_probability",
                Box::new(|c| pnp(c).goal_air_probability = 1.5),
            ),
            (
                "task.goal_air_height",
                Box::new(|c| pnp(c).goal_air_height = [0.2, 0.1]),
            ),
            (
                "randomization.cube_mass",
                Box::new(|c| c.randomization.cube_mass = Some([-1.0, 1.0])),
            ),
            (
                "randomization.cube_size",
                Box::new(|c| c.randomization.cube_size = Some([0.02, 0.1])),
            ),
            (
                "ee_workspace",
                Box::new(|c| c.ee_workspace[0][2] = f64::NAN),
            ),
            ("physics.solver.dt", Box::new(|c| c.physics.solver.dt = 0.0)),
            ("ee_rot_step", Box::new(|c| c.ee_rot_step = 0.0)),
            ("task.cube.mass", Box::new(|c| pnp(c).cube.mass = 0.0)),
            (
                "task.platform.friction",
                Box::new(|c| pnp(c).platform.friction = -1.0),
            ),
            (
                "robot.motors.damping",
                Box::new(|c| c.robot.motors.damping = f64::NAN),
            ),
        ];
        for (field, mutate) in cases {
            let mut config = EnvConfig::default();
            mutate(&mut config);
            match config.validate() {
                Err(Error::InvalidConfig { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{field}: expected InvalidConfig, got {other:?}"),
            }
        }
    }

    #[test]
    fn a_task_without_a_cube_refuses_cube_randomisation() {
        let mut config = EnvConfig::for_task(TaskKind::Reach);
        config.randomization.cube_mass = Some([0.05, 0.2]);
        match config.validate() {
            Err(Error::InvalidConfig { field, reason }) => {
                assert_eq!(field, "randomization.cube_mass");
                assert!(reason.contains("reach"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
        assert!(config.cube().is_none() && config.platform().is_none());
    }

    #[test]
    fn json_round_trip_and_unknown_keys() {
        let config = EnvConfig::from_json(
            r#"{"control_mode": "joints", "reward_type": "dense",
                "task": {"name": "pick_and_place", "cube": {"mass": 0.2}}}"#,
        )
        .unwrap();
        assert_eq!(config.control_mode, ControlMode::Joints);
        assert_eq!(config.reward_type, RewardType::Dense);
        assert_eq!(config.cube().unwrap().mass, 0.2);
        let text = serde_json::to_string(&config).unwrap();
        assert_eq!(EnvConfig::from_json(&text).unwrap(), config);
        let err = EnvConfig::from_json(r#"{"episode_length": 10}"#).unwrap_err();
        assert!(err.to_string().contains("episode_length"), "{err}");
        let err = EnvConfig::from_json(r#"{"control_mode": "torque"}"#).unwrap_err();
        assert!(err.to_string().contains("torque"), "{err}");
        let config =
            EnvConfig::from_json(r#"{"control_mode": "ee_pose", "ee_frame": "hand"}"#).unwrap();
        assert_eq!(config.control_mode, ControlMode::EePose);
        assert_eq!(config.ee_frame, EeFrame::Hand);
        match EnvConfig::from_json(r#"{"control_mode": "ee_pose", "ee_frame": "tool"}"#) {
            Err(Error::InvalidConfig { field, reason }) => {
                assert_eq!(field, "ee_frame");
                assert!(reason.contains("tool"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }
}
