//! Articulated objects: a URDF's links and joints (a cabinet and its drawer) standing in the
//! world beside the robot. The root link is fixed where the task puts it; the other links move
//! when something pushes or pulls them (the robot opening a drawer), within the URDF's joint
//! limits and against its `<dynamics>` damping and friction.
//!
//! Two ways to simulate the joints ([`ArticulationJoints`]): one rapier multibody (reduced
//! coordinates: a joint cannot drift off its axis or past its limits, the URDF's damping and dry
//! friction act per dof), or free bodies held by impulse joints (constraints solved with the
//! contacts; damping and friction become joint motors). Collision meshes become one convex hull
//! each (a cabinet's parts are boxes); the URDF's `<inertial>` gives each link its mass.

use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rapier3d::dynamics::{
    ImpulseJointHandle, JointAxis, MotorModel, MultibodyIndex, RigidBodyBuilder, RigidBodyHandle,
};
use rapier3d::geometry::{
    ColliderBuilder, ColliderHandle, Group, InteractionGroups, MeshConverter,
};
use rapier3d::math::Vector;
use rapier3d::pipeline::PhysicsWorld;
use rapier3d_urdf::{UrdfLoaderOptions, UrdfMultibodyOptions, UrdfRobot};

use super::convert::{pose_from_na, pose_to_na, vec_from_na, vec_to_na};
use super::{BodyState, JointState, Simulation, OBJECT_GROUP};
use crate::config::non_negative;
use crate::error::{ensure_all_finite, Error, Result};
use crate::model::{JointType, RobotModel};

/// How an articulated object's joints are simulated (`joints` of [`ArticulationSpec`];
/// `"multibody"` or `"impulse"` in configurations).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ArticulationJoints {
    /// One rapier multibody in reduced coordinates: exact joints, the URDF's damping and dry
    /// friction per degree of freedom.
    #[default]
    Multibody,
    /// Every moving link a body of its own held by impulse joints, solved with the contacts;
    /// the URDF's damping and friction act through joint motors ([`IMPULSE_STICK_SPEED`]).
    Impulse,
}

/// With impulse joints, a joint's dry friction `f` is a motor holding the joint still with
/// damping `f / IMPULSE_STICK_SPEED` plus the URDF's damping, its force capped at `f` plus the
/// damping's force at 1 m/s (or rad/s): full friction from this speed (m/s or rad/s) on.
pub const IMPULSE_STICK_SPEED: f64 = 0.01;

/// One articulated object of a [`crate::physics::Scene`].
#[derive(Debug, Clone)]
pub struct ArticulationSpec {
    /// Unique name ([`Simulation::articulation`] looks it up).
    pub name: String,
    /// Its links and joints, read from a URDF ([`RobotModel::from_urdf_file`]); shared between
    /// the worlds of a vector environment.
    pub model: Arc<RobotModel>,
    /// Where its root link starts (world frame); tasks place it at every reset with
    /// [`Simulation::set_articulation`].
    pub pose: Isometry3<f64>,
    /// Friction coefficient of every collider.
    pub friction: f64,
    /// How its joints are simulated.
    pub joints: ArticulationJoints,
}

impl PartialEq for ArticulationSpec {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.pose == other.pose
            && self.friction == other.friction
            && self.joints == other.joints
            && (Arc::ptr_eq(&self.model, &other.model)
                || format!("{:?}", self.model.urdf()) == format!("{:?}", other.model.urdf()))
    }
}

impl ArticulationSpec {
    /// Checks the pose, the friction and that every link a joint moves has a mass.
    pub(super) fn validate(&self, field: &str) -> Result<()> {
        ensure_all_finite(
            &format!("{field}.pose"),
            self.pose.translation.vector.as_slice(),
        )?;
        ensure_all_finite(
            &format!("{field}.pose"),
            self.pose.rotation.coords.as_slice(),
        )?;
        non_negative(&format!("{field}.friction"), self.friction)?;
        let model = &self.model;
        for j in model.joints().iter().filter(|j| j.joint_type.is_movable()) {
            let link = &model.links()[j.child_link_index];
            if link.mass.is_nan() || link.mass <= 0.0 {
                return Err(Error::InvalidConfig {
                    field: format!("{field}.model"),
                    reason: format!(
                        "link `{}` of {} moves (joint `{}`) but its <inertial> mass is {}; give \
                         it a positive mass",
                        link.name,
                        model.source(),
                        j.name,
                        link.mass
                    ),
                });
            }
        }
        Ok(())
    }
}

/// An articulated object of a [`Simulation`], from [`Simulation::articulation`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ArticulationId(pub(super) usize);

impl ArticulationId {
    /// The first articulated object of a scene (before a task has looked it up by name).
    pub(crate) fn first() -> Self {
        Self(0)
    }

