//! Validated configuration of the simulated scene and the physics solver.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The physics engine's step and solver settings.
///
/// The defaults are the cheapest settings that keep the friction grasp honest (see
/// `tests/grasp_sequence.rs` for the slip bound they are held to).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverConfig {
    /// Physics time step in seconds.
    pub dt: f64,
    /// Physics steps per control step (`Simulation::step_control`); the control period is
    /// `dt * substeps` (default 0.01 s x 4 = 25 Hz).
    pub substeps: u32,
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
            substeps: 4,
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
    /// with the grasp's slip unchanged (`tests/grasp_sequence.rs`).
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

/// The fixed box the cube is carried to.
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

/// The dynamic cube that is picked and placed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CubeConfig {
    /// Edge length (m).
    pub size: f64,
    /// Mass (kg).
    pub mass: f64,
    /// Friction coefficient.
    pub friction: f64,
    /// Initial centre (m, world frame); the default rests on the floor in front of the robot.
    pub position: [f64; 3],
}

impl Default for CubeConfig {
    fn default() -> Self {
        Self {
            size: 0.05,
            mass: 0.1,
            friction: 1.0,
            position: [0.5, -0.15, 0.025],
        }
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

/// Everything needed to build a [`crate::Simulation`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// Fidelity of the arm's simulation.
    pub arm: ArmFidelity,
    /// Gravity (m/s^2).
    pub gravity: [f64; 3],
    /// Robot description; `None` uses the bundled Panda (`assets/panda/panda.urdf`).
    pub robot_urdf: Option<PathBuf>,
    /// Position of the robot's root link (m).
    pub robot_base: [f64; 3],
    /// Initial arm configuration, one entry per actuated joint; `None` uses the Panda's ready
    /// pose (hand pointing down, gripper open) or zeros for other robots.
    pub initial_configuration: Option<Vec<f64>>,
    /// Friction coefficient of the finger pads.
    pub finger_friction: f64,
    /// Friction coefficient of the other robot links.
    pub robot_friction: f64,
    /// Friction coefficient of the floor.
    pub floor_friction: f64,
    /// Viscous damping (N m s/rad or N s/m) of every movable joint of the dynamic arm and the
    /// gripper, in place of the URDF's `<dynamics damping>`; `None` uses the URDF's, 0 where
    /// it has none (the bundled Panda has none). A passive term beside the motors: position and
    /// velocity control have their own damping (`motors`).
    pub joint_damping: Option<f64>,
    /// Coulomb friction (N m or N) of every movable joint, in place of the URDF's `<dynamics
    /// friction>`; `None` uses the URDF's, 0 where absent.
    pub joint_friction: Option<f64>,
    /// Solver settings.
    pub solver: SolverConfig,
    /// Joint motor gains.
    pub motors: MotorConfig,
    /// The platform.
    pub platform: PlatformConfig,
    /// The cube.
    pub cube: CubeConfig,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            arm: ArmFidelity::Dynamic,
            gravity: [0.0, 0.0, -9.81],
            robot_urdf: None,
            robot_base: [0.0, 0.0, 0.0],
            initial_configuration: None,
            finger_friction: 1.0,
            robot_friction: 0.5,
            floor_friction: 1.0,
            joint_damping: None,
            joint_friction: None,
            solver: SolverConfig::default(),
            motors: MotorConfig::default(),
            platform: PlatformConfig::default(),
            cube: CubeConfig::default(),
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
        finite3("gravity", self.gravity)?;
        finite3("robot_base", self.robot_base)?;
        if let Some(q) = &self.initial_configuration {
            if let Some(bad) = q.iter().find(|v| !v.is_finite()) {
                return Err(invalid(
                    "initial_configuration",
                    format!("must be finite, got {bad}"),
                ));
            }
        }
        non_negative("finger_friction", self.finger_friction)?;
        non_negative("robot_friction", self.robot_friction)?;
        non_negative("floor_friction", self.floor_friction)?;
        if let Some(d) = self.joint_damping {
            non_negative("joint_damping", d)?;
        }
        if let Some(f) = self.joint_friction {
            non_negative("joint_friction", f)?;
        }

        let s = &self.solver;
        positive("solver.dt", s.dt)?;
        if s.dt > 0.05 {
            return Err(invalid(
                "solver.dt",
                format!("must be <= 0.05 s, got {}", s.dt),
            ));
        }
        if s.substeps == 0 || s.substeps > 10_000 {
            return Err(invalid(
                "solver.substeps",
                format!("must be in 1..=10000, got {}", s.substeps),
            ));
        }
        if s.solver_iterations == 0 || s.solver_iterations > 100 {
            return Err(invalid(
                "solver.solver_iterations",
                format!("must be in 1..=100, got {}", s.solver_iterations),
            ));
        }
        positive(
            "solver.contact_natural_frequency",
            s.contact_natural_frequency,
        )?;
        positive("solver.contact_damping_ratio", s.contact_damping_ratio)?;
        positive("solver.length_unit", s.length_unit)?;
        positive(
            "solver.contact_prediction_distance",
            s.contact_prediction_distance,
        )?;
        if s.contact_prediction_distance > 1.0 {
            return Err(invalid(
                "solver.contact_prediction_distance",
                format!("must be at most 1 m, got {}", s.contact_prediction_distance),
            ));
        }

        let m = &self.motors;
        positive("motors.stiffness", m.stiffness)?;
        non_negative("motors.damping", m.damping)?;
        positive("motors.velocity_damping", m.velocity_damping)?;
        non_negative("motors.gripper_force", m.gripper_force)?;
        positive("motors.gripper_stiffness", m.gripper_stiffness)?;
        non_negative("motors.gripper_damping", m.gripper_damping)?;
        non_negative("motors.arm_armature", m.arm_armature)?;
        non_negative("motors.finger_armature", m.finger_armature)?;
        positive("motors.kinematic_acceleration", m.kinematic_acceleration)?;

        let p = &self.platform;
        finite3("platform.top_center", p.top_center)?;
        for (i, &v) in p.size.iter().enumerate() {
            positive(&format!("platform.size[{i}]"), v)?;
        }
        non_negative("platform.friction", p.friction)?;
        if p.top_center[2] - p.size[2] < -1e-9 {
            return Err(invalid(
                "platform",
                format!(
                    "extends below the floor: top at z = {} with height {}",
                    p.top_center[2], p.size[2]
                ),
            ));
        }

        let c = &self.cube;
        positive("cube.size", c.size)?;
        positive("cube.mass", c.mass)?;
        non_negative("cube.friction", c.friction)?;
        finite3("cube.position", c.position)?;
        if c.size > 0.08 {
            return Err(invalid(
                "cube.size",
                format!("must fit the gripper's 0.08 m opening, got {}", c.size),
            ));
        }
        Ok(())
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
            ("cube.mass", Box::new(|c| c.cube.mass = -1.0)),
            ("cube.size", Box::new(|c| c.cube.size = f64::NAN)),
            ("solver.dt", Box::new(|c| c.solver.dt = 0.0)),
            ("solver.substeps", Box::new(|c| c.solver.substeps = 0)),
            (
                "solver.contact_prediction_distance",
                Box::new(|c| c.solver.contact_prediction_distance = f64::NAN),
            ),
            (
                "solver.contact_prediction_distance",
                Box::new(|c| c.solver.contact_prediction_distance = 2.0),
            ),
            ("platform.size[1]", Box::new(|c| c.platform.size[1] = 0.0)),
            ("gravity", Box::new(|c| c.gravity[2] = f64::INFINITY)),
            ("motors.stiffness", Box::new(|c| c.motors.stiffness = 0.0)),
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
        let config = SimConfig::from_json(r#"{"cube": {"mass": 0.2}}"#).unwrap();
        assert_eq!(config.cube.mass, 0.2);
        assert_eq!(config.cube.size, 0.05);
        let err = SimConfig::from_json(r#"{"cube": {"weight": 0.2}}"#).unwrap_err();
        assert!(err.to_string().contains("weight"), "{err}");
    }
}
