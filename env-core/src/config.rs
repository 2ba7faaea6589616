//! Validated configuration of the simulated world, by owner: the physics ([`PhysicsConfig`]:
//! gravity, the floor, the solver), the robot ([`RobotConfig`]: its model, base, joints and
//! motors) and the objects a task puts in the world ([`PlatformConfig`], [`CubeConfig`], which
//! the task's own configuration section holds). [`SimConfig`] joins the first two with the arm's
//! fidelity for a bare [`crate::Simulation`].

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The physics engine's step and solver settings.
///
/// The defaults are the cheapest settings that keep the friction grasp honest (see
/// `tests/integration/grasp_sequence.rs` for the slip bound they are held to).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverConfig {
    /// Physics time step in seconds.
    pub dt: f64,
    /// Velocity solver iterations per physics step. With 4 a held cube creeps in the hand
    /// under sustained swinging (it dropped after 30-60 s of a 0.5 Hz swing); 6 holds it.
    pub solver_iterations: u32,
    /// Natural frequency (Hz) of the soft contact model; stiffer contacts stop a squeezed cube
    /// from sinking into the finger pads.
    pub contact_natural_frequency: f64,
    /// Contact damping ratio.
    pub contact_damping_ratio: f64,
    /// Characteristic length of the scene (m): rapier scales its penetration and
    /// prediction tolerances by it, so it is set to the size of the objects handled.
    pub length_unit: f64,
    /// Distance (m) within which rapier creates contacts ahead of time, before the shapes
    /// touch. A physics step must not move fingers and cube farther than this, or contacts
    /// arrive late and grasps slip (`docs/benchmarks.md`, "Why dt = 0.02 s loses the
    /// scripted policy"). rapier's own default is `0.02 x length_unit`.
    pub contact_prediction_distance: f64,
    /// How often the dynamic arm's mass matrix (and what depends only on its configuration)
    /// is rebuilt: once per physics step (`"step"`, the default) or after every solver
    /// iteration (`"substep"`, rapier's own behaviour, several times more expensive).
    pub multibody_update: MultibodyUpdate,
}

/// How often the articulated arm's configuration-dependent dynamics (its mass matrix and that
/// matrix's factorization, the inverse-mass columns of its joint motor and limit rows, its free
/// accelerations) are refreshed within one physics step. Link poses, Jacobians and joint
/// motor targets follow every solver iteration in both modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MultibodyUpdate {
    /// Once, at the start of each physics step, held for its solver iterations (as rapier
    /// already holds the arm's contact rows). The grasp, creep and scripted-policy figures
    /// match `Substep`'s (`docs/benchmarks.md`).
    #[default]
    Step,
    /// After every solver iteration (substep), as stock rapier 0.36.1 does.
    Substep,
}

impl MultibodyUpdate {
    /// The name used in configuration files.
    pub fn as_str(self) -> &'static str {
        match self {
            MultibodyUpdate::Step => "step",
            MultibodyUpdate::Substep => "substep",
        }
    }
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            dt: 0.01,
            solver_iterations: 6,
            contact_natural_frequency: 120.0,
            contact_damping_ratio: 5.0,
            length_unit: 0.1,
            contact_prediction_distance: 0.002,
            multibody_update: MultibodyUpdate::Step,
        }
    }
}