    /// The object's position in [`crate::physics::Scene::articulations`].
    pub fn index(self) -> usize {
        self.0
    }
}

/// Where one joint of an articulated object lives in rapier.
#[derive(Debug, Clone, Copy)]
enum JointSlot {
    /// A multibody link's joint: its coordinate in `coords()` (0 along x, 3 about x).
    Multibody { link_id: usize, coord: usize },
    /// An impulse joint between two bodies; its frames' x axis is the URDF axis, along which
    /// it slides (`prismatic`) or about which it turns.
    Impulse {
        handle: ImpulseJointHandle,
        parent: RigidBodyHandle,
        child: RigidBodyHandle,
        prismatic: bool,
    },
}

/// An articulated object as built in the world.
#[derive(Debug, Clone)]
pub(super) struct SceneArticulation {
    root: RigidBodyHandle,
    /// The body of each model link; `None` for frame-only links folded into their parent.
    link_bodies: Vec<Option<RigidBodyHandle>>,
    /// Where each model joint is; `None` for fixed joints and folded links.
    joints: Vec<Option<JointSlot>>,
    multibody: Option<MultibodyIndex>,
    /// Every collider with the model link it belongs to.
    pub(super) colliders: Vec<(ColliderHandle, usize)>,
}

/// Builds `spec` into `world`.
pub(super) fn insert_articulation(
    world: &mut PhysicsWorld,
    spec: &ArticulationSpec,
) -> Result<SceneArticulation> {
    let model = &spec.model;
    let options = UrdfLoaderOptions {
        make_roots_fixed: true,
        shift: pose_from_na(&spec.pose),
        rigid_body_blueprint: RigidBodyBuilder::dynamic().can_sleep(false),
        collider_blueprint: ColliderBuilder::default()
            .density(0.0)
            .friction(spec.friction as f32)
            .collision_groups(InteractionGroups::new(
                OBJECT_GROUP,
                Group::ALL,
                Default::default(),
            )),
        mesh_converter: Some(MeshConverter::ConvexHull),
        ..Default::default()
    };
    let robot = UrdfRobot::from_robot(model.urdf(), options, std::path::Path::new("/"));
    let link_sources: Vec<usize> = robot.links.iter().map(|l| l.urdf_link_index).collect();
    let joint_sources: Vec<usize> = robot
        .joints
        .iter()
        .map(|j| j.source_urdf_joint_index())
        .collect();
    let mut link_bodies = vec![None; model.links().len()];
    let mut colliders = Vec::new();
    let mut joints = vec![None; model.joints().len()];
    let mut multibody = None;
    let mut record_links = |links: &[rapier3d_urdf::UrdfLinkHandle]| {
        for (handle, &link) in links.iter().zip(&link_sources) {
            link_bodies[link] = Some(handle.body);
            colliders.extend(handle.colliders.iter().map(|c| (c.handle, link)));
        }
    };
    match spec.joints {
        ArticulationJoints::Multibody => {
            let handles = robot.insert_using_multibody_joints(
                &mut world.bodies,
                &mut world.colliders,
                &mut world.multibody_joints,
                UrdfMultibodyOptions::DISABLE_SELF_CONTACTS,
            );
            record_links(&handles.links);
            for (handle, &joint) in handles.joints.iter().zip(&joint_sources) {
                let info = &model.joints()[joint];
                let coord = match info.joint_type {
                    JointType::Prismatic => 0,
                    JointType::Revolute | JointType::Continuous => 3,
                    JointType::Fixed => continue,
                };
                let Some(link) = handle
                    .joint
                    .and_then(|_| world.multibody_joints.rigid_body_link(handle.link2))
                    .copied()
                else {
                    continue;
                };
                multibody = Some(link.multibody);
                joints[joint] = Some(JointSlot::Multibody {
                    link_id: link.id,
                    coord,
                });
            }
            if let Some(mb) = multibody.and_then(|m| world.multibody_joints.get_multibody_mut(m)) {
                for (joint, slot) in joints.iter().enumerate() {
                    let Some(JointSlot::Multibody { link_id, .. }) = slot else {
                        continue;
                    };
                    let info = &model.joints()[joint];
                    if let Some(link) = mb.link(*link_id) {
                        let dof = link.assembly_id();
                        if dof < mb.damping().len() {
                            // rapier's default damping (0.1 on angular dofs) replaced by the
                            // URDF's, 0 where it gives none.
                            mb.damping_mut()[dof] = info.damping as f32;
                            mb.frictions_mut()[dof] = info.friction as f32;
                        }
                    }
                }
                mb.forward_kinematics(&world.bodies, true);
                mb.update_rigid_bodies(&mut world.bodies, true);
            }
        }
        ArticulationJoints::Impulse => {
            let handles = robot.insert_using_impulse_joints(
                &mut world.bodies,
                &mut world.colliders,
                &mut world.impulse_joints,
            );
            record_links(&handles.links);
            for (handle, &joint) in handles.joints.iter().zip(&joint_sources) {
                let info = &model.joints()[joint];
                let axis = match info.joint_type {
                    JointType::Prismatic => JointAxis::LinX,
                    JointType::Revolute | JointType::Continuous => JointAxis::AngX,
                    JointType::Fixed => continue,
                };
                if let Some(j) = world.impulse_joints.get_mut(handle.joint, false) {
                    let (damping, friction) = (info.damping, info.friction);
                    if damping > 0.0 || friction > 0.0 {
                        let data = &mut j.data;
                        data.set_motor_model(axis, MotorModel::ForceBased);
                        data.set_motor_velocity(
                            axis,
                            0.0,
                            (damping + friction / IMPULSE_STICK_SPEED) as f32,
                        );
                        if friction > 0.0 {
                            data.set_motor_max_force(axis, (friction + damping) as f32);
                        }
                    }
                }
                joints[joint] = Some(JointSlot::Impulse {
                    handle: handle.joint,
                    parent: handle.link1,
                    child: handle.link2,
                    prismatic: axis == JointAxis::LinX,
                });
            }
        }
    }
    let root = link_bodies[model.root_link()].ok_or_else(|| Error::MalformedUrdf {
        source_name: model.source().to_owned(),
        reason: "its root link was not built (it has no collision geometry or mass)".into(),
    })?;
    for j in model.joints().iter().filter(|j| j.joint_type.is_movable()) {
        if joints[j.index].is_none() {
            return Err(Error::MalformedUrdf {
                source_name: model.source().to_owned(),
                reason: format!("joint `{}` could not be built", j.name),
            });
        }
    }
    Ok(SceneArticulation {
        root,
        link_bodies,
        joints,
        multibody,
        colliders,
    })
}

