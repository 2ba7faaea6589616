//! The action controller: turns an `ee`, `ee_pose` or `joints` action into joint targets and
//! drives the arm to them across one control period, or, with `ee_controller: "osc"`, an end-
//! effector action into a target pose that the operational-space controller ([`Osc`]) pulls the
//! TCP to by joint torques. The same for every task.

use nalgebra::{UnitQuaternion, Vector3};

use crate::env::config::{ControlMode, EeController, EeFrame, EnvConfig};
use crate::env::osc::Osc;
use crate::kinematics::{IkOptions, IkWorkspace};
use crate::physics::{JointControl, Simulation};
use crate::robot::RobotSpec;

/// What one action asked for, besides the joint targets the controller keeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plan {
    /// Position error (m) the inverse kinematics left on the TCP target (`ee` and `ee_pose`
    /// control; 0 for `joints` and for the operational-space controller, which solves none).
    pub ik_position_error: f64,
    /// The gripper opening asked for (m).
    pub gripper_width: f64,
}

/// Maps actions in `[-1, 1]` to joint targets (see [`EnvConfig`]'s `control_mode`, `ee_step`,
/// `joint_step`, `ee_workspace` and `ee_surface_*`) and steps the physics through a control
/// period towards them. It keeps its scratch buffers, so planning and driving do not allocate.
#[derive(Debug, Clone)]
pub struct Controller {
    config: EnvConfig,
    ik_options: IkOptions,
    ik_workspace: IkWorkspace,
    /// The measured configuration at the start of the step.
    q: Vec<f64>,
    /// The planned configuration at its end.
    targets: Vec<f64>,
    controls: Vec<JointControl>,
    /// The operational-space controller (`ee_controller: "osc"`) and the TCP pose it holds
    /// this step.
    osc: Option<Osc>,
    pose: (Vector3<f64>, UnitQuaternion<f64>),
}

impl Controller {
    /// The controller of an environment built from `config` for `robot`.
    pub fn new(config: &EnvConfig, robot: &RobotSpec) -> Self {
        let num_dofs = robot.model().num_dofs();
        Self {
            config: config.clone(),
            ik_options: IkOptions {
                max_iterations: 30,
                ..IkOptions::default()
            },
            ik_workspace: IkWorkspace::default(),
            q: vec![0.0; num_dofs],
            targets: vec![0.0; num_dofs],
            controls: vec![JointControl::position(0.0); num_dofs],
            osc: (config.ee_controller == EeController::Osc).then(|| {
                let [x, y, z] = config.physics.gravity;
                Osc::new(
                    config.osc,
                    robot.model(),
                    robot.arm_dofs(),
                    *robot.base_pose(),
                    Vector3::new(x, y, z),
                    robot.start_configuration(),
                )
            }),
            pose: (Vector3::zeros(), UnitQuaternion::identity()),
        }
    }

    /// Length of an action: 4 for `ee` (TCP displacement and gripper), 7 for `ee_pose` (TCP
    /// displacement, rotation vector and gripper), one per arm joint plus the gripper for
    /// `joints` (8 for the Panda).
    pub fn action_dim(mode: ControlMode, robot: &RobotSpec) -> usize {
        match mode {
            ControlMode::Ee => 4,
            ControlMode::EePose => 7,
            ControlMode::Joints => robot.arm_dofs().len() + 1,
        }
    }

    /// The TCP position `tcp + displacement` clipped into `ee_workspace` and kept
    /// `ee_surface_clearance` above the surface under it.
    fn clip_target(&self, tcp: &Vector3<f64>, displacement: &Vector3<f64>) -> Vector3<f64> {
        let [low, high] = self.config.ee_workspace;
        let mut target = Vector3::zeros();
        for i in 0..3 {
            target[i] = (tcp[i] + displacement[i]).clamp(low[i], high[i]);
        }
        let lowest =
            self.config.surface_height(target.x, target.y) + self.config.ee_surface_clearance;
        target.z = target.z.max(lowest);
        target
    }

    /// The TCP pose an `ee_pose` action asks for, from the measured pose (`position`,
    /// `orientation`): the displacement `ee_step * a[0..3]` and the rotation vector
    /// `ee_rot_step * a[3..6]` (each entry clipped to `[-1, 1]` first), in the base frame
    /// (`p + dp`, `exp(dr) R`) or the hand frame (`p + R dp`, `R exp(dr)`); the position is
    /// then clipped as `ee` targets are.
    pub fn pose_target(
        &self,
        position: &Vector3<f64>,
        orientation: &UnitQuaternion<f64>,
        action: &[f32],
    ) -> (Vector3<f64>, UnitQuaternion<f64>) {
        let a = |i: usize| action[i].clamp(-1.0, 1.0) as f64;
        let dp = Vector3::new(a(0), a(1), a(2)) * self.config.ee_step;
        let dr = Vector3::new(a(3), a(4), a(5)) * self.config.ee_rot_step;
        let turn = UnitQuaternion::from_scaled_axis(dr);
        let (dp, rotation) = match self.config.ee_frame {
            EeFrame::Base => (dp, turn * orientation),
            EeFrame::Hand => (orientation * dp, orientation * turn),
        };
        (self.clip_target(position, &dp), rotation)
    }

