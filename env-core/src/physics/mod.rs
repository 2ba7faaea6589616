//! The simulation: the only module that talks to rapier.
//!
//! Over 600 lines: building, control, state, contacts, visuals and snapshots still live here
//! together; splitting them by concern is the architecture issue's first step.
//!
//! A [`Simulation`] holds one physics world with a floor, a fixed platform, a dynamic cube and a
//! robot built from a [`RobotModel`] as a rapier multibody (reduced coordinates) with joint
//! motors. Everything it hands out is in f64 nalgebra types; rapier's types stay inside.

mod convert;
mod kinematic_arm;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rapier3d::dynamics::{
    FixedJointBuilder, ImpulseJointSet, IslandManager, JointAxis, MotorModel, MultibodyDofCoupling,
    MultibodyIndex, MultibodyJointSet, RigidBodyBuilder, RigidBodyHandle, RigidBodySet,
    RigidBodyType,
};
use rapier3d::geometry::{
    BroadPhaseBvh, ColliderBuilder, ColliderHandle, ColliderSet, Group, InteractionGroups,
    MeshConverter, NarrowPhase, SharedShape,
};
use rapier3d::math::Vector;
use rapier3d::pipeline::PhysicsWorld;
use rapier3d_urdf::{
    UrdfColliderHandle, UrdfJoint, UrdfLinkHandle, UrdfLoaderOptions, UrdfMultibodyOptions,
    UrdfRobot,
};

use crate::config::{ArmModel, MultibodyUpdate, SimConfig, PANDA_READY};
use crate::error::{ensure_all_finite, ensure_finite, ensure_len, Error, Result};
use crate::model::{JointType, RobotModel};
use convert::{pose_from_na, pose_to_na, vec_from_array, vec_from_na, vec_to_na};

/// How one actuated joint is driven.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointControl {
    /// Drive to `target` (rad or m, clamped into the joint limits) with a PD motor, optionally
    /// tracking `target_velocity`, using at most `max_force` (`None`: the joint's effort limit).
    Position {
        /// Target position.
        target: f64,
        /// Velocity feed-forward (rad/s or m/s).
        target_velocity: f64,
        /// Force or torque limit.
        max_force: Option<f64>,
    },
    /// Drive to `target` velocity using at most `max_force` (`None`: the effort limit).
    Velocity {
        /// Target velocity.
        target: f64,
        /// Force or torque limit.
        max_force: Option<f64>,
    },
    /// Apply this joint torque (N m) or force (N), clamped to the effort limit; the motor is
    /// switched off.
    Torque(f64),
}

impl JointControl {
    /// Position control at the joint's effort limit.
    pub fn position(target: f64) -> Self {
        JointControl::Position {
            target,
            target_velocity: 0.0,
            max_force: None,
        }
    }

    /// Velocity control at the joint's effort limit.
    pub fn velocity(target: f64) -> Self {
        JointControl::Velocity {
            target,
            max_force: None,
        }
    }

    fn validate(&self, joint: &str) -> Result<()> {
        let check_force = |f: Option<f64>| -> Result<()> {
            if let Some(f) = f {
                ensure_finite(|| format!("max_force of joint `{joint}`"), f)?;
                if f < 0.0 {
                    return Err(Error::InvalidConfig {
                        field: format!("max_force of joint `{joint}`"),
                        reason: format!("must be >= 0, got {f}"),
                    });
                }
            }
            Ok(())
        };
        match *self {
            JointControl::Position {
                target,
                target_velocity,
                max_force,
            } => {
                ensure_finite(|| format!("position target of joint `{joint}`"), target)?;
                ensure_finite(
                    || format!("target velocity of joint `{joint}`"),
                    target_velocity,
                )?;
                check_force(max_force)
            }
            JointControl::Velocity { target, max_force } => {
                ensure_finite(|| format!("velocity target of joint `{joint}`"), target)?;
                check_force(max_force)
            }
            JointControl::Torque(t) => {
                ensure_finite(|| format!("torque of joint `{joint}`"), t).map(|_| ())
            }
        }
    }
}

/// Pose and velocity of a body, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    /// Position of the body frame's origin (m).
    pub position: Vector3<f64>,
    /// Orientation.
    pub orientation: UnitQuaternion<f64>,
    /// Velocity of the body frame's origin (m/s).
    pub linear_velocity: Vector3<f64>,
    /// Angular velocity (rad/s).
    pub angular_velocity: Vector3<f64>,
}

/// State and physical properties of one robot link.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkState {
    /// Link index (as in [`RobotModel::links`]).
    pub index: usize,
    /// Link name.
    pub name: String,
    /// Mass (kg) from the robot description.
    pub mass: f64,
    /// Friction coefficient of the link's colliders (0 when it has none).
    pub friction: f64,
    /// Number of colliders attached to the link (primitives, or convex hulls of meshes).
    pub num_colliders: usize,
    /// Pose and velocity of the link frame.
    pub state: BodyState,
}

/// Position and velocity of one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointState {
    /// Position (rad or m).
    pub position: f64,
    /// Velocity (rad/s or m/s).
    pub velocity: f64,
}

/// What the cube is touching right now.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CubeContacts {
    /// Robot links (indices into [`RobotModel::links`]) with an active contact.
    pub robot_links: Vec<usize>,
    /// Normal contact force (N) each of those links pushes the cube with, in the same order.
    pub robot_forces: Vec<f64>,
    /// Touching the floor.
    pub floor: bool,
    /// Touching the platform.
    pub platform: bool,
}

/// What touches the cube right now, without allocating (read every control step).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CubeTouch {
    /// Normal force (N) from each finger (the gripper's driving joint's finger first); 0 when
    /// not touching. Robots with one finger report 0 for the second.
    pub finger_forces: [f64; 2],
    /// Normal force (N) from robot links other than the fingers.
    pub other_robot_force: f64,
    /// Touching the floor.
    pub floor: bool,
    /// Touching the platform.
    pub platform: bool,
}

impl CubeTouch {
    /// Whether any robot link touches the cube.
    pub fn robot_touching(&self) -> bool {
        self.finger_forces.iter().any(|&f| f > 0.0) || self.other_robot_force > 0.0
    }
}

/// A collider's shape in its own frame, for drawing: renderer-neutral, so no renderer needs
/// rapier's types.
#[derive(Debug, Clone, PartialEq)]
pub enum VisualShape {
    /// A box centred on the origin.
    Box {
        /// Half the side lengths along x, y and z (m).
        half_extents: Vector3<f64>,
    },
    /// A sphere centred on the origin.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A capsule along z, centred on the origin: the segment from `-half_height` to
    /// `+half_height`, swept by a sphere.
    Capsule {
        /// Half the length of the central segment (m).
        half_height: f64,
        /// Radius (m).
        radius: f64,
    },
    /// A cylinder along z, centred on the origin.
    Cylinder {
        /// Half the height (m).
        half_height: f64,
        /// Radius (m).
        radius: f64,
    },
    /// A convex mesh (a convex hull of a mesh collider).
    ConvexMesh {
        /// Vertices (m).
        vertices: Vec<Vector3<f64>>,
        /// Triangles as indices into `vertices`.
        triangles: Vec<[u32; 3]>,
    },
    /// The unbounded plane z = 0, facing +z (the floor).
    Plane,
}