impl Simulation {
    /// The articulated object named `name`.
    pub fn articulation(&self, name: &str) -> Result<ArticulationId> {
        self.scene
            .articulations
            .iter()
            .position(|a| a.name == name)
            .map(ArticulationId)
            .ok_or_else(|| Error::UnknownLink {
                name: name.into(),
                known: self
                    .scene
                    .articulations
                    .iter()
                    .map(|a| a.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// The links and joints of articulated object `id`.
    pub fn articulation_model(&self, id: ArticulationId) -> Result<&RobotModel> {
        self.scene_articulation(id)?;
        Ok(&self.scene.articulations[id.0].model)
    }

    fn scene_articulation(&self, id: ArticulationId) -> Result<&SceneArticulation> {
        self.articulations
            .get(id.0)
            .ok_or_else(|| Error::UnknownLink {
                name: format!("articulation #{}", id.0),
                known: format!(
                    "{} articulated objects in this scene",
                    self.articulations.len()
                ),
            })
    }

    /// Position (m or rad) and velocity of joint `joint` (an index into the model's joints;
    /// fixed joints read 0) of articulated object `id`.
    pub fn articulation_joint_state(&self, id: ArticulationId, joint: usize) -> Result<JointState> {
        let art = self.scene_articulation(id)?;
        self.scene.articulations[id.0].model.joint(joint)?;
        Ok(match art.joints[joint] {
            None => JointState {
                position: 0.0,
                velocity: 0.0,
            },
            Some(JointSlot::Multibody { link_id, coord }) => {
                let mb = art
                    .multibody
                    .and_then(|m| self.world.multibody_joints.get_multibody(m));
                match mb.and_then(|mb| mb.link(link_id).map(|l| (mb, l))) {
                    Some((mb, link)) => JointState {
                        position: link.joint().coords()[coord] as f64,
                        velocity: mb.joint_velocity(link)[0] as f64,
                    },
                    None => JointState {
                        position: f64::NAN,
                        velocity: f64::NAN,
                    },
                }
            }
            Some(JointSlot::Impulse {
                handle,
                parent,
                child,
                prismatic,
            }) => self.impulse_joint_state(handle, parent, child, prismatic),
        })
    }

    fn impulse_joint_state(
        &self,
        handle: ImpulseJointHandle,
        parent: RigidBodyHandle,
        child: RigidBodyHandle,
        prismatic: bool,
    ) -> JointState {
        let nan = JointState {
            position: f64::NAN,
            velocity: f64::NAN,
        };
        let (Some(j), Some(p), Some(c)) = (
            self.world.impulse_joints.get(handle),
            self.world.bodies.get(parent),
            self.world.bodies.get(child),
        ) else {
            return nan;
        };
        let frame1 = pose_to_na(p.position()) * pose_to_na(&j.data.local_frame1);
        let frame2 = pose_to_na(c.position()) * pose_to_na(&j.data.local_frame2);
        let relative = frame1.inverse() * frame2;
        let axis = frame1.rotation * Vector3::x();
        let anchor = vec_from_na(&frame2.translation.vector);
        if prismatic {
            let v = vec_to_na(c.velocity_at_point(anchor)) - vec_to_na(p.velocity_at_point(anchor));
            JointState {
                position: relative.translation.x,
                velocity: v.dot(&axis),
            }
        } else {
            let q = relative.rotation.quaternion();
            let w = vec_to_na(c.angvel()) - vec_to_na(p.angvel());
            JointState {
                position: 2.0 * q.i.atan2(q.w),
                velocity: w.dot(&axis),
            }
        }
    }

    /// Pose and velocity of link `link` (an index into the model's links) of articulated object
    /// `id`; a frame-only link is placed by the fixed joints to its nearest ancestor with a body.
    pub fn articulation_link_state(&self, id: ArticulationId, link: usize) -> Result<BodyState> {
        let art = self.scene_articulation(id)?;
        let model = &self.scene.articulations[id.0].model;
        if link >= model.links().len() {
            return Err(Error::UnknownLink {
                name: format!("link #{link}"),
                known: format!("{} links in {}", model.links().len(), model.name()),
            });
        }
        let mut offset = Isometry3::identity();
        let mut current = link;
        loop {
            if let Some(body) = art.link_bodies[current] {
                return Ok(self.body_state_at(body, &offset));
            }
            let Some(joint) = model.links()[current].parent_joint else {
                return Ok(BodyState::nan());
            };
            let j = &model.joints()[joint];
            offset = j.origin * offset;
            current = j.parent_link_index;
        }
    }

    /// Teleports articulated object `id` at rest: its root to `pose`, its joints to `q` (one
    /// value per movable non-mimic joint, in the model's dof order; clamped into the limits).
    pub fn set_articulation(
        &mut self,
        id: ArticulationId,
        pose: &Isometry3<f64>,
        q: &[f64],
    ) -> Result<()> {
        ensure_all_finite("articulation pose", pose.translation.vector.as_slice())?;
        ensure_all_finite("articulation pose", pose.rotation.coords.as_slice())?;
        self.scene_articulation(id)?;
        // Disjoint borrows: the slots and model are read while the world is written.
        let art = &self.articulations[id.0];
        let model = &self.scene.articulations[id.0].model;
        let world = &mut self.world;
        model.validate_configuration(q)?;
        let mut q = q.to_vec();
        model.clamp_configuration(&mut q);
        let mut positions = vec![0.0; model.joints().len()];
        model.expand_positions(&q, &mut positions);

        if let Some(rb) = world.bodies.get_mut(art.root) {
            rb.set_position(pose_from_na(pose), true);
        }
        if let Some(mb) = art
            .multibody
            .and_then(|m| world.multibody_joints.get_multibody_mut(m))
        {
            let mut displacement = vec![0.0f32; mb.ndofs()];
            for (joint, slot) in art.joints.iter().enumerate() {
                let Some(JointSlot::Multibody { link_id, coord }) = slot else {
                    continue;
                };
                if let Some(link) = mb.link(*link_id) {
                    let current = link.joint().coords()[*coord];
                    displacement[link.assembly_id()] = positions[joint] as f32 - current;
                }
            }
            mb.apply_displacements(&displacement);
            mb.generalized_velocity_mut().fill(0.0);
            mb.forward_kinematics(&world.bodies, true);
            mb.update_rigid_bodies(&mut world.bodies, true);
        }
        // Impulse joints: each child placed from its parent, parents first.
        for &joint in model.topological_joints() {
            let Some(JointSlot::Impulse {
                handle,
                parent,
                child,
                prismatic,
            }) = art.joints[joint]
            else {
                continue;
            };
            let (Some(j), Some(p)) = (world.impulse_joints.get(handle), world.bodies.get(parent))
            else {
                continue;
            };
            let motion = if prismatic {
                Isometry3::from_parts(
                    Translation3::new(positions[joint], 0.0, 0.0),
                    UnitQuaternion::identity(),
                )
            } else {
                Isometry3::rotation(Vector3::x() * positions[joint])
            };
            let placed = pose_to_na(p.position())
                * pose_to_na(&j.data.local_frame1)
                * motion
                * pose_to_na(&j.data.local_frame2).inverse();
            if let Some(rb) = world.bodies.get_mut(child) {
                rb.set_position(pose_from_na(&placed), true);
            }
        }
        for body in art.link_bodies.iter().flatten() {
            if let Some(rb) = world.bodies.get_mut(*body) {
                rb.set_linvel(Vector::ZERO, true);
                rb.set_angvel(Vector::ZERO, true);
                rb.reset_forces(true);
            }
        }
        Ok(())
    }
}