/// Position-control gains of the arm's joint motors (acceleration based: independent of the
/// link masses).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotorConfig {
    /// Stiffness (1/s^2) of position control.
    pub stiffness: f64,
    /// Damping (1/s) of position control.
    pub damping: f64,
    /// Damping (1/s) used by velocity control.
    pub velocity_damping: f64,
    /// Force limit (N) of the gripper's drive when it is commanded without a force. The drive
    /// moves both coupled fingers, so closed on an object each finger presses with half of it.
    pub gripper_force: f64,
    /// Stiffness (N/m) of the fingers' position control. Force based, unlike the arm's: closed
    /// on an object the finger motors saturate at the commanded force, so the squeeze is the
    /// force asked for rather than whatever a mass-scaled spring produces.
    pub gripper_stiffness: f64,
    /// Damping (N s/m) of the fingers' position control.
    pub gripper_damping: f64,
    /// Reflected rotor inertia (kg m^2) added to each arm joint, as the Panda's geared motors
    /// have.
    pub arm_armature: f64,
    /// Reflected drive inertia (kg) added to the gripper's finger joints. The real gripper's
    /// geared drive has plenty; without any, a light finger pressed against the floor spiked to
    /// 20-40 m/s (3 times in 64,000 random-action steps), and 0.05 kg removed those blow-ups
    /// with the grasp's slip unchanged (`tests/integration/grasp_sequence.rs`).
    pub finger_armature: f64,
    /// Joint acceleration limit (rad/s^2 or m/s^2) of the kinematic arm
    /// ([`ArmFidelity::Kinematic`]). The default matches what the dynamic arm's torque-limited
    /// motors do under the scripted policy (99th percentile 43 rad/s^2 over a control step,
    /// peaks of 50-280), so a policy behaves alike on both arms: at 20 rad/s^2 the scripted
    /// policy overshot and placed 90.5 % (ee) / 97.5 % (joints) of 200 episodes, at 50 it
    /// placed 100 % / 99.5 %. The real Panda's datasheet gives 7.5-20 rad/s^2 per joint.
    pub kinematic_acceleration: f64,
}

impl Default for MotorConfig {
    fn default() -> Self {
        Self {
            stiffness: 4.0e4,
            damping: 400.0,
            velocity_damping: 400.0,
            gripper_force: 20.0,
            gripper_stiffness: 5000.0,
            gripper_damping: 50.0,
            arm_armature: 0.0,
            finger_armature: 0.05,
            kinematic_acceleration: 50.0,
        }
    }
}

/// The fixed box a task carries its cube to (part of the task's configuration section).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlatformConfig {
    /// Centre of the box's top face (m, world frame).
    pub top_center: [f64; 3],
    /// Full size of the box (m): x, y, and height.
    pub size: [f64; 3],
    /// Friction coefficient.
    pub friction: f64,
}

impl Default for PlatformConfig {
    fn default() -> Self {
        Self {
            top_center: [0.5, 0.3, 0.1],
            size: [0.3, 0.3, 0.1],
            friction: 1.0,
        }
    }
}

impl PlatformConfig {
    /// Checks every value; errors name the field under `prefix` (such as `task.platform`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        finite3(&format!("{prefix}.top_center"), self.top_center)?;
        for (i, &v) in self.size.iter().enumerate() {
            positive(&format!("{prefix}.size[{i}]"), v)?;
        }
        non_negative(&format!("{prefix}.friction"), self.friction)?;
        if self.top_center[2] - self.size[2] < -1e-9 {
            return Err(invalid(
                prefix,
                format!(
                    "extends below the floor: top at z = {} with height {}",
                    self.top_center[2], self.size[2]
                ),
            ));
        }
        Ok(())
    }

    /// The box's top face as `(low, high)` corners in x and y (m).
    pub fn top_face(&self) -> ([f64; 2], [f64; 2]) {
        let half = [self.size[0] / 2.0, self.size[1] / 2.0];
        (
            [self.top_center[0] - half[0], self.top_center[1] - half[1]],
            [self.top_center[0] + half[0], self.top_center[1] + half[1]],
        )
    }
}

/// The dynamic cube a task moves (part of the task's configuration section; the task places
/// it at every reset, so it has no position here).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CubeConfig {
    /// Edge length (m).
    pub size: f64,
    /// Mass (kg).
    pub mass: f64,
    /// Friction coefficient.
    pub friction: f64,
}

impl Default for CubeConfig {
    fn default() -> Self {
        Self {
            size: 0.05,
            mass: 0.1,
            friction: 1.0,
        }
    }
}