    /// Turns `action` (of [`Controller::action_dim`] finite values) into joint targets, from the
    /// measured configuration, limited to what the joints' velocity limits allow in one control
    /// period.
    pub fn plan(&mut self, robot: &RobotSpec, sim: &Simulation, action: &[f32]) -> Plan {
        let a = |i: usize| action[i].clamp(-1.0, 1.0) as f64;
        // The sim is finite here (a blow-up stops the episode), so this cannot fail.
        let _ = sim.joint_positions_into(&mut self.q);
        self.targets.copy_from_slice(&self.q);
        let mut ik_error = 0.0;
        let arm_dofs = robot.arm_dofs();
        let gripper_action = match self.config.control_mode {
            ControlMode::Ee | ControlMode::EePose => {
                let tcp = sim.tcp_state();
                let (target, orientation, gripper) = if self.config.control_mode == ControlMode::Ee
                {
                    let step = Vector3::new(a(0), a(1), a(2)) * self.config.ee_step;
                    let target = self.clip_target(&tcp.position, &step);
                    (target, *robot.hand_down(), a(3))
                } else {
                    let (target, orientation) =
                        self.pose_target(&tcp.position, &tcp.orientation, action);
                    (target, orientation, a(6))
                };
                if self.osc.is_some() {
                    self.pose = (target, orientation);
                    return Plan {
                        ik_position_error: 0.0,
                        gripper_width: robot.gripper_width_for(gripper),
                    };
                }
                if let Ok(report) = robot.model().inverse_kinematics_in(
                    &target,
                    Some(&orientation),
                    &self.q,
                    robot.base_pose(),
                    &self.ik_options,
                    &mut self.ik_workspace,
                ) {
                    for &dof in arm_dofs {
                        self.targets[dof] = self.ik_workspace.q[dof];
                    }
                    ik_error = report.position_error;
                }
                gripper
            }
            ControlMode::Joints => {
                for (i, &dof) in arm_dofs.iter().enumerate() {
                    self.targets[dof] = self.q[dof] + a(i) * self.config.joint_step;
                }
                a(arm_dofs.len())
            }
        };
        // Slow the whole motion down until every joint keeps within its velocity limit:
        // clamping joints one by one would bend the hand's path away from the commanded
        // direction (seen as centimetre-scale sideways swerves on fast descents).
        let period = sim.control_period();
        let model = robot.model();
        let mut slowdown = 1.0f64;
        for &dof in arm_dofs {
            let joint = model.actuated_joints()[dof];
            let limit = model.joints()[joint].max_velocity * period;
            if limit > 0.0 {
                slowdown = slowdown.max((self.targets[dof] - self.q[dof]).abs() / limit);
            }
        }
        for &dof in arm_dofs {
            self.targets[dof] = self.q[dof] + (self.targets[dof] - self.q[dof]) / slowdown;
        }
        Plan {
            ik_position_error: ik_error,
            gripper_width: robot.gripper_width_for(gripper_action),
        }
    }

    /// Steps the physics through one control period, moving the arm's position targets
    /// linearly from the measured configuration to the planned one with a matching velocity
    /// feed-forward: the arm moves at a steady speed instead of lunging at a target a whole
    /// period away (which drew peaks of 2 m/s and 40 m/s^2 at the hand and shook the cube
    /// loose).
    pub fn drive(&mut self, sim: &mut Simulation, plan: &Plan) {
        // The touch reading is the control step's mean.
        sim.begin_touch_window();
        if self.osc.is_some() {
            return self.drive_osc(sim, plan);
        }
        let substeps = sim.config().substeps;
        let period = sim.control_period();
        for k in 1..=substeps {
            let fraction = k as f64 / substeps as f64;
            for (control, (&start, &end)) in self
                .controls
                .iter_mut()
                .zip(self.q.iter().zip(self.targets.iter()))
            {
                *control = JointControl::Position {
                    target: start + fraction * (end - start),
                    target_velocity: (end - start) / period,
                    max_force: None,
                };
            }
            let _ = sim.set_joint_controls(&self.controls);
            let _ = sim.set_gripper(plan.gripper_width, None);
            sim.step();
        }
    }

    /// [`Controller::drive`] for the operational-space controller: the arm's torques are
    /// recomputed from the measured state before every physics step (the controller is a
    /// spring on the TCP; holding torques over a 40 ms period would let it overshoot).
    fn drive_osc(&mut self, sim: &mut Simulation, plan: &Plan) {
        let Some(osc) = &self.osc else {
            return;
        };
        for _ in 0..sim.config().substeps {
            let _ = sim.joint_positions_into(&mut self.q);
            let qd = sim.joint_velocities();
            // The state is finite while the episode runs (a blow-up ends it); a model error
            // leaves the torques at zero rather than panicking.
            let torques = osc
                .torques(sim.model(), &self.q, &qd, &self.pose.0, &self.pose.1)
                .ok();
            for control in self.controls.iter_mut() {
                *control = JointControl::Torque(0.0);
            }
            if let Some(torques) = torques {
                for (&dof, &torque) in osc.arm_dofs().iter().zip(torques.iter()) {
                    self.controls[dof] = JointControl::Torque(torque);
                }
            }
            let _ = sim.set_joint_controls(&self.controls);
            let _ = sim.set_gripper(plan.gripper_width, None);
            sim.step();
        }
    }
}
