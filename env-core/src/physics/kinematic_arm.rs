//! The Fetch-style arm of [`ArmFidelity::Kinematic`]: links placed along the commanded joint
//! trajectory, fingers left to the physics.

use nalgebra::Isometry3;
use rapier3d::math::Vector;
use rapier3d::parry::bounding_volume::BoundingVolume;
use rapier3d::parry::query::intersection_test;

use super::convert::pose_from_na;
use super::{Arm, JointControl, JointState, Simulation};
use crate::config::ArmFidelity;
use crate::error::{Error, Result};
use crate::model::RobotModel;

/// The arm of [`ArmFidelity::Kinematic`]: the joint trajectory its links follow.
#[derive(Debug, Clone, Default)]
pub(super) struct KinematicArm {
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

impl KinematicArm {
    /// The arm of `model`, every joint at 0 and at rest.
    pub(super) fn new(model: &RobotModel) -> Self {
        let dofs = model.num_dofs();
        Self {
            q: vec![0.0; dofs],
            qd: vec![0.0; dofs],
            blocked_steps: 0,
            q_next: vec![0.0; dofs],
            joint_positions: vec![0.0; model.joints().len()],
            link_poses: vec![Isometry3::identity(); model.links().len()],
        }
    }
}

impl Simulation {
    /// How the arm is simulated.
    pub fn arm_model(&self) -> ArmFidelity {
        self.config.arm
    }

    /// Physics steps (since construction) in which the kinematic arm refused a motion that
    /// would have taken one of its links into the floor or the platform; always 0 for the
    /// dynamic arm, whose links collide with the scenery instead.
    pub fn arm_blocked_steps(&self) -> u64 {
        match &self.arm {
            Arm::Kinematic { arm, .. } => arm.blocked_steps,
            Arm::Dynamic { .. } => 0,
        }
    }

    pub(super) fn check_supported(&self, control: &JointControl, joint: usize) -> Result<()> {
        if matches!(self.arm, Arm::Kinematic { .. }) && matches!(control, JointControl::Torque(_)) {
            return Err(Error::JointNotCommandable {
                name: self.model.joints()[joint].name.clone(),
                reason: "torque control needs the dynamic arm (`arm = \"dynamic\"`); the \
                         kinematic arm follows position and velocity commands"
                    .into(),
            });
        }
        Ok(())
    }

    /// The kinematic arm's trajectory, taken out so it can be changed while the world is
    /// borrowed; `None` for the dynamic arm. Put it back with `put_kinematic_arm`.
    fn take_kinematic_arm(&mut self) -> Option<KinematicArm> {
        match &mut self.arm {
            Arm::Kinematic { arm, .. } => Some(std::mem::take(arm)),
            Arm::Dynamic { .. } => None,
        }
    }

    fn put_kinematic_arm(&mut self, trajectory: KinematicArm) {
        if let Arm::Kinematic { arm, .. } = &mut self.arm {
            *arm = trajectory;
        }
    }

    /// The arm joints report the trajectory the links were placed along.
    pub(super) fn read_kinematic_joint(&self, arm: &KinematicArm, joint: usize) -> JointState {
        let info = &self.model.joints()[joint];
        match info.dof {
            Some(dof) => JointState {
                position: arm.q[dof],
                velocity: arm.qd[dof],
            },
            None => JointState {
                position: self.model.joint_position(joint, &arm.q),
                velocity: 0.0,
            },
        }
    }

    /// Puts every link at configuration `q`, at rest (the gripper's multibody then follows its
    /// root).
    pub(super) fn teleport_kinematic_arm(&mut self, q: &[f64]) {
        let Some(mut arm) = self.take_kinematic_arm() else {
            return;
        };
        arm.q.copy_from_slice(q);
        arm.qd.fill(0.0);
        self.model
            .link_poses_into(q, &self.base, &mut arm.joint_positions, &mut arm.link_poses);
        for (link, body) in self.link_bodies.iter().enumerate() {
            let Some(rb) = body.and_then(|b| self.world.bodies.get_mut(b)) else {
                continue;
            };
            let pose = pose_from_na(&arm.link_poses[link]);
            rb.set_position(pose, true);
            if rb.is_kinematic() {
                rb.set_next_kinematic_position(pose);
            }
            rb.set_linvel(Vector::ZERO, true);
            rb.set_angvel(Vector::ZERO, true);
        }
        self.put_kinematic_arm(arm);
    }