/// What a [`VisualPrimitive`] belongs to, so a renderer can pick its material.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VisualTag {
    /// The floor.
    Floor,
    /// The platform the cube is placed on.
    Platform,
    /// The cube.
    Cube,
    /// A robot link (index into [`RobotModel::links`]).
    RobotLink {
        /// Link index.
        link: usize,
        /// Whether the link is a finger of the gripper.
        finger: bool,
    },
}

/// One collider as it is now: its shape, world pose and owner.
#[derive(Debug, Clone, PartialEq)]
pub struct VisualPrimitive {
    /// Shape in the primitive's frame.
    pub shape: VisualShape,
    /// World pose of the primitive's frame.
    pub pose: Isometry3<f64>,
    /// What it belongs to.
    pub tag: VisualTag,
}

/// Everything that decides how a [`Simulation`] continues: bodies, colliders, joints, contact
/// and broad-phase caches, motor commands and the clock. Restoring it with
/// [`Simulation::restore`] continues bit-identically to the moment it was taken.
#[derive(Clone)]
pub struct SimSnapshot {
    config: SimConfig,
    islands: IslandManager,
    broad_phase: BroadPhaseBvh,
    narrow_phase: NarrowPhase,
    bodies: RigidBodySet,
    colliders: ColliderSet,
    impulse_joints: ImpulseJointSet,
    multibody_joints: MultibodyJointSet,
    kinematic: Option<KinematicArm>,
    controls: Vec<JointControl>,
    torques_applied: bool,
    time: f64,
    steps: u64,
}

impl std::fmt::Debug for SimSnapshot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimSnapshot")
            .field("time", &self.time)
            .field("steps", &self.steps)
            .finish_non_exhaustive()
    }
}

/// One body the cube touches, as `Simulation::for_each_cube_contact` reports it.
enum CubeContact {
    Floor,
    Platform,
    /// A robot link (index into the model's links) and its normal force (N).
    Robot {
        link: usize,
        force: f64,
    },
}

const STATIC_GROUP: Group = Group::GROUP_1;
const CUBE_GROUP: Group = Group::GROUP_2;
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

/// The arm of [`ArmModel::Kinematic`]: the joint trajectory its links follow.
#[derive(Debug, Clone)]
struct KinematicArm {
    /// Position and velocity of every actuated dof (the gripper's entries are unused: the
    /// fingers are dynamic).
    q: Vec<f64>,
    qd: Vec<f64>,
    /// Physics steps whose arm motion was refused because a link would enter the scenery.
    blocked_steps: u64,

    /// Scratch space, so stepping does not allocate.
    q_next: Vec<f64>,
    joint_positions: Vec<f64>,
    link_poses: Vec<Isometry3<f64>>,
}

/// One physics world: the robot, the floor, the platform and the cube.
pub struct Simulation {
    config: SimConfig,
    model: RobotModel,
    base: Isometry3<f64>,
    world: PhysicsWorld,
    /// The arm's multibody ([`ArmModel::Dynamic`]).
    multibody: Option<MultibodyIndex>,
    /// The arm's trajectory ([`ArmModel::Kinematic`]).
    kinematic: Option<KinematicArm>,
    /// Rigid body of each model link that has one (frame-only links are folded into a parent).
    link_bodies: Vec<Option<RigidBodyHandle>>,
    /// Collider friction of each model link.
    link_friction: Vec<f64>,
    /// Multibody slot of each model joint; `None` for fixed joints.
    joint_slots: Vec<Option<DofSlot>>,
    /// Current command of each actuated joint (indexed by dof).
    controls: Vec<JointControl>,
    /// The gripper's driving joint (index into joints), when the robot has one.
    gripper_joint: Option<usize>,
    /// The gripper's driving joint followed by the joints mimicking it (one per finger).
    finger_joints: Vec<usize>,
    /// Child link of each finger joint, in the same order.
    finger_links: Vec<usize>,
    /// Every joint that moves (actuated and mimic), in joint order.
    movable_joints: Vec<usize>,
    robot_colliders: Vec<(ColliderHandle, usize)>,
    cube: RigidBodyHandle,
    cube_collider: ColliderHandle,
    floor_collider: ColliderHandle,
    platform_collider: ColliderHandle,
    time: f64,
    steps: u64,
    /// Whether the last step applied joint torques as body forces (they must be cleared).
    torques_applied: bool,
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
    /// Builds the world described by `config` (the bundled Panda unless `robot_urdf` is set).
    pub fn new(config: SimConfig) -> Result<Self> {
        config.validate()?;
        let model = match &config.robot_urdf {
            Some(path) => RobotModel::from_urdf_file(path)?,
            None => RobotModel::panda()?,
        };
        Self::with_model(config, model)
    }

