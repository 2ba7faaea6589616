//! Reading the world: joints, links, the tool centre point and objects, as [`BodyState`]s and
//! [`JointState`]s in f64 world coordinates.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rapier3d::dynamics::RigidBodyHandle;

use super::convert::{pose_to_na, vec_to_na};
use super::{Arm, DofSlot, Simulation};
use crate::error::{ensure_len, Result};

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

impl BodyState {
    /// The state of the frame at `offset` in this body's frame, moving with it: the velocity of
    /// a point rigidly attached to the body.
    pub(crate) fn at_offset(&self, offset: &Isometry3<f64>) -> Self {
        let pose = Isometry3::from_parts(Translation3::from(self.position), self.orientation);
        let frame = pose * offset;
        let lever = frame.translation.vector - self.position;
        Self {
            position: frame.translation.vector,
            orientation: frame.rotation,
            linear_velocity: self.linear_velocity + self.angular_velocity.cross(&lever),
            angular_velocity: self.angular_velocity,
        }
    }

    /// The state of a body that is not there: NaN position and velocities (so any use shows).
    pub(crate) fn nan() -> Self {
        Self {
            position: Vector3::repeat(f64::NAN),
            orientation: UnitQuaternion::identity(),
            linear_velocity: Vector3::repeat(f64::NAN),
            angular_velocity: Vector3::repeat(f64::NAN),
        }
    }
}

/// State and physical properties of one robot link.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkState {
    /// Link index (as in [`crate::RobotModel::links`]).
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

impl Simulation {
    pub(super) fn dof_joint(&self, dof: usize) -> usize {
        self.model.actuated_joints()[dof]
    }

    pub(super) fn slot(&self, joint: usize) -> Option<DofSlot> {
        self.joint_slots.get(joint).copied().flatten()
    }

    pub(super) fn read_joint(&self, joint: usize) -> JointState {
        if let Arm::Kinematic { arm, .. } = &self.arm {
            if !self.finger_joints().contains(&joint) {
                return self.read_kinematic_joint(arm, joint);
            }
        }
        let Some(slot) = self.slot(joint) else {
            // Fixed joints.
            return JointState {
                position: 0.0,
                velocity: 0.0,
            };
        };
        let mb = self.multibody();
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
        self.gripper.as_ref().map(|g| g.dof)
    }

    /// The widest opening the fingers allow (m): the sum of the finger joints' upper limits.
    pub fn gripper_max_width(&self) -> f64 {
        self.gripper.as_ref().map_or(0.0, |g| g.max_width)
    }

    pub(super) fn body_state(&self, handle: RigidBodyHandle) -> BodyState {
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
            None => BodyState::nan(),
        }
    }

    /// Pose and velocity of the frame at `offset` in body `handle`'s frame, moving with it.
    pub(super) fn body_state_at(
        &self,
        handle: RigidBodyHandle,
        offset: &Isometry3<f64>,
    ) -> BodyState {
        self.body_state(handle).at_offset(offset)
    }

    /// Pose and velocity of link `index`. Frame-only links without a body of their own (such as
    /// the flange) are placed by the fixed transforms to their nearest ancestor with a body.
    pub(super) fn link_body_state(&self, index: usize) -> BodyState {
        let mut offset = Isometry3::identity();
        let mut link = index;
        loop {
            if let Some(handle) = self.link_bodies[link] {
                return self.body_state_at(handle, &offset);
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

    /// States of all links, in [`crate::RobotModel::links`] order.
    pub fn link_states(&self) -> Vec<LinkState> {
        (0..self.model.links().len())
            .map(|i| self.link_state_at(i))
            .collect()
    }

    /// Pose and velocity of the tool centre point.
    pub fn tcp_state(&self) -> BodyState {
        let tcp = self.model.tcp();
        self.link_body_state(tcp.link).at_offset(&tcp.offset)
    }
}
