//! Driving the robot: joint commands ([`JointControl`]), the gripper, teleporting the robot
//! for resets, and pushing commands into rapier's joint motors and body torques.

use rapier3d::dynamics::MotorModel;
use rapier3d::math::Vector;

use super::convert::vec_from_na;
use super::{Arm, Simulation};
use crate::error::{ensure_all_finite, ensure_finite, ensure_len, Error, Result};
use crate::model::JointType;

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

impl Simulation {
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
        let read_root = matches!(self.arm, Arm::Kinematic { .. });
        self.teleport_kinematic_arm(&q);
        let Some(mb) = self
            .world
            .multibody_joints
            .get_multibody_mut(self.arm.multibody())
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

    /// Sets how joint `index` (an index into [`crate::RobotModel::joints`]) is driven from now on.
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
        let gripper = self
            .gripper
            .as_ref()
            .ok_or_else(|| Error::JointNotCommandable {
                name: "gripper".into(),
                reason: "this robot has no prismatic finger joint".into(),
            })?;
        ensure_finite(|| "gripper width".into(), width)?;
        let force = force.unwrap_or(self.config.robot.motors.gripper_force);
        // The opening is the sum of the finger joints' positions, all driven by one joint.
        let (joint, gain) = (gripper.joint, gripper.width_gain);
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
        self.finger_joints()
            .iter()
            .map(|&j| self.read_joint(j).position)
            .sum()
    }

    /// Pushes the current controls into the rapier joint motors.
    fn apply_motor_settings(&mut self) {
        let motors = &self.config.robot.motors;
        let gripper_joint = self.gripper.as_ref().map(|g| g.joint);
        let Some(mb) = self
            .world
            .multibody_joints
            .get_multibody_mut(self.arm.multibody())
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
            let is_gripper = Some(joint.index) == gripper_joint;
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
    pub(super) fn apply_joint_torques(&mut self) {
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
        // rapier keeps user forces and torques until they are reset, each kind by its own
        // call: clearing only the forces let every step add the torque again on top of the
        // last (issue 33: the arm accelerated harder every step under a constant torque).
        for body in self.link_bodies.iter().flatten() {
            if let Some(rb) = self.world.bodies.get_mut(*body) {
                rb.reset_forces(false);
                rb.reset_torques(false);
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
}