    /// Builds the world around an already loaded robot description.
    pub fn with_model(config: SimConfig, model: RobotModel) -> Result<Self> {
        config.validate()?;
        let mut world = PhysicsWorld::new();
        world.gravity = vec_from_array(config.gravity);
        let p = &mut world.integration_parameters;
        let s = &config.solver;
        p.dt = s.dt as f32;
        p.num_solver_iterations = s.solver_iterations as usize;
        p.multibody_update = match s.multibody_update {
            MultibodyUpdate::Step => rapier3d::dynamics::MultibodyUpdate::Step,
            MultibodyUpdate::Substep => rapier3d::dynamics::MultibodyUpdate::Substep,
        };
        p.length_unit = s.length_unit as f32;
        p.contact_softness.natural_frequency = s.contact_natural_frequency as f32;
        p.contact_softness.damping_ratio = s.contact_damping_ratio as f32;
        // Stale recycled contacts let the fingers "hold" the cube 7-8 mm short of touching it,
        // and without friction in the bias pass a squeezed cube creeps out of the grip.
        p.contact_recycling = false;
        p.friction_in_bias_pass = true;
        // The kinematic arm's weld between its last placed link and the gripper is an impulse
        // joint; restarting from zero impulse every substep it would sag under the load.
        p.warmstart_joints = true;

        let base = Isometry3::translation(
            config.robot_base[0],
            config.robot_base[1],
            config.robot_base[2],
        );

        // Scenery.
        let floor_body = world.bodies.insert(RigidBodyBuilder::fixed().build());
        let floor_collider = world.colliders.insert_with_parent(
            ColliderBuilder::halfspace(nalgebra::Unit::new_unchecked(Vector::Z))
                .friction(config.floor_friction as f32)
                .collision_groups(InteractionGroups::new(
                    STATIC_GROUP,
                    CUBE_GROUP | ARM_GROUP,
                    Default::default(),
                ))
                .build(),
            floor_body,
            &mut world.bodies,
        );
        let pc = &config.platform;
        let platform_body = world.bodies.insert(
            RigidBodyBuilder::fixed()
                .translation(vec_from_array([
                    pc.top_center[0],
                    pc.top_center[1],
                    pc.top_center[2] - pc.size[2] / 2.0,
                ]))
                .build(),
        );
        let platform_collider = world.colliders.insert_with_parent(
            ColliderBuilder::cuboid(
                (pc.size[0] / 2.0) as f32,
                (pc.size[1] / 2.0) as f32,
                (pc.size[2] / 2.0) as f32,
            )
            .friction(pc.friction as f32)
            .collision_groups(InteractionGroups::new(
                STATIC_GROUP,
                CUBE_GROUP | ARM_GROUP,
                Default::default(),
            ))
            .build(),
            platform_body,
            &mut world.bodies,
        );

        // The cube.
        let cc = &config.cube;
        let cube = world.bodies.insert(
            RigidBodyBuilder::dynamic()
                .translation(vec_from_array(cc.position))
                .can_sleep(false)
                .build(),
        );
        let half = (cc.size / 2.0) as f32;
        let cube_collider = world.colliders.insert_with_parent(
            ColliderBuilder::cuboid(half, half, half)
                .mass(cc.mass as f32)
                .friction(cc.friction as f32)
                .collision_groups(InteractionGroups::new(
                    CUBE_GROUP,
                    Group::ALL,
                    Default::default(),
                ))
                .build(),
            cube,
            &mut world.bodies,
        );

        // The robot, as one multibody.
        let options = UrdfLoaderOptions {
            make_roots_fixed: true,
            shift: pose_from_na(&base),
            rigid_body_blueprint: RigidBodyBuilder::dynamic().can_sleep(false),
            // Mesh colliders on moving links must be convex to collide with the cube.
            mesh_converter: Some(MeshConverter::ConvexHull),
            ..Default::default()
        };
        let gripper_joint = find_gripper_joint(&model);
        // The gripper's driving joint and the joints mimicking it: one per finger.
        let finger_joints: Vec<usize> = model
            .joints()
            .iter()
            .filter(|j| {
                gripper_joint
                    .is_some_and(|g| j.index == g || j.mimic.is_some_and(|m| m.master == g))
            })
            .map(|j| j.index)
            .collect();
        let finger_links: Vec<usize> = finger_joints
            .iter()
            .map(|&j| model.joints()[j].child_link_index)
            .collect();
        let proximal = proximal_links(&model);
        let movable_joints: Vec<usize> = model
            .joints()
            .iter()
            .filter(|j| j.joint_type.is_movable())
            .map(|j| j.index)
            .collect();

        let urdf_robot = UrdfRobot::from_robot(model.urdf(), options, std::path::Path::new("/"));
        let link_sources: Vec<usize> = urdf_robot.links.iter().map(|l| l.urdf_link_index).collect();
        let (link_handles, link_sources, joint_slots, multibody, kinematic) = match config.arm {
            ArmModel::Dynamic => {
                let (handles, joint_slots, multibody) = insert_multibody(
                    &mut world,
                    urdf_robot,
                    &model,
                    &config,
                    &finger_joints,
                    |_| true,
                )?;
                (
                    handles.links,
                    link_sources,
                    joint_slots,
                    Some(multibody),
                    None,
                )
            }
            ArmModel::Kinematic => {
                let built = build_kinematic_arm(
                    &mut world,
                    &model,
                    &config,
                    urdf_robot,
                    gripper_joint,
                    &finger_joints,
                )?;
                (
                    built.links,
                    built.link_sources,
                    built.joint_slots,
                    Some(built.multibody),
                    Some(built.arm),
                )
            }
        };

        let mut link_bodies = vec![None; model.links().len()];
        let mut link_friction = vec![0.0; model.links().len()];
        let mut robot_colliders = Vec::new();
        for (handle, &link) in link_handles.iter().zip(&link_sources) {
            link_bodies[link] = Some(handle.body);
            let friction = if finger_links.contains(&link) {
                config.finger_friction
            } else {
                config.robot_friction
            };
            link_friction[link] = friction;
            let groups = if proximal.contains(&link) {
                InteractionGroups::new(PROXIMAL_GROUP, CUBE_GROUP, Default::default())
            } else {
                InteractionGroups::new(ARM_GROUP, CUBE_GROUP | STATIC_GROUP, Default::default())
            };
            for c in &handle.colliders {
                if let Some(collider) = world.colliders.get_mut(c.handle) {
                    collider.set_friction(friction as f32);
                    collider.set_collision_groups(groups);
                }
                robot_colliders.push((c.handle, link));
            }
        }

        let controls = vec![JointControl::position(0.0); model.num_dofs()];
        let mut sim = Self {
            config,
            model,
            base,
            world,
            multibody,
            kinematic,
            link_bodies,
            link_friction,
            joint_slots,
            controls,
            gripper_joint,
            finger_joints,
            finger_links,
            movable_joints,
            robot_colliders,
            cube,
            cube_collider,
            floor_collider,
            platform_collider,
            time: 0.0,
            steps: 0,
            torques_applied: false,
        };
        let q0 = match &sim.config.initial_configuration {
            Some(q) => q.clone(),
            None if sim.model.num_dofs() == PANDA_READY.len()
                && sim.model.joint_index("panda_joint1").is_ok() =>
            {
                PANDA_READY.to_vec()
            }
            None => vec![0.0; sim.model.num_dofs()],
        };
        if q0.len() != sim.model.num_dofs() {
            return Err(Error::InvalidConfig {
                field: "initial_configuration".into(),
                reason: format!(
                    "must have {} values (one per actuated joint), got {}",
                    sim.model.num_dofs(),
                    q0.len()
                ),
            });
        }
        sim.set_joint_positions(&q0)?;
        Ok(sim)
    }

    /// The configuration this world was built from.
    pub fn config(&self) -> &SimConfig {
        &self.config
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
        self.config.solver.dt * self.config.solver.substeps as f64
    }

    fn dof_joint(&self, dof: usize) -> usize {
        self.model.actuated_joints()[dof]
    }

    fn slot(&self, joint: usize) -> Option<DofSlot> {
        self.joint_slots.get(joint).copied().flatten()
    }

    fn read_joint(&self, joint: usize) -> JointState {
        if let Some(arm) = &self.kinematic {
            if !self.finger_joints.contains(&joint) {
                return self.read_kinematic_joint(arm, joint);
            }
        }
        let Some(slot) = self.slot(joint) else {
            return JointState {
                position: 0.0,
                velocity: 0.0,
            };
        };
        let Some(mb) = self
            .multibody
            .and_then(|m| self.world.multibody_joints.get_multibody(m))
        else {
            return JointState {
                position: f64::NAN,
                velocity: f64::NAN,
            };
        };
        match mb.link(slot.link_id) {
            Some(link) => JointState {
                position: link.joint().coords()[slot.coord] as f64,
                velocity: mb.joint_velocity(link)[0] as f64,
            },
            None => JointState {
                position: f64::NAN,
                velocity: f64::NAN,
            },
        }
    }

    /// Position and velocity of joint `index` (any joint; fixed joints read 0).
    pub fn joint_state(&self, index: usize) -> Result<JointState> {
        self.model.joint(index)?;
        Ok(self.read_joint(index))
    }

    /// Positions of the actuated joints: the configuration `q`.
    pub fn joint_positions(&self) -> Vec<f64> {
        (0..self.model.num_dofs())
            .map(|d| self.read_joint(self.dof_joint(d)).position)
            .collect()
    }

    /// Velocities of the actuated joints.
    pub fn joint_velocities(&self) -> Vec<f64> {
        (0..self.model.num_dofs())
            .map(|d| self.read_joint(self.dof_joint(d)).velocity)
            .collect()
    }