impl CubeConfig {
    /// Checks every value; errors name the field under `prefix` (such as `task.cube`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        positive(&format!("{prefix}.size"), self.size)?;
        positive(&format!("{prefix}.mass"), self.mass)?;
        non_negative(&format!("{prefix}.friction"), self.friction)?;
        if self.size > 0.08 {
            return Err(invalid(
                &format!("{prefix}.size"),
                format!("must fit the gripper's 0.08 m opening, got {}", self.size),
            ));
        }
        Ok(())
    }
}

/// How the arm is simulated: the fidelity level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ArmFidelity {
    /// Full dynamics: the arm is a multibody (reduced coordinates) whose torque-limited joint
    /// motors fight gravity, inertia and contacts; joint targets are tracked, not imposed.
    #[default]
    Dynamic,
    /// Fetch-style: the arm's links are placed along the commanded joint trajectory (the
    /// dynamic arm's motor law, within the joints' velocity limits and
    /// `motors.kinematic_acceleration`), pushing whatever they touch with unlimited force; no
    /// arm dynamics, gravity or torque limits. The gripper (hand and fingers, with the same
    /// coupled, force-limited drive) and the cube stay fully dynamic, and the grasp is held by
    /// friction as with `Dynamic`. A motion that would take a robot link into the floor or the
    /// platform is refused (the arm stops) rather than letting the link sink in. With the
    /// default `solver.multibody_update` it costs about a fifth fewer instructions per step
    /// than `Dynamic` (its gripper is a free multibody welded to the placed arm). Torque
    /// control is not available.
    Kinematic,
}

impl ArmFidelity {
    /// The name used in configuration files.
    pub fn as_str(self) -> &'static str {
        match self {
            ArmFidelity::Dynamic => "dynamic",
            ArmFidelity::Kinematic => "kinematic",
        }
    }
}

/// The physics of the world: gravity, the floor and the solver.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhysicsConfig {
    /// Gravity (m/s^2).
    pub gravity: [f64; 3],
    /// Friction coefficient of the floor.
    pub floor_friction: f64,
    /// Solver settings.
    pub solver: SolverConfig,
}

impl Default for PhysicsConfig {
    fn default() -> Self {
        Self {
            gravity: [0.0, 0.0, -9.81],
            floor_friction: 1.0,
            solver: SolverConfig::default(),
        }
    }
}

/// The robot: its model, where it stands, its joints and its motors. (Its fidelity, `arm`, and
/// how it is commanded, `control_mode`, are top-level options of an environment.)
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotConfig {
    /// Robot description; `None` uses the bundled Panda (`assets/panda/panda.urdf`).
    pub urdf: Option<PathBuf>,
    /// Position of the robot's root link (m).
    pub base: [f64; 3],
    /// Initial arm configuration, one entry per actuated joint; `None` uses the Panda's ready
    /// pose (hand pointing down, gripper open) or zeros for other robots.
    pub initial_configuration: Option<Vec<f64>>,
    /// Friction coefficient of the finger pads.
    pub finger_friction: f64,
    /// Friction coefficient of the other robot links.
    pub link_friction: f64,
    /// Viscous damping (N m s/rad or N s/m) of every movable joint of the dynamic arm and the
    /// gripper, in place of the URDF's `<dynamics damping>`; `None` uses the URDF's, 0 where
    /// it has none (the bundled Panda has none). A passive term beside the motors: position and
    /// velocity control have their own damping (`motors`).
    pub joint_damping: Option<f64>,
    /// Coulomb friction (N m or N) of every movable joint, in place of the URDF's `<dynamics
    /// friction>`; `None` uses the URDF's, 0 where absent.
    pub joint_friction: Option<f64>,
    /// Joint motor gains.
    pub motors: MotorConfig,
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self {
            urdf: None,
            base: [0.0, 0.0, 0.0],
            initial_configuration: None,
            finger_friction: 1.0,
            link_friction: 0.5,
            joint_damping: None,
            joint_friction: None,
            motors: MotorConfig::default(),
        }
    }
}

