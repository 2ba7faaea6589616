//! The action controller: turns an `ee` or `joints` action into joint targets and drives the
//! arm to them across one control period. The same for every task.

use nalgebra::Vector3;

use crate::kinematics::{IkOptions, IkWorkspace};
use crate::physics::{JointControl, Simulation};
use crate::robot::RobotSpec;
use crate::task::config::{ControlMode, EnvConfig};

/// What one action asked for, besides the joint targets the controller keeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plan {
    /// Position error (m) the inverse kinematics left on the TCP target (`ee` control; 0 for
    /// `joints`).
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
        }
    }

    /// Length of an action: 4 for `ee` (TCP displacement and gripper), one per arm joint plus
    /// the gripper for `joints` (8 for the Panda).
    pub fn action_dim(mode: ControlMode, robot: &RobotSpec) -> usize {
        match mode {
            ControlMode::Ee => 4,
            ControlMode::Joints => robot.arm_dofs().len() + 1,
        }
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
            ControlMode::Ee => {
                let [low, high] = self.config.ee_workspace;
                let tcp = sim.tcp_state().position;
                let mut target = Vector3::zeros();
                for i in 0..3 {
                    target[i] = (tcp[i] + a(i) * self.config.ee_step).clamp(low[i], high[i]);
                }
                let lowest = self.config.surface_height(target.x, target.y)
                    + self.config.ee_surface_clearance;
                target.z = target.z.max(lowest);
                if let Ok(report) = robot.model().inverse_kinematics_in(
                    &target,
                    Some(robot.hand_down()),
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
                a(3)
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
}