    /// Writes the configuration `q` into `out` (one entry per actuated joint) without allocating.
    pub fn joint_positions_into(&self, out: &mut [f64]) -> Result<()> {
        ensure_len("joint position buffer", self.model.num_dofs(), out.len())?;
        for (d, o) in out.iter_mut().enumerate() {
            *o = self.read_joint(self.dof_joint(d)).position;
        }
        Ok(())
    }

    /// Every joint that moves (actuated and mimic joints, e.g. both Panda fingers), in joint
    /// order: the joints [`Simulation::movable_joint_states_into`] reports.
    pub fn movable_joints(&self) -> &[usize] {
        &self.movable_joints
    }

    /// Positions and velocities of [`Simulation::movable_joints`], written without allocating.
    pub fn movable_joint_states_into(
        &self,
        positions: &mut [f64],
        velocities: &mut [f64],
    ) -> Result<()> {
        let n = self.movable_joints.len();
        ensure_len("joint position buffer", n, positions.len())?;
        ensure_len("joint velocity buffer", n, velocities.len())?;
        for (i, &j) in self.movable_joints.iter().enumerate() {
            let state = self.read_joint(j);
            positions[i] = state.position;
            velocities[i] = state.velocity;
        }
        Ok(())
    }

    /// Index into `q` of the gripper's driving joint, when the robot has a gripper.
    pub fn gripper_dof(&self) -> Option<usize> {
        self.gripper_joint.and_then(|j| self.model.joints()[j].dof)
    }

    /// The widest opening the fingers allow (m): the sum of the finger joints' upper limits.
    pub fn gripper_max_width(&self) -> f64 {
        self.finger_joints
            .iter()
            .map(|&j| self.model.joints()[j].upper)
            .sum()
    }

    /// Teleports the robot to configuration `q` (one value per actuated joint, clamped into
    /// the joint limits) at rest, and makes position control hold it. For resets.
    pub fn set_joint_positions(&mut self, q: &[f64]) -> Result<()> {
        self.model.validate_configuration(q)?;
        let mut q = q.to_vec();
        self.model.clamp_configuration(&mut q);
        let mut positions = vec![0.0; self.model.joints().len()];
        self.model.expand_positions(&q, &mut positions);

        // The kinematic arm's links (and the gripper's root, the hand) are put in place first;
        // the gripper's multibody then reads its root pose from the hand's body.
        let read_root = self.kinematic.is_some();
        self.teleport_kinematic_arm(&q);
        let Some(mb) = self
            .multibody
            .and_then(|m| self.world.multibody_joints.get_multibody_mut(m))
        else {
            return Ok(());
        };
        let mut displacement = vec![0.0f32; mb.ndofs()];
        for (joint, slot) in self.joint_slots.iter().enumerate() {
            let Some(slot) = slot else { continue };
            if let Some(link) = mb.link(slot.link_id) {
                let current = link.joint().coords()[slot.coord];
                displacement[link.assembly_id()] = positions[joint] as f32 - current;
            }
        }
        mb.apply_displacements(&displacement);
        mb.generalized_velocity_mut().fill(0.0);
        mb.forward_kinematics(&self.world.bodies, read_root);
        mb.update_rigid_bodies(&mut self.world.bodies, true);
        for body in self.link_bodies.iter().flatten() {
            if let Some(rb) = self.world.bodies.get_mut(*body) {
                rb.set_linvel(Vector::ZERO, true);
                rb.set_angvel(Vector::ZERO, true);
            }
        }
        for (dof, &target) in q.iter().enumerate() {
            self.controls[dof] = JointControl::position(target);
        }
        self.apply_motor_settings();
        Ok(())
    }

    fn actuated_dof(&self, joint: usize) -> Result<usize> {
        let info = self.model.joint(joint)?;
        match (info.dof, info.mimic) {
            (Some(d), _) => Ok(d),
            (None, Some(m)) => Err(Error::JointNotCommandable {
                name: info.name.clone(),
                reason: format!(
                    "it mimics `{}`; command that joint instead",
                    self.model.joints()[m.master].name
                ),
            }),
            (None, None) => Err(Error::JointNotCommandable {
                name: info.name.clone(),
                reason: "it is a fixed joint".into(),
            }),
        }
    }

    /// Sets how joint `index` (an index into [`RobotModel::joints`]) is driven from now on.
    pub fn set_joint_control(&mut self, index: usize, control: JointControl) -> Result<()> {
        let dof = self.actuated_dof(index)?;
        control.validate(&self.model.joints()[index].name)?;
        self.check_supported(&control, index)?;
        self.controls[dof] = control;
        self.apply_motor_settings();
        Ok(())
    }

    /// [`Simulation::set_joint_control`] by joint name.
    pub fn set_joint_control_by_name(&mut self, name: &str, control: JointControl) -> Result<()> {
        let index = self.model.joint_index(name)?;
        self.set_joint_control(index, control)
    }

    /// Sets the control of every actuated joint at once (one entry per entry of `q`).
    pub fn set_joint_controls(&mut self, controls: &[JointControl]) -> Result<()> {
        ensure_len("joint controls", self.model.num_dofs(), controls.len())?;
        for (dof, c) in controls.iter().enumerate() {
            c.validate(&self.model.joints()[self.dof_joint(dof)].name)?;
            self.check_supported(c, self.dof_joint(dof))?;
        }
        self.controls.copy_from_slice(controls);
        self.apply_motor_settings();
        Ok(())
    }

    /// Position control of every actuated joint to `targets` at the effort limits.
    pub fn set_position_targets(&mut self, targets: &[f64]) -> Result<()> {
        ensure_len("position targets", self.model.num_dofs(), targets.len())?;
        ensure_all_finite("position targets", targets)?;
        for (control, &t) in self.controls.iter_mut().zip(targets) {
            *control = JointControl::position(t);
        }
        self.apply_motor_settings();
        Ok(())
    }

    /// The current command of every actuated joint.
    pub fn joint_controls(&self) -> &[JointControl] {
        &self.controls
    }

    /// Drives the gripper to an opening of `width` metres (between the finger pads, clamped to
    /// the fingers' range) with a drive force of at most `force` newtons (`None`: the
    /// configured gripper force); the two coupled fingers share it, so closed on an object each
    /// presses with half. Closing on an object holds it by friction alone.
    pub fn set_gripper(&mut self, width: f64, force: Option<f64>) -> Result<()> {
        let joint = self
            .gripper_joint
            .ok_or_else(|| Error::JointNotCommandable {
                name: "gripper".into(),
                reason: "this robot has no prismatic finger joint".into(),
            })?;
        ensure_finite(|| "gripper width".into(), width)?;
        let force = force.unwrap_or(self.config.motors.gripper_force);
        // The opening is the sum of the finger joints' positions, all driven by `joint`.
        let gain: f64 = self
            .finger_joints
            .iter()
            .filter_map(|&j| self.model.joint_driver(j).map(|(_, g)| g))
            .sum();
        self.set_joint_control(
            joint,
            JointControl::Position {
                target: width / gain,
                target_velocity: 0.0,
                max_force: Some(force),
            },
        )
    }

