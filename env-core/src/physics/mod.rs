//! The simulation: the only module that talks to rapier.
//!
//! A [`Simulation`] holds one physics world: the floor, the [`Scene`] a task asks for (the
//! platform and the movable objects, reached through [`ObjectId`]s) and a robot built from a
//! [`RobotModel`], its arm either a rapier multibody with joint motors or placed along its joint
//! trajectory ([`crate::ArmFidelity`]). Everything it hands out is in f64 nalgebra types; rapier's
//! types stay inside. Its public surface, by concern (one file each):
//!
//! | concern | file | what |
//! |---|---|---|
//! | building | `build.rs` | [`Simulation::new`], [`Simulation::with_model`], [`Simulation::with_scene`] |
//! | scene | `scene.rs` | [`Scene`], [`ObjectSpec`], [`ObjectId`]; object poses and properties; the `attach` shortcut grasp |
//! | articulated objects | `articulation.rs` | [`ArticulationSpec`], [`ArticulationId`]: URDF objects with joints (a cabinet's drawer) |
//! | shapes | `shape.rs` | [`ObjectShape`], [`ShapePart`]: boxes, spheres, cylinders, capsules, hulls, compounds |
//! | control | `control.rs` | [`JointControl`]; joint commands, the gripper, teleporting the robot |
//! | state | `state.rs` | [`BodyState`], [`JointState`], [`LinkState`]; joints, links, TCP, objects |
//! | contacts | `contacts.rs` | [`ObjectContacts`], [`ObjectTouch`]: what touches an object |
//! | touch | `touch.rs` | [`TouchReading`], [`FingerTouch`], [`Wrench`]: finger contact forces, the wrist's force-torque reading |
//! | visuals | `visuals.rs` | [`VisualPrimitive`]: every collider's shape and pose, for renderers |
//! | snapshots | `snapshot.rs` | [`SimSnapshot`]: save and restore the whole state |
//! | kinematic arm | `kinematic_arm.rs` | the placed arm of [`crate::ArmFidelity::Kinematic`] |
//!
//! Stepping ([`Simulation::step`], [`Simulation::step_control`]) and the blow-up checks
//! ([`Simulation::max_body_speeds`], [`Simulation::is_finite`]) are here.

mod articulation;
mod build;
mod contacts;
mod control;
mod convert;
mod grasp;
mod kinematic_arm;
mod mesh;
mod scene;
mod shape;
mod snapshot;
mod state;
mod touch;
mod visuals;

use nalgebra::Isometry3;
use rapier3d::dynamics::{
    ImpulseJointHandle, JointAxis, Multibody, MultibodyIndex, RigidBodyHandle,
};
use rapier3d::geometry::{ColliderHandle, Group};
use rapier3d::pipeline::PhysicsWorld;

use crate::config::SimConfig;
use crate::model::RobotModel;
use crate::robot::Gripper;

pub use articulation::{ArticulationId, ArticulationJoints, ArticulationSpec, IMPULSE_STICK_SPEED};
pub use contacts::{ObjectContacts, ObjectTouch, PairContact};
pub use control::JointControl;
pub use grasp::{GripperGeometry, TopGrasp};
use kinematic_arm::KinematicArm;
pub use mesh::{Decomposition, LoadedMesh, MeshCollision, MeshFile, ShapeCache};
pub use scene::{ObjectId, ObjectSpec, Scene};
pub use shape::{ObjectShape, ShapePart};
pub use snapshot::SimSnapshot;
pub use state::{BodyState, JointState, LinkState};
pub use touch::{FingerTouch, TouchReading, Wrench};
pub use visuals::{
    color_from_fractions, ObjectVisual, SharedMesh, TriangleMesh, VisualPart, VisualPrimitive,
    VisualShape, VisualTag,
};

const STATIC_GROUP: Group = Group::GROUP_1;
const OBJECT_GROUP: Group = Group::GROUP_2;
/// Links that cannot reach the floor or the platform (the base and the first link), so their
/// pairs with the scenery are never tested.
const PROXIMAL_GROUP: Group = Group::GROUP_3;
const ARM_GROUP: Group = Group::GROUP_4;

/// Where a joint of the model lives in the rapier multibody.
#[derive(Debug, Clone, Copy)]
struct DofSlot {
    /// Multibody link id of the joint's child body.
    link_id: usize,
    /// Index of the joint's coordinate in the link joint's `coords()` (0 for a prismatic joint
    /// along its x axis, 3 for a revolute joint about it).
    coord: usize,
    /// The rapier joint axis the motor acts on.
    axis: JointAxis,
    /// Rigid body of the joint's child link, and of its parent link.
    child_body: RigidBodyHandle,
    parent_body: RigidBodyHandle,
}

/// How the arm is simulated ([`crate::ArmFidelity`]), with what each kind needs.
#[derive(Debug, Clone)]
enum Arm {
    /// The whole robot is one multibody with joint motors.
    Dynamic {
        /// The robot's multibody.
        multibody: MultibodyIndex,
    },
    /// The arm's links are placed along `arm`'s joint trajectory; the gripper (the fingers'
    /// parent link and the fingers) is a multibody of its own, welded to the last placed link.
    Kinematic {
        /// The gripper's multibody.
        gripper: MultibodyIndex,
        /// The trajectory.
        arm: KinematicArm,
    },
}

impl Arm {
    /// The multibody holding the actuated joints the physics integrates.
    fn multibody(&self) -> MultibodyIndex {
        match self {
            Arm::Dynamic { multibody } => *multibody,
            Arm::Kinematic { gripper, .. } => *gripper,
        }
    }
}