    /// Moves the arm's joints one physics step along their commands (the dynamic arm's PD law,
    /// velocity and acceleration limited) and places the links there, unless a link would enter
    /// the floor or the platform: then the arm stops where it is and the step is counted in
    /// [`Simulation::arm_blocked_steps`].
    pub(super) fn advance_kinematic_arm(&mut self) {
        let Some(mut arm) = self.take_kinematic_arm() else {
            return;
        };
        let dt = self.config.physics.solver.dt;
        let max_dv = self.config.robot.motors.kinematic_acceleration * dt;
        let motors = &self.config.robot.motors;
        let (stiffness, damping) = (motors.stiffness, motors.damping);
        let velocity_damping = motors.velocity_damping;
        let gripper = self.gripper_dof();
        let mut velocities = std::mem::take(&mut arm.qd);
        for (dof, velocity) in velocities.iter_mut().enumerate() {
            let (q, v) = (arm.q[dof], *velocity);
            if Some(dof) == gripper {
                arm.q_next[dof] = q;
                continue;
            }
            let joint = &self.model.joints()[self.model.actuated_joints()[dof]];
            let v_max = if joint.max_velocity > 0.0 {
                joint.max_velocity
            } else {
                f64::INFINITY
            };
            // The dynamic arm's joint motors as an implicit (unconditionally stable) PD law,
            // limited in acceleration and velocity: free-space motion tracks as the dynamic arm
            // tracks, without its dynamics.
            let v_wanted = match self.controls[dof] {
                JointControl::Position {
                    target,
                    target_velocity,
                    ..
                } => {
                    let error = joint.clamp(target) - q;
                    (v + dt * (stiffness * error + damping * target_velocity))
                        / (1.0 + dt * damping + dt * dt * stiffness)
                }
                JointControl::Velocity { target, .. } => {
                    (v + dt * velocity_damping * target) / (1.0 + dt * velocity_damping)
                }
                JointControl::Torque(_) => 0.0,
            };
            let mut v_next = v + (v_wanted - v).clamp(-max_dv, max_dv);
            v_next = v_next.clamp(-v_max, v_max);
            let mut q_next = q + v_next * dt;
            if q_next < joint.lower || q_next > joint.upper {
                q_next = joint.clamp(q_next);
                v_next = 0.0;
            }
            arm.q_next[dof] = q_next;
            *velocity = v_next;
        }
        // The fingers are dynamic: their joints keep whatever the physics gives them.
        if let Some(g) = gripper {
            arm.q_next[g] = self.read_joint(self.model.actuated_joints()[g]).position;
        }
        arm.qd = velocities;

        self.model.link_poses_into(
            &arm.q_next,
            &self.base,
            &mut arm.joint_positions,
            &mut arm.link_poses,
        );
        if self.links_enter_scenery(&arm.link_poses) {
            // Refuse the motion unless the arm is in the scenery already (say after a teleport),
            // where any motion must stay possible to get out.
            let mut now = arm.link_poses.clone();
            self.model
                .link_poses_into(&arm.q, &self.base, &mut arm.joint_positions, &mut now);
            if !self.links_enter_scenery(&now) {
                arm.link_poses = now;
                arm.q_next.copy_from_slice(&arm.q);
                arm.qd.fill(0.0);
                arm.blocked_steps += 1;
            }
        }
        std::mem::swap(&mut arm.q, &mut arm.q_next);
        for (link, body) in self.link_bodies.iter().enumerate() {
            if let Some(rb) = body.and_then(|b| self.world.bodies.get_mut(b)) {
                if rb.is_kinematic() {
                    rb.set_next_kinematic_position(pose_from_na(&arm.link_poses[link]));
                }
            }
        }
        self.put_kinematic_arm(arm);
    }

    /// Whether any robot link, at `link_poses`, intersects the floor, the platform or a fixture (the
    /// fingers count: pushed into a surface they would drag the welded gripper along).
    fn links_enter_scenery(&self, link_poses: &[Isometry3<f64>]) -> bool {
        let colliders = &self.world.colliders;
        // The floor, the platform and the fixtures (no allocation: this runs every step).
        let fixtures = self
            .objects
            .iter()
            .filter(|o| o.fixed)
            .map(|o| Some(o.collider));
        let scenery = || {
            [Some(self.floor_collider), self.platform_collider]
                .into_iter()
                .chain(fixtures.clone())
                .flatten()
                .filter_map(|c| colliders.get(c))
        };
        self.robot_colliders.iter().any(|&(handle, link)| {
            let Some(collider) = colliders.get(handle) else {
                return false;
            };
            let local = collider.position_wrt_parent().copied().unwrap_or_default();
            let pose = pose_from_na(&link_poses[link]) * local;
            let aabb = collider.shape().compute_aabb(&pose);
            scenery().any(|scenery| {
                // Pairs the collision filter skips (the base standing on the floor) don't count;
                // disjoint bounding boxes (most links, most of the time) need no exact test.
                collider.collision_groups().test(scenery.collision_groups())
                    && aabb.intersects(&scenery.compute_aabb())
                    && intersection_test(
                        &pose,
                        collider.shape(),
                        scenery.position(),
                        scenery.shape(),
                    )
                    .is_ok_and(|hit| hit.intersecting)
            })
        })
    }
}