    /// Opening between the finger pads (m); 0 for robots without a gripper.
    pub fn gripper_width(&self) -> f64 {
        self.finger_joints
            .iter()
            .map(|&j| self.read_joint(j).position)
            .sum()
    }

    /// Pushes the current controls into the rapier joint motors.
    fn apply_motor_settings(&mut self) {
        let motors = &self.config.motors;
        let Some(mb) = self
            .multibody
            .and_then(|m| self.world.multibody_joints.get_multibody_mut(m))
        else {
            return;
        };
        for (dof, control) in self.controls.iter().enumerate() {
            let joint = &self.model.joints()[self.model.actuated_joints()[dof]];
            let Some(slot) = self.joint_slots[joint.index] else {
                continue;
            };
            let Some(link) = mb.link_mut(slot.link_id) else {
                continue;
            };
            let effort = joint.max_force;
            let data = &mut link.joint.data;
            let is_gripper = Some(joint.index) == self.gripper_joint;
            match *control {
                JointControl::Position {
                    target,
                    target_velocity,
                    max_force,
                } => {
                    let (model, stiffness, damping) = if is_gripper {
                        (
                            MotorModel::ForceBased,
                            motors.gripper_stiffness,
                            motors.gripper_damping,
                        )
                    } else {
                        (
                            MotorModel::AccelerationBased,
                            motors.stiffness,
                            motors.damping,
                        )
                    };
                    data.set_motor_model(slot.axis, model);
                    data.set_motor(
                        slot.axis,
                        joint.clamp(target) as f32,
                        target_velocity as f32,
                        stiffness as f32,
                        damping as f32,
                    );
                    data.set_motor_max_force(slot.axis, max_force.unwrap_or(effort) as f32);
                }
                JointControl::Velocity { target, max_force } => {
                    data.set_motor_model(slot.axis, MotorModel::AccelerationBased);
                    data.set_motor(
                        slot.axis,
                        0.0,
                        target as f32,
                        0.0,
                        motors.velocity_damping as f32,
                    );
                    data.set_motor_max_force(slot.axis, max_force.unwrap_or(effort) as f32);
                }
                JointControl::Torque(_) => {
                    data.set_motor(slot.axis, 0.0, 0.0, 0.0, 0.0);
                    data.set_motor_max_force(slot.axis, 0.0);
                }
            }
        }
    }

    /// Joint torques of torque-controlled joints become equal and opposite body torques
    /// (forces for prismatic joints) on the joint's child and parent links.
    fn apply_joint_torques(&mut self) {
        let torque_control = self
            .controls
            .iter()
            .any(|c| matches!(c, JointControl::Torque(_)));
        // Touching a body marks it modified for rapier, which costs work and allocations every
        // step: leave the bodies alone unless torques are (or were last step) applied.
        if !torque_control && !self.torques_applied {
            return;
        }
        self.torques_applied = torque_control;
        for body in self.link_bodies.iter().flatten() {
            if let Some(rb) = self.world.bodies.get_mut(*body) {
                rb.reset_forces(false);
            }
        }
        for (dof, control) in self.controls.iter().enumerate() {
            let JointControl::Torque(torque) = *control else {
                continue;
            };
            let joint = &self.model.joints()[self.model.actuated_joints()[dof]];
            let Some(slot) = self.joint_slots[joint.index] else {
                continue;
            };
            let torque = torque.clamp(-joint.max_force.abs(), joint.max_force.abs());
            let Some(child) = self.world.bodies.get(slot.child_body) else {
                continue;
            };
            // Joint motion leaves the axis fixed in the child's frame, so the child link carries
            // it into world coordinates.
            let axis = child.rotation() * vec_from_na(&(joint.axis * torque));
            let prismatic = joint.joint_type == JointType::Prismatic;
            for (body, sign) in [(slot.child_body, 1.0f32), (slot.parent_body, -1.0)] {
                if let Some(rb) = self.world.bodies.get_mut(body) {
                    if prismatic {
                        rb.add_force(axis * sign, true);
                    } else {
                        rb.add_torque(axis * sign, true);
                    }
                }
            }
        }
    }

    /// Advances the world by one physics step (`solver.dt`).
    pub fn step(&mut self) {
        if self.kinematic.is_some() {
            self.advance_kinematic_arm();
        } else {
            self.apply_joint_torques();
        }
        self.world.step();
        self.time += self.config.solver.dt;
        self.steps += 1;
    }

    /// Advances the world by one control period (`solver.substeps` physics steps).
    pub fn step_control(&mut self) {
        for _ in 0..self.config.solver.substeps {
            self.step();
        }
    }

    fn body_state(&self, handle: RigidBodyHandle) -> BodyState {
        match self.world.bodies.get(handle) {
            Some(rb) => {
                let pose = pose_to_na(rb.position());
                BodyState {
                    position: pose.translation.vector,
                    orientation: pose.rotation,
                    linear_velocity: vec_to_na(rb.velocity_at_point(rb.translation())),
                    angular_velocity: vec_to_na(rb.angvel()),
                }
            }
            None => BodyState {
                position: Vector3::repeat(f64::NAN),
                orientation: UnitQuaternion::identity(),
                linear_velocity: Vector3::repeat(f64::NAN),
                angular_velocity: Vector3::repeat(f64::NAN),
            },
        }
    }

    /// Pose and velocity of link `index`. Frame-only links without a body of their own (such as
    /// the flange) are placed by the fixed transforms to their nearest ancestor with a body.
    pub(super) fn link_body_state(&self, index: usize) -> BodyState {
        let mut offset = Isometry3::identity();
        let mut link = index;
        loop {
            if let Some(handle) = self.link_bodies[link] {
                let body = self.body_state(handle);
                let pose =
                    Isometry3::from_parts(Translation3::from(body.position), body.orientation);
                let frame = pose * offset;
                let lever = frame.translation.vector - body.position;
                return BodyState {
                    position: frame.translation.vector,
                    orientation: frame.rotation,
                    linear_velocity: body.linear_velocity + body.angular_velocity.cross(&lever),
                    angular_velocity: body.angular_velocity,
                };
            }
            let Some(j) = self.model.links()[link].parent_joint else {
                // A root without a body: it is where the base was put.
                return BodyState {
                    position: (self.base * offset).translation.vector,
                    orientation: (self.base * offset).rotation,
                    linear_velocity: Vector3::zeros(),
                    angular_velocity: Vector3::zeros(),
                };
            };
            let position = self.read_joint(j).position;
            offset = self.model.joint_transform(j, position) * offset;
            link = self.model.joints()[j].parent_link_index;
        }
    }

    /// State of the link named `name`: pose, velocity, mass and friction.
    pub fn link_state(&self, name: &str) -> Result<LinkState> {
        let index = self.model.link_index(name)?;
        Ok(self.link_state_at(index))
    }

    fn link_state_at(&self, index: usize) -> LinkState {
        let info = &self.model.links()[index];
        LinkState {
            index,
            name: info.name.clone(),
            mass: info.mass,
            friction: self.link_friction[index],
            num_colliders: self
                .robot_colliders
                .iter()
                .filter(|(_, link)| *link == index)
                .count(),
            state: self.link_body_state(index),
        }
    }

