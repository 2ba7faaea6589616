//! Validated configuration of an environment ([`EnvConfig`]): the task's section, the robot,
//! the physics and the episode's options.
//!
//! Over 600 lines because [`EnvConfig`]'s doc test spells out every default value (about 100
//! lines), which keeps the documented defaults true, and the validation's tests name every
//! field they refuse.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::config::{
    invalid, non_negative, positive, ArmFidelity, CubeConfig, PhysicsConfig, PlatformConfig,
    RobotConfig, SimConfig,
};
use crate::error::Result;
use crate::task::migrate::{migrate, Deprecation};
#[cfg(doc)]
use crate::task::registry::TaskSpec;
use crate::task::registry::{TaskConfig, TaskDescriptor, TaskKind};

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
}

impl ControlMode {
    /// The name used in configs and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            ControlMode::Ee => "ee",
            ControlMode::Joints => "joints",
        }
    }
}

/// Which reward the environment returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RewardType {
    /// -1 until the cube is within the success threshold of the goal, then 0.
    #[default]
    Sparse,
    /// Staged shaping: reach, grasp, lift, carry, place (see [`crate::task::reward`]).
    Dense,
}

impl RewardType {
    /// The name used in configs and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            RewardType::Sparse => "sparse",
            RewardType::Dense => "dense",
        }
    }
}

/// An axis-aligned rectangle in the horizontal plane (m, world frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Smallest x and y.
    pub low: [f64; 2],
    /// Largest x and y.
    pub high: [f64; 2],
}

impl Region {
    /// The point at fractions `u` (each in [0, 1]) across the region.
    pub fn lerp(&self, u: [f64; 2]) -> [f64; 2] {
        [
            self.low[0] + (self.high[0] - self.low[0]) * u[0],
            self.low[1] + (self.high[1] - self.low[1]) * u[1],
        ]
    }

    /// Checks that the region is finite and not inverted; errors name `field`.
    pub fn validate(&self, field: &str) -> Result<()> {
        for i in 0..2 {
            if !(self.low[i].is_finite() && self.high[i].is_finite()) {
                return Err(invalid(field, format!("must be finite, got {self:?}")));
            }
            if self.low[i] > self.high[i] {
                return Err(invalid(
                    field,
                    format!("is inverted: low {:?} > high {:?}", self.low, self.high),
                ));
            }
        }
        Ok(())
    }
}

/// A closed interval `[low, high]` for a randomised quantity.
pub type Range = [f64; 2];

/// Domain randomisation, drawn at every reset. Everything is off by default; the random draws
/// happen either way, so switching one on does not change the other quantities of a seed.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Randomization {
    /// Cube edge length range (m).
    pub cube_size: Option<Range>,
    /// Cube mass range (kg).
    pub cube_mass: Option<Range>,
    /// Cube friction coefficient range.
    pub cube_friction: Option<Range>,
    /// Uniform noise (+- rad) added to each arm joint of the start configuration.
    pub joint_noise: f64,
}

/// Thresholds that decide the task's predicates (`is_grasped`, `is_placed`, ...).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TaskThresholds {
    /// Normal force (N) each finger must press the cube with for it to count as grasped.
    pub grasp_force: f64,
    /// The cube is at rest below this speed (m/s)...
    pub rest_linear_speed: f64,
    /// ...and this angular speed (rad/s).
    pub rest_angular_speed: f64,
    /// A body faster than this (m/s) means the physics blew up: the episode is truncated.
    pub unstable_linear_speed: f64,
    /// A body spinning faster than this (rad/s) means the physics blew up.
    pub unstable_angular_speed: f64,
}

impl Default for TaskThresholds {
    fn default() -> Self {
        Self {
            grasp_force: 1.0,
            rest_linear_speed: 0.02,
            rest_angular_speed: 0.3,
            unstable_linear_speed: 20.0,
            unstable_angular_speed: 200.0,
        }
    }
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
    /// TCP displacement (m) per step at action 1.0 (`ee` control).
    pub ee_step: f64,
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
            success_threshold: 0.05,
            terminate_on_success: false,
            ee_step: 0.05,
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

/// Checks that `r` is finite, not inverted and starts at or above `min`; errors name `field`.
pub fn validate_range(field: &str, r: Range, min: f64) -> Result<()> {
    if !(r[0].is_finite() && r[1].is_finite()) {
        return Err(invalid(field, format!("must be finite, got {r:?}")));
    }
    if r[0] > r[1] {
        return Err(invalid(field, format!("is inverted: {r:?}")));
    }
    if r[0] < min {
        return Err(invalid(field, format!("must be >= {min}, got {r:?}")));
    }
    Ok(())
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
    /// name `task.cube_region` or `task.goal_region`.
    pub fn validate_platform_regions(
        &self,
        platform: &PlatformConfig,
        cube: &CubeConfig,
        cube_region: &Region,
        goal_region: &Region,
    ) -> Result<()> {
        let (platform_low, platform_high) = platform.top_face();
        let largest_cube = self.randomization.cube_size.map_or(cube.size, |s| s[1]);
        // Half the diagonal: a yawed cube reaches that far from its centre.
        let reach = largest_cube * std::f64::consts::FRAC_1_SQRT_2;
        let pick = cube_region;
        let overlaps = (0..2).all(|i| {
            pick.low[i] - reach < platform_high[i] && pick.high[i] + reach > platform_low[i]
        });
        if overlaps {
            return Err(invalid(
                "task.cube_region",
                format!(
                    "a cube drawn in {pick:?} could overlap the platform spanning {platform_low:?}..{platform_high:?}"
                ),
            ));
        }
        let goal = goal_region;
        let inside =
            (0..2).all(|i| goal.low[i] >= platform_low[i] && goal.high[i] <= platform_high[i]);
        if !inside {
            return Err(invalid(
                "task.goal_region",
                format!(
                    "must lie on the platform's top {platform_low:?}..{platform_high:?}, got {goal:?}"
                ),
            ));
        }
        Ok(())
    }

    /// Checks a task's cube start: `task.cube_region` and `task.cube_yaw_range`.
    pub fn validate_cube_start(cube_region: &Region, cube_yaw_range: Range) -> Result<()> {
        cube_region.validate("task.cube_region")?;
        validate_range("task.cube_yaw_range", cube_yaw_range, f64::NEG_INFINITY)
    }

    /// The weights of the task's reward terms: each term's default, or what `reward_weights`
    /// sets.
    pub fn reward_weights_resolved(&self) -> BTreeMap<&'static str, f64> {
        let terms = self.task.kind().descriptor().reward_terms;
        crate::task::reward::resolve_weights(terms, &self.reward_weights)
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
        self.task.validate(self)?;
        Ok(())
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
    }
}