/// Everything needed to build a [`crate::Simulation`] besides its [`crate::Scene`]: the arm's
/// fidelity, the physics steps per control step, the physics and the robot. An environment
/// derives it from its [`crate::EnvConfig`] (`EnvConfig::sim_config`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// Fidelity of the arm's simulation.
    pub arm: ArmFidelity,
    /// Physics steps per control step (`Simulation::step_control`); the control period is
    /// `physics.solver.dt * substeps` (default 0.01 s x 4 = 25 Hz).
    pub substeps: u32,
    /// Gravity, floor and solver.
    pub physics: PhysicsConfig,
    /// The robot.
    pub robot: RobotConfig,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            arm: ArmFidelity::Dynamic,
            substeps: 4,
            physics: PhysicsConfig::default(),
            robot: RobotConfig::default(),
        }
    }
}

pub(crate) fn invalid(field: &str, reason: impl Into<String>) -> Error {
    Error::InvalidConfig {
        field: field.to_owned(),
        reason: reason.into(),
    }
}

pub(crate) fn positive(field: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must be finite and > 0, got {value}"),
        ))
    }
}

pub(crate) fn non_negative(field: &str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must be finite and >= 0, got {value}"),
        ))
    }
}

fn finite3(field: &str, v: [f64; 3]) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(invalid(field, format!("must be finite, got {v:?}")))
    }
}

impl SolverConfig {
    /// Checks every value; errors name the field under `prefix` (such as `physics.solver`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        let field = |name: &str| format!("{prefix}.{name}");
        positive(&field("dt"), self.dt)?;
        if self.dt > 0.05 {
            return Err(invalid(
                &field("dt"),
                format!("must be <= 0.05 s, got {}", self.dt),
            ));
        }
        if self.solver_iterations == 0 || self.solver_iterations > 100 {
            return Err(invalid(
                &field("solver_iterations"),
                format!("must be in 1..=100, got {}", self.solver_iterations),
            ));
        }
        positive(
            &field("contact_natural_frequency"),
            self.contact_natural_frequency,
        )?;
        positive(&field("contact_damping_ratio"), self.contact_damping_ratio)?;
        positive(&field("length_unit"), self.length_unit)?;
        positive(
            &field("contact_prediction_distance"),
            self.contact_prediction_distance,
        )?;
        if self.contact_prediction_distance > 1.0 {
            return Err(invalid(
                &field("contact_prediction_distance"),
                format!(
                    "must be at most 1 m, got {}",
                    self.contact_prediction_distance
                ),
            ));
        }
        Ok(())
    }
}

impl PhysicsConfig {
    /// Checks every value; errors name the field as `physics.<field>`.
    pub fn validate(&self) -> Result<()> {
        finite3("physics.gravity", self.gravity)?;
        non_negative("physics.floor_friction", self.floor_friction)?;
        self.solver.validate("physics.solver")
    }
}

impl MotorConfig {
    /// Checks every value; errors name the field under `prefix` (such as `robot.motors`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        let field = |name: &str| format!("{prefix}.{name}");
        positive(&field("stiffness"), self.stiffness)?;
        non_negative(&field("damping"), self.damping)?;
        positive(&field("velocity_damping"), self.velocity_damping)?;
        non_negative(&field("gripper_force"), self.gripper_force)?;
        positive(&field("gripper_stiffness"), self.gripper_stiffness)?;
        non_negative(&field("gripper_damping"), self.gripper_damping)?;
        non_negative(&field("arm_armature"), self.arm_armature)?;
        non_negative(&field("finger_armature"), self.finger_armature)?;
        positive(
            &field("kinematic_acceleration"),
            self.kinematic_acceleration,
        )
    }
}