    /// States of all links, in [`RobotModel::links`] order.
    pub fn link_states(&self) -> Vec<LinkState> {
        (0..self.model.links().len())
            .map(|i| self.link_state_at(i))
            .collect()
    }

    /// Pose and velocity of the tool centre point.
    pub fn tcp_state(&self) -> BodyState {
        let tcp = self.model.tcp();
        let link = self.link_body_state(tcp.link);
        let pose =
            Isometry3::from_parts(Translation3::from(link.position), link.orientation) * tcp.offset;
        let lever = pose.translation.vector - link.position;
        BodyState {
            position: pose.translation.vector,
            orientation: pose.rotation,
            linear_velocity: link.linear_velocity + link.angular_velocity.cross(&lever),
            angular_velocity: link.angular_velocity,
        }
    }

    /// Pose and velocity of the cube's centre.
    pub fn cube_state(&self) -> BodyState {
        self.body_state(self.cube)
    }

    /// Every collider as a [`VisualPrimitive`] at its current pose, appended to `out`: the
    /// floor, the platform, the cube and the robot's links. Renderers draw these instead of
    /// touching the physics engine.
    pub fn visual_primitives(&self, out: &mut Vec<VisualPrimitive>) {
        let mut push = |handle: ColliderHandle, tag: VisualTag| {
            let Some(collider) = self.world.colliders.get(handle) else {
                return;
            };
            // A collider's own pose is synchronised with its body only when the world steps;
            // after a teleport (a reset) the body already is where it should be drawn.
            let parent = collider
                .parent()
                .and_then(|b| self.world.bodies.get(b))
                .zip(collider.position_wrt_parent());
            let pose = match parent {
                Some((body, local)) => pose_to_na(body.position()) * pose_to_na(local),
                None => pose_to_na(collider.position()),
            };
            push_visual(collider.shape(), &pose, tag, out);
        };
        push(self.floor_collider, VisualTag::Floor);
        push(self.platform_collider, VisualTag::Platform);
        push(self.cube_collider, VisualTag::Cube);
        for &(handle, link) in &self.robot_colliders {
            let finger = self.finger_links.contains(&link);
            push(handle, VisualTag::RobotLink { link, finger });
        }
    }

    /// Teleports the cube to `position` / `orientation`, at rest.
    pub fn set_cube_pose(
        &mut self,
        position: &Vector3<f64>,
        orientation: &UnitQuaternion<f64>,
    ) -> Result<()> {
        ensure_all_finite("cube position", position.as_slice())?;
        ensure_all_finite("cube orientation", orientation.coords.as_slice())?;
        if let Some(rb) = self.world.bodies.get_mut(self.cube) {
            let pose = Isometry3::from_parts(Translation3::from(*position), *orientation);
            rb.set_position(pose_from_na(&pose), true);
            rb.set_linvel(Vector::ZERO, true);
            rb.set_angvel(Vector::ZERO, true);
            rb.reset_forces(true);
        }
        Ok(())
    }

    /// What the cube touches right now (contacts with a positive impulse in the last step).
    pub fn cube_contacts(&self) -> CubeContacts {
        let mut contacts = CubeContacts::default();
        self.for_each_cube_contact(|contact| match contact {
            CubeContact::Floor => contacts.floor = true,
            CubeContact::Platform => contacts.platform = true,
            CubeContact::Robot { link, force } => {
                match contacts.robot_links.iter().position(|&l| l == link) {
                    Some(i) => contacts.robot_forces[i] += force,
                    None => {
                        contacts.robot_links.push(link);
                        contacts.robot_forces.push(force);
                    }
                }
            }
        });
        contacts
    }

    /// Calls `visit` for every collider pair of the cube with an active contact.
    fn for_each_cube_contact(&self, mut visit: impl FnMut(CubeContact)) {
        for pair in self
            .world
            .narrow_phase
            .contact_pairs_with(self.cube_collider)
        {
            if !pair.has_any_active_contact() {
                continue;
            }
            let other = if pair.collider1 == self.cube_collider {
                pair.collider2
            } else {
                pair.collider1
            };
            if other == self.floor_collider {
                visit(CubeContact::Floor);
            } else if other == self.platform_collider {
                visit(CubeContact::Platform);
            } else if let Some(&(_, link)) = self.robot_colliders.iter().find(|(c, _)| *c == other)
            {
                let force = pair.total_impulse().length() as f64 / self.config.solver.dt;
                visit(CubeContact::Robot { link, force });
            }
        }
    }

    /// Joints or constraints of any kind that attach the cube to another body. The grasp is
    /// frictional, so this is 0.
    pub fn constraints_on_cube(&self) -> usize {
        self.world.impulse_joints.attached_joints(self.cube).count()
            + self
                .world
                .multibody_joints
                .attached_joints(self.cube)
                .count()
    }

    /// What touches the cube, summarised without allocating (contacts with a positive impulse in
    /// the last physics step).
    pub fn cube_touch(&self) -> CubeTouch {
        let mut touch = CubeTouch::default();
        self.for_each_cube_contact(|contact| match contact {
            CubeContact::Floor => touch.floor = true,
            CubeContact::Platform => touch.platform = true,
            CubeContact::Robot { link, force } => {
                match self.finger_links.iter().position(|&l| l == link) {
                    Some(i) if i < 2 => touch.finger_forces[i] += force,
                    _ => touch.other_robot_force += force,
                }
            }
        });
        touch
    }

