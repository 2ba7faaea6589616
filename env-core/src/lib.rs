//! # panda-rapier-core
//!
//! The simulation core of panda_rapier: a Franka Panda on a fixed base, a platform and a cube,
//! simulated with rapier3d, with a friction grasp (no attachment constraint), joint position,
//! velocity and torque control, and forward/inverse kinematics as pure functions of the joint
//! configuration.
//!
//! - [`RobotModel`]: the robot description read from a URDF (introspection, kinematics).
//! - [`RobotSpec`]: the robot of an environment without a world (gripper, start pose, controller).
//! - [`Simulation`]: one physics world; the only type that talks to rapier.
//! - [`SimConfig`]: validated, serde-deserialisable configuration.
//! - [`Task`]: what differs between tasks ([`task::PickAndPlace`] is the first).
//! - [`PandaEnv`] / [`EnvConfig`]: one environment running a task.
//! - [`PandaVecEnv`]: many environments stepped in parallel into contiguous buffers.
//! - [`Error`]: every failure, typed.

pub mod assets;
pub mod config;
pub mod dynamics;
pub mod env;
pub mod error;
pub mod kinematics;
pub mod model;
pub mod physics;
pub mod robot;
pub mod sensor;
pub mod task;
pub mod urdf_object;
pub mod vector;

pub use config::{
    ArmFidelity, CubeConfig, MotorConfig, MultibodyUpdate, PhysicsConfig, PlatformConfig,
    RobotConfig, SimConfig, SolverConfig,
};
pub use env::{
    ControlMode, Controller, EeController, EeFrame, EnvConfig, EnvSnapshot, OscConfig, PandaEnv,
};
pub use error::{Error, Result};
pub use kinematics::{pointing_down, IkOptions, IkReport, IkSolution, IkWorkspace};
pub use model::{JointInfo, JointType, LinkInfo, Mimic, RobotModel, Tcp};
pub use physics::{
    ArticulationId, ArticulationJoints, ArticulationSpec, BodyState, Decomposition, FingerTouch,
    GripperGeometry, JointControl, JointState, LinkState, LoadedMesh, MeshCollision, MeshFile,
    ObjectContacts, ObjectId, ObjectShape, ObjectSpec, ObjectTouch, ObjectVisual, PairContact,
    Scene, ShapeCache, ShapePart, SharedMesh, SimSnapshot, Simulation, TopGrasp, TouchReading,
    TriangleMesh, VisualPart, VisualPrimitive, VisualShape, VisualTag, Wrench,
};
pub use robot::panda::READY as PANDA_READY;
#[allow(deprecated)]
pub use robot::Robot;
pub use robot::{Gripper, RobotSpec};
pub use sensor::{Sensor, SensorChain, TouchSensor};
pub use task::{ObservationLayout, ResetOptions, RewardType, StepInfo, Task, TaskKind, Transition};
pub use urdf_object::UrdfObject;
pub use vector::{AutoresetMode, PandaVecEnv};

/// Re-exported so users can name the math types of the API without a second nalgebra.
pub use nalgebra;