impl RobotConfig {
    /// Checks every value; errors name the field as `robot.<field>`.
    pub fn validate(&self) -> Result<()> {
        finite3("robot.base", self.base)?;
        if let Some(q) = &self.initial_configuration {
            if let Some(bad) = q.iter().find(|v| !v.is_finite()) {
                return Err(invalid(
                    "robot.initial_configuration",
                    format!("must be finite, got {bad}"),
                ));
            }
        }
        non_negative("robot.finger_friction", self.finger_friction)?;
        non_negative("robot.link_friction", self.link_friction)?;
        if let Some(d) = self.joint_damping {
            non_negative("robot.joint_damping", d)?;
        }
        if let Some(f) = self.joint_friction {
            non_negative("robot.joint_friction", f)?;
        }
        self.motors.validate("robot.motors")
    }
}

impl SimConfig {
    /// Parses a JSON document; unknown keys are errors.
    pub fn from_json(text: &str) -> Result<Self> {
        let config: Self =
            serde_json::from_str(text).map_err(|e| invalid("<json>", e.to_string()))?;
        config.validate()?;
        Ok(config)
    }

    /// Checks every value; the first problem found is returned with its field name.
    pub fn validate(&self) -> Result<()> {
        if self.substeps == 0 || self.substeps > 10_000 {
            return Err(invalid(
                "substeps",
                format!("must be in 1..=10000, got {}", self.substeps),
            ));
        }
        self.physics.validate()?;
        self.robot.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        SimConfig::default().validate().unwrap();
    }

    #[test]
    fn each_bad_value_names_its_field() {
        type Mutation = Box<dyn Fn(&mut SimConfig)>;
        let cases: Vec<(&str, Mutation)> = vec![
            ("physics.solver.dt", Box::new(|c| c.physics.solver.dt = 0.0)),
            ("substeps", Box::new(|c| c.substeps = 0)),
            (
                "physics.solver.contact_prediction_distance",
                Box::new(|c| c.physics.solver.contact_prediction_distance = f64::NAN),
            ),
            (
                "physics.solver.contact_prediction_distance",
                Box::new(|c| c.physics.solver.contact_prediction_distance = 2.0),
            ),
            (
                "physics.gravity",
                Box::new(|c| c.physics.gravity[2] = f64::INFINITY),
            ),
            (
                "robot.motors.stiffness",
                Box::new(|c| c.robot.motors.stiffness = 0.0),
            ),
            (
                "robot.link_friction",
                Box::new(|c| c.robot.link_friction = -1.0),
            ),
        ];
        for (field, mutate) in cases {
            let mut config = SimConfig::default();
            mutate(&mut config);
            match config.validate() {
                Err(Error::InvalidConfig { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{field}: expected InvalidConfig, got {other:?}"),
            }
        }
    }

    #[test]
    fn json_rejects_unknown_keys_and_fills_defaults() {
        let config = SimConfig::from_json(r#"{"robot": {"motors": {"stiffness": 2e4}}}"#).unwrap();
        assert_eq!(config.robot.motors.stiffness, 2e4);
        assert_eq!(config.robot.motors.damping, 400.0);
        let err = SimConfig::from_json(r#"{"robot": {"weight": 0.2}}"#).unwrap_err();
        assert!(err.to_string().contains("weight"), "{err}");
        // `substeps` is the environment's to derive, not a solver setting.
        let err = SimConfig::from_json(r#"{"physics": {"solver": {"substeps": 2}}}"#).unwrap_err();
        assert!(err.to_string().contains("substeps"), "{err}");
    }

    #[test]
    fn objects_name_their_fields_under_the_given_prefix() {
        let cube = CubeConfig {
            mass: -1.0,
            ..CubeConfig::default()
        };
        match cube.validate("task.cube") {
            Err(Error::InvalidConfig { field, .. }) => assert_eq!(field, "task.cube.mass"),
            other => panic!("{other:?}"),
        }
        let mut platform = PlatformConfig::default();
        platform.size[1] = 0.0;
        match platform.validate("task.platform") {
            Err(Error::InvalidConfig { field, .. }) => assert_eq!(field, "task.platform.size[1]"),
            other => panic!("{other:?}"),
        }
    }
}