    /// Changes the cube's edge length, mass and friction (domain randomisation); its pose and
    /// velocity are kept.
    pub fn set_cube_properties(&mut self, size: f64, mass: f64, friction: f64) -> Result<()> {
        for (field, value) in [("cube size", size), ("cube mass", mass)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::InvalidConfig {
                    field: field.into(),
                    reason: format!("must be finite and > 0, got {value}"),
                });
            }
        }
        if !(friction.is_finite() && friction >= 0.0) {
            return Err(Error::InvalidConfig {
                field: "cube friction".into(),
                reason: format!("must be finite and >= 0, got {friction}"),
            });
        }
        if let Some(collider) = self.world.colliders.get_mut(self.cube_collider) {
            let half = (size / 2.0) as f32;
            collider.set_shape(SharedShape::cuboid(half, half, half));
            collider.set_mass(mass as f32);
            collider.set_friction(friction as f32);
        }
        Ok(())
    }

    /// Edge length (m), mass (kg) and friction of the cube as simulated now.
    pub fn cube_properties(&self) -> (f64, f64, f64) {
        match self.world.colliders.get(self.cube_collider) {
            Some(c) => {
                let size = c
                    .shape()
                    .as_cuboid()
                    .map(|b| 2.0 * b.half_extents.x as f64)
                    .unwrap_or(f64::NAN);
                (size, c.mass() as f64, c.friction() as f64)
            }
            None => (f64::NAN, f64::NAN, f64::NAN),
        }
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

    /// Copies the whole dynamic state (see [`SimSnapshot`]).
    pub fn snapshot(&self) -> SimSnapshot {
        SimSnapshot {
            config: self.config.clone(),
            islands: self.world.islands.clone(),
            broad_phase: self.world.broad_phase.clone(),
            narrow_phase: self.world.narrow_phase.clone(),
            bodies: self.world.bodies.clone(),
            colliders: self.world.colliders.clone(),
            impulse_joints: self.world.impulse_joints.clone(),
            multibody_joints: self.world.multibody_joints.clone(),
            kinematic: self.kinematic.clone(),
            controls: self.controls.clone(),
            torques_applied: self.torques_applied,
            time: self.time,
            steps: self.steps,
        }
    }

    /// Puts the world back into the state `snapshot` recorded. The snapshot must come from a
    /// simulation built from an equal configuration.
    pub fn restore(&mut self, snapshot: &SimSnapshot) -> Result<()> {
        if snapshot.config != self.config {
            return Err(Error::SnapshotMismatch {
                reason: "it was taken from a simulation with a different configuration".into(),
            });
        }
        self.world.islands.clone_from(&snapshot.islands);
        self.world.broad_phase.clone_from(&snapshot.broad_phase);
        self.world.narrow_phase.clone_from(&snapshot.narrow_phase);
        self.world.bodies.clone_from(&snapshot.bodies);
        self.world.colliders.clone_from(&snapshot.colliders);
        self.world
            .impulse_joints
            .clone_from(&snapshot.impulse_joints);
        self.world
            .multibody_joints
            .clone_from(&snapshot.multibody_joints);
        self.kinematic.clone_from(&snapshot.kinematic);
        self.controls.clone_from(&snapshot.controls);
        self.torques_applied = snapshot.torques_applied;
        self.time = snapshot.time;
        self.steps = snapshot.steps;
        Ok(())
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
}

/// What [`build_kinematic_arm`] put into the world.
struct KinematicBuild {
    links: Vec<UrdfLinkHandle>,
    link_sources: Vec<usize>,
    joint_slots: Vec<Option<DofSlot>>,
    multibody: MultibodyIndex,
    arm: KinematicArm,
}

/// The kinematic arm: every link but the gripper's becomes a placed (kinematic) body; the
/// gripper (the fingers' parent link and the fingers) becomes its own multibody with the
/// dynamic arm's coupled, force-limited drive, its root free and welded by a fixed joint to
/// the placed link it hangs from. (A multibody rooted on a placed body does not pass the
/// body's motion on to the fingers' contacts, and fingers on separate impulse joints could
/// not be coupled: a held cube shuttled 1-2 cm between them during carries.)
fn build_kinematic_arm(
    world: &mut PhysicsWorld,
    model: &RobotModel,
    config: &SimConfig,
    robot: UrdfRobot,
    gripper_joint: Option<usize>,
    finger_joints: &[usize],
) -> Result<KinematicBuild> {
    let malformed = |reason: &str| Error::MalformedUrdf {
        source_name: model.source().to_owned(),
        reason: reason.into(),
    };
    let gripper_root = gripper_joint
        .map(|g| model.joints()[g].parent_link_index)
        .ok_or_else(|| malformed("the kinematic arm needs a robot with a prismatic gripper"))?;
    let in_gripper = |link: usize| {
        link == gripper_root
            || finger_joints
                .iter()
                .any(|&j| model.joints()[j].child_link_index == link)
    };
    let UrdfRobot { links, joints } = robot;
    let mut gripper = UrdfRobot {
        links: Vec::new(),
        joints: Vec::new(),
    };
    let mut gripper_index = vec![None; links.len()];
    let mut placed_links = Vec::new();
    let mut link_sources = Vec::new();
    for (i, mut link) in links.into_iter().enumerate() {
        if in_gripper(link.urdf_link_index) {
            gripper_index[i] = Some(gripper.links.len());
            gripper.links.push(link);
        } else {
            link.body
                .set_body_type(RigidBodyType::KinematicPositionBased, false);
            let body = world.bodies.insert(link.body);
            let colliders = link
                .colliders
                .into_iter()
                .map(|c| UrdfColliderHandle {
                    handle: world
                        .colliders
                        .insert_with_parent(c.collider, body, &mut world.bodies),
                    visual: c.visual,
                })
                .collect();
            placed_links.push(UrdfLinkHandle { body, colliders });
            link_sources.push(link.urdf_link_index);
        }
    }
    for joint in joints {
        if let (Some(link1), Some(link2)) = (gripper_index[joint.link1], gripper_index[joint.link2])
        {
            gripper.joints.push(UrdfJoint {
                link1,
                link2,
                ..joint
            });
        }
    }
    let gripper_sources: Vec<usize> = gripper.links.iter().map(|l| l.urdf_link_index).collect();
    let root_position = gripper_sources
        .iter()
        .position(|&l| l == gripper_root)
        .ok_or_else(|| malformed("the gripper's parent link has no body"))?;
    let (handles, joint_slots, multibody) =
        insert_multibody(world, gripper, model, config, finger_joints, |j| {
            finger_joints.contains(&j)
        })?;

    // Weld the gripper's root to the nearest placed ancestor, through fixed joints only.
    let mut offset = Isometry3::identity();
    let mut link = gripper_root;
    let anchor = loop {
        let j = model.links()[link]
            .parent_joint
            .ok_or_else(|| malformed("the gripper is the robot's root"))?;
        if model.joints()[j].joint_type != JointType::Fixed {
            return Err(malformed(
                "the kinematic arm needs the gripper fixed to the last arm link",
            ));
        }
        offset = model.joint_transform(j, 0.0) * offset;
        link = model.joints()[j].parent_link_index;
        if let Some(i) = link_sources.iter().position(|&l| l == link) {
            break placed_links[i].body;
        }
    };
    let weld = FixedJointBuilder::new()
        .local_frame1(pose_from_na(&offset))
        .contacts_enabled(false)
        .build();
    world
        .impulse_joints
        .insert(anchor, handles.links[root_position].body, weld, true);

    let dofs = model.num_dofs();
    let mut links = placed_links;
    links.extend(handles.links);
    link_sources.extend(gripper_sources);
    Ok(KinematicBuild {
        links,
        link_sources,
        joint_slots,
        multibody,
        arm: KinematicArm {
            q: vec![0.0; dofs],
            qd: vec![0.0; dofs],
            blocked_steps: 0,
            q_next: vec![0.0; dofs],
            joint_positions: vec![0.0; model.joints().len()],
            link_poses: vec![Isometry3::identity(); model.links().len()],
        },
    })
}

/// What the URDF loader returns for a robot inserted as a multibody.
type MultibodyHandles =
    rapier3d_urdf::UrdfRobotHandles<Option<rapier3d::dynamics::MultibodyJointHandle>>;

/// Inserts `robot` into `world` as a multibody (no self contacts) and finds its joints there
/// (see [`build_multibody`]; `required` says which movable joints must be in it).
fn insert_multibody(
    world: &mut PhysicsWorld,
    robot: UrdfRobot,
    model: &RobotModel,
    config: &SimConfig,
    finger_joints: &[usize],
    required: impl Fn(usize) -> bool,
) -> Result<(MultibodyHandles, Vec<Option<DofSlot>>, MultibodyIndex)> {
    let joint_sources: Vec<usize> = robot
        .joints
        .iter()
        .map(|j| j.source_urdf_joint_index())
        .collect();
    let handles = robot.insert_using_multibody_joints(
        &mut world.bodies,
        &mut world.colliders,
        &mut world.multibody_joints,
        UrdfMultibodyOptions::DISABLE_SELF_CONTACTS,
    );
    let (joint_slots, multibody) = build_multibody(
        &mut world.multibody_joints,
        model,
        config,
        &handles.joints,
        &joint_sources,
        finger_joints,
        required,
    )?;
    Ok((handles, joint_slots, multibody))
}

/// Where each joint of `model` landed in the multibody the URDF loader built, after giving the
/// arm's and fingers' dofs their armature and coupling the mimic joints to their masters.
fn build_multibody(
    multibody_joints: &mut MultibodyJointSet,
    model: &RobotModel,
    config: &SimConfig,
    joints: &[rapier3d_urdf::UrdfJointHandle<Option<rapier3d::dynamics::MultibodyJointHandle>>],
    joint_sources: &[usize],
    finger_joints: &[usize],
    required: impl Fn(usize) -> bool,
) -> Result<(Vec<Option<DofSlot>>, MultibodyIndex)> {
    let mut joint_slots = vec![None; model.joints().len()];
    let mut multibody = None;
    for (handle, &joint) in joints.iter().zip(joint_sources) {
        if handle.joint.is_none() {
            continue;
        }
        let Some(link_id) = multibody_joints.rigid_body_link(handle.link2).copied() else {
            continue;
        };
        multibody = Some(link_id.multibody);
        let info = &model.joints()[joint];
        let (coord, axis) = match info.joint_type {
            JointType::Prismatic => (0, JointAxis::LinX),
            JointType::Revolute | JointType::Continuous => (3, JointAxis::AngX),
            JointType::Fixed => continue,
        };
        joint_slots[joint] = Some(DofSlot {
            link_id: link_id.id,
            coord,
            axis,
            child_body: handle.link2,
            parent_body: handle.link1,
        });
    }
    for j in model.joints() {
        if j.joint_type.is_movable() && required(j.index) && joint_slots[j.index].is_none() {
            return Err(Error::MalformedUrdf {
                source_name: model.source().to_owned(),
                reason: format!("joint `{}` could not be built as a multibody joint", j.name),
            });
        }
    }
    let multibody = multibody.ok_or_else(|| Error::MalformedUrdf {
        source_name: model.source().to_owned(),
        reason: "the robot has no movable joints".into(),
    })?;

    // Mimic joints (the second finger) follow their master through a holonomic coupling,
    // like the real gripper's single drive, instead of two independently saturated motors
    // that let a held cube drift sideways.
    if let Some(mb) = multibody_joints.get_multibody_mut(multibody) {
        for j in model.joints() {
            let Some(slot) = joint_slots[j.index] else {
                continue;
            };
            let armature = if finger_joints.contains(&j.index) {
                config.motors.finger_armature
            } else {
                config.motors.arm_armature
            };
            if let Some(link) = mb.link(slot.link_id) {
                let dof = link.assembly_id();
                if dof < mb.armature().len() {
                    mb.armature_mut()[dof] = armature as f32;
                }
            }
        }
        for j in model.joints() {
            if let (Some(m), Some(slave)) = (j.mimic, joint_slots[j.index]) {
                if let Some(master) = joint_slots[m.master] {
                    mb.add_dof_coupling(MultibodyDofCoupling {
                        link1: master.link_id,
                        dof1: 0,
                        axis1: master.coord,
                        link2: slave.link_id,
                        dof2: 0,
                        axis2: slave.coord,
                        coeff: m.multiplier as f32,
                        offset: m.offset as f32,
                    });
                }
            }
        }
    }

    Ok((joint_slots, multibody))
}

/// The actuated prismatic joint that drives the fingers: `panda_finger_joint1` for the Panda,
/// else the first actuated prismatic joint that another joint mimics, else none.
fn find_gripper_joint(model: &RobotModel) -> Option<usize> {
    if let Ok(j) = model.joint_index("panda_finger_joint1") {
        return Some(j);
    }
    model
        .joints()
        .iter()
        .filter(|j| j.joint_type == JointType::Prismatic && j.dof.is_some())
        .find(|j| {
            model
                .joints()
                .iter()
                .any(|o| o.mimic.is_some_and(|m| m.master == j.index))
        })
        .map(|j| j.index)
}

/// Links with at most one movable joint between them and the root: they only turn about the
/// base's vertical axis and cannot reach the floor or the platform.
fn proximal_links(model: &RobotModel) -> Vec<usize> {
    model
        .links()
        .iter()
        .filter(|link| {
            let mut movable = 0;
            let mut current = link.index;
            while let Some(j) = model.links()[current].parent_joint {
                if model.joints()[j].joint_type.is_movable() {
                    movable += 1;
                }
                current = model.joints()[j].parent_link_index;
            }
            movable <= 1
        })
        .map(|l| l.index)
        .collect()
}

/// Appends `shape` (at world `pose`) as visual primitives; compounds are flattened and shapes
/// a renderer has no use for (none in the scenes built here) are skipped.
fn push_visual(
    shape: &dyn rapier3d::geometry::Shape,
    pose: &Isometry3<f64>,
    tag: VisualTag,
    out: &mut Vec<VisualPrimitive>,
) {
    // parry's cylinders and capsules run along y (capsules between two points); visuals run
    // along z, so the frame is turned: this rotation maps z onto y.
    let z_to_y = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -std::f64::consts::FRAC_PI_2);
    let (shape, local) = if let Some(b) = shape.as_cuboid() {
        let half_extents = vec_to_na(b.half_extents);
        (VisualShape::Box { half_extents }, Isometry3::identity())
    } else if let Some(b) = shape.as_ball() {
        let radius = b.radius as f64;
        (VisualShape::Sphere { radius }, Isometry3::identity())
    } else if let Some(c) = shape.as_capsule() {
        let (a, b) = (vec_to_na(c.segment.a), vec_to_na(c.segment.b));
        let axis = b - a;
        let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &axis)
            // Antiparallel (or a zero-length segment): a half turn about x does.
            .unwrap_or_else(|| {
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
            });
        let shape = VisualShape::Capsule {
            half_height: axis.norm() / 2.0,
            radius: c.radius as f64,
        };
        (
            shape,
            Isometry3::from_parts(Translation3::from((a + b) / 2.0), rotation),
        )
    } else if let Some(c) = shape.as_cylinder() {
        let shape = VisualShape::Cylinder {
            half_height: c.half_height as f64,
            radius: c.radius as f64,
        };
        (
            shape,
            Isometry3::from_parts(Translation3::identity(), z_to_y),
        )
    } else if let Some(c) = shape.as_convex_polyhedron() {
        let (points, triangles) = c.to_trimesh();
        let vertices = points.into_iter().map(vec_to_na).collect();
        (
            VisualShape::ConvexMesh {
                vertices,
                triangles,
            },
            Isometry3::identity(),
        )
    } else if shape.as_halfspace().is_some() {
        // Every halfspace built here is the floor, z up.
        (VisualShape::Plane, Isometry3::identity())
    } else if let Some(compound) = shape.as_compound() {
        for (part_pose, part) in compound.shapes() {
            push_visual(part.as_ref(), &(pose * pose_to_na(part_pose)), tag, out);
        }
        return;
    } else {
        return;
    };
    out.push(VisualPrimitive {
        shape,
        pose: pose * local,
        tag,
    });
}