/// One object of the world.
#[derive(Debug, Clone)]
struct SceneObject {
    body: RigidBodyHandle,
    collider: ColliderHandle,
    /// A fixture (a fixed body).
    fixed: bool,
}

/// One physics world: the robot, the floor and a [`Scene`].
pub struct Simulation {
    config: SimConfig,
    scene: Scene,
    model: RobotModel,
    base: Isometry3<f64>,
    world: PhysicsWorld,
    arm: Arm,
    gripper: Option<Gripper>,
    /// Rigid body of each model link that has one (frame-only links are folded into a parent).
    link_bodies: Vec<Option<RigidBodyHandle>>,
    /// Collider friction of each model link.
    link_friction: Vec<f64>,
    /// Multibody slot of each model joint; `None` for fixed joints.
    joint_slots: Vec<Option<DofSlot>>,
    /// Current command of each actuated joint (indexed by dof).
    controls: Vec<JointControl>,
    /// Every joint that moves (actuated and mimic), in joint order.
    movable_joints: Vec<usize>,
    robot_colliders: Vec<(ColliderHandle, usize)>,
    /// The scene's objects, in [`Scene::objects`] order.
    objects: Vec<SceneObject>,
    /// The scene's articulated objects, in [`Scene::articulations`] order.
    articulations: Vec<articulation::SceneArticulation>,
    floor_collider: ColliderHandle,
    platform_collider: Option<ColliderHandle>,
    time: f64,
    steps: u64,
    /// Whether the last step applied joint torques as body forces (they must be cleared).
    torques_applied: bool,
    /// Objects held to the hand by a fixed joint ([`Simulation::attach`]), with the joint.
    attachments: Vec<(ObjectId, ImpulseJointHandle)>,
    /// The gripper's hand link first, then every link below it (empty without a gripper):
    /// the subtree the wrist reading weighs.
    hand_links: Vec<usize>,
    /// What the touch reading is computed from: the last control step's contact forces on
    /// the hand and its motion.
    touch_window: touch::TouchWindow,
}

impl std::fmt::Debug for Simulation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Simulation")
            .field("robot", &self.model.name())
            .field("time", &self.time)
            .field("steps", &self.steps)
            .finish_non_exhaustive()
    }
}

impl Simulation {
    /// The configuration this world was built from.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// What the world holds besides the robot and the floor.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The robot description (introspection, forward and inverse kinematics).
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// Pose of the robot's root link in the world.
    pub fn base_pose(&self) -> &Isometry3<f64> {
        &self.base
    }

    /// Simulated time since construction (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Physics steps taken since construction.
    pub fn physics_steps(&self) -> u64 {
        self.steps
    }

    /// The control period: `dt * substeps` (s).
    pub fn control_period(&self) -> f64 {
        self.config.physics.solver.dt * self.config.substeps as f64
    }

    /// Advances the world by one physics step (`solver.dt`), added to the touch reading's
    /// window ([`Simulation::begin_touch_window`]).
    pub fn step(&mut self) {
        self.physics_step();
    }

    /// Advances the world by one control period (`solver.substeps` physics steps); the touch
    /// reading ([`Simulation::touch`]) then covers the period.
    pub fn step_control(&mut self) {
        self.begin_touch_window();
        for _ in 0..self.config.substeps {
            self.physics_step();
        }
    }

    /// One physics step, added to the touch window.
    fn physics_step(&mut self) {
        // (`step` and `step_control` differ in the window only.)
        if matches!(self.arm, Arm::Kinematic { .. }) {
            self.advance_kinematic_arm();
        } else {
            self.apply_joint_torques();
        }
        self.world.step();
        self.accumulate_touch();
        self.time += self.config.physics.solver.dt;
        self.steps += 1;
    }

    /// The largest linear (m/s) and angular (rad/s) speed of any body; NaN propagates, so a
    /// blown-up world reports NaN.
    pub fn max_body_speeds(&self) -> (f64, f64) {
        let mut linear = 0.0f32;
        let mut angular = 0.0f32;
        for (_, rb) in self.world.bodies.iter() {
            let v = rb.linvel().length();
            let w = rb.angvel().length();
            // `f32::max` drops NaN; keep it visible instead.
            linear = if v.is_nan() || v > linear { v } else { linear };
            angular = if w.is_nan() || w > angular {
                w
            } else {
                angular
            };
            if linear.is_nan() || angular.is_nan() {
                return (f64::NAN, f64::NAN);
            }
        }
        (linear as f64, angular as f64)
    }

    /// Whether every body's pose and velocity is finite.
    pub fn is_finite(&self) -> bool {
        self.world.bodies.iter().all(|(_, rb)| {
            let t = rb.translation();
            let v = rb.linvel();
            let w = rb.angvel();
            t.is_finite() && v.is_finite() && w.is_finite() && rb.rotation().is_finite()
        })
    }

    /// The multibody holding the joints the physics integrates (the whole robot for the
    /// dynamic arm, the gripper for the kinematic one). It lives as long as the world: the
    /// index is never removed.
    fn multibody(&self) -> &Multibody {
        self.world
            .multibody_joints
            .get_multibody(self.arm.multibody())
            .expect("the robot's multibody is never removed from its world")
    }

    /// The finger joints (the gripper's driving joint first); empty without a gripper.
    fn finger_joints(&self) -> &[usize] {
        self.gripper
            .as_ref()
            .map_or(&[][..], |g| g.finger_joints.as_slice())
    }
}
