//! The scripted pick-and-place controller: the classic manual-control sequence (open, move
//! above, descend, close, lift, carry, lower, release, retreat), closed-loop and stateless.
//!
//! Every action is a function of the current observation alone: the phase is recognised from
//! where the hand, the fingers and the cube are, not remembered. So the policy can take over
//! any environment at any step, and it recovers by itself when the cube slips or a grasp
//! misses (the cube is then "not in the hand" again, and the approach starts over).
//!
//! The other tasks branch off early: `reach` moves the open hand to the goal; `push` closes the
//! hand, lines it up behind the cube on the line from the goal through the cube and pushes
//! along that line (see [`Phase::Align`] and [`Phase::Push`]); `lift` is pick-and-place with
//! the goal in the air; `stack` is pick-and-place twice, with a gentler grasp (see `stack.rs`).

mod params;
mod push;
mod stack;

pub use params::ScriptedParams;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use panda_rapier_core::task::observation::{
    GRIPPER_WIDTH, JOINT_POSITIONS, JOINT_VELOCITIES, TCP_POSITION, TCP_VELOCITY,
};
use panda_rapier_core::task::{make_task, ControlMode, EnvConfig, ObservationLayout, TaskKind};
use panda_rapier_core::{Controller, Error, IkOptions, IkWorkspace, Result, Robot, RobotModel};

/// What the controller is doing, recognised from the observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Opening the hand and moving above the cube.
    Approach,
    /// Lowering the open hand around the cube.
    Descend,
    /// Squeezing the cube.
    Close,
    /// Raising the held cube until it clears whatever lies on the way to the goal.
    Lift,
    /// Moving the held cube above the goal.
    Carry,
    /// Lowering the held cube onto the goal.
    Lower,
    /// Opening the hand with the cube at the goal.
    Release,
    /// Moving the open hand up and away from the placed cube.
    Retreat,
    /// Holding the cube at a goal in the air (nothing to place it on).
    Hold,
    /// Moving the hand to the goal (the `reach` task: no cube).
    Reach,
    /// Moving the closed hand behind the cube, on its far side from the goal (the `push` task).
    Align,
    /// Pushing the cube along the floor towards the goal (the `push` task).
    Push,
}

impl Phase {
    /// Every phase, in the order of the sequence.
    pub const ALL: [Phase; 12] = [
        Phase::Approach,
        Phase::Descend,
        Phase::Close,
        Phase::Lift,
        Phase::Carry,
        Phase::Lower,
        Phase::Release,
        Phase::Retreat,
        Phase::Hold,
        Phase::Reach,
        Phase::Align,
        Phase::Push,
    ];

    /// The phase's name in snake case.
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Approach => "approach",
            Phase::Descend => "descend",
            Phase::Close => "close",
            Phase::Lift => "lift",
            Phase::Carry => "carry",
            Phase::Lower => "lower",
            Phase::Release => "release",
            Phase::Retreat => "retreat",
            Phase::Hold => "hold",
            Phase::Reach => "reach",
            Phase::Align => "align",
            Phase::Push => "push",
        }
    }
}

/// Where the policy's inputs sit in the flat observation.
#[derive(Debug, Clone)]
struct Slots {
    achieved: std::ops::Range<usize>,
    desired: std::ops::Range<usize>,
    joint_positions: std::ops::Range<usize>,
    joint_velocities: std::ops::Range<usize>,
    tcp: std::ops::Range<usize>,
    tcp_velocity: std::ops::Range<usize>,
    width: usize,
    /// The cube's orientation, in the tasks that observe it.
    cube_orientation: Option<std::ops::Range<usize>>,
    /// `stack`: the two cubes' orientations.
    stack_orientations: Option<[std::ops::Range<usize>; 2]>,
}

impl Slots {
    fn new(layout: &ObservationLayout) -> Self {
        Self {
            achieved: layout.achieved_goal(),
            desired: layout.desired_goal(),
            joint_positions: layout.robot_slot(JOINT_POSITIONS),
            joint_velocities: layout.robot_slot(JOINT_VELOCITIES),
            tcp: layout.robot_slot(TCP_POSITION),
            tcp_velocity: layout.robot_slot(TCP_VELOCITY),
            width: layout.robot_slot(GRIPPER_WIDTH).start,
            cube_orientation: layout.slot("cube_orientation"),
            stack_orientations: layout
                .slot("cube1_orientation")
                .zip(layout.slot("cube2_orientation"))
                .map(|(a, b)| [a, b]),
        }
    }
}

/// The three values of an observation slot, as a vector.
fn vector_at(observation: &[f32], slot: &std::ops::Range<usize>) -> Vector3<f64> {
    let o = &observation[slot.start..slot.start + 3];
    Vector3::new(o[0] as f64, o[1] as f64, o[2] as f64)
}

/// What the controller decided for one observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// The recognised phase.
    pub phase: Phase,
    /// Where the tool centre point should go (world frame).
    pub tcp_target: Vector3<f64>,
    /// Largest action magnitude per axis for the motion.
    pub speed: f64,
    /// Fraction of the remaining distance to cover in one step: below 1 where the hand must
    /// arrive without overshooting (the arm carries momentum from one step into the next).
    pub gain: f64,
    /// Gripper command: +1 open, -1 squeeze.
    pub gripper: f32,
}

/// The scripted pick-and-place policy for one environment configuration, in either action
/// mode. Actions depend on the observation only (see the module documentation).
#[derive(Debug, Clone)]
pub struct ScriptedPolicy {
    config: EnvConfig,
    params: ScriptedParams,
    slots: Slots,
    observation_dim: usize,
    action_dim: usize,
    cube_half: f64,
    open_width: f64,
    // Joint control: the robot's kinematics, where each dof's position sits among the
    // observed joints, and scratch memory so acting does not allocate.
    model: RobotModel,
    base: Isometry3<f64>,
    hand_down: UnitQuaternion<f64>,
    dof_slots: Vec<usize>,
    arm_dofs: Vec<usize>,
    ik_options: IkOptions,
    ik_workspace: IkWorkspace,
    q: Vec<f64>,
}

impl ScriptedPolicy {
    /// The policy for environments built from `config`, with the default parameters.
    pub fn new(config: &EnvConfig) -> Result<Self> {
        Self::with_params(config, ScriptedParams::default())
    }

    /// The policy with explicit parameters.
    pub fn with_params(config: &EnvConfig, params: ScriptedParams) -> Result<Self> {
        config.validate()?;
        // The robot's facts (kinematics, base pose, start pose, joint order) exactly as the
        // environment sees them, without building a world.
        let robot = Robot::new(&config.sim_config()?)?;
        let model = robot.model().clone();
        let movable = robot.movable_joints();
        let dof_slots = model
            .actuated_joints()
            .iter()
            .map(|j| movable.iter().position(|m| m == j).unwrap_or(0))
            .collect();
        let task = make_task(config);
        let layout = ObservationLayout::new(
            movable.len(),
            task.goal_dim(),
            task.goal_descriptions(),
            task.observation_slots(),
        );
        let action_dim = Controller::action_dim(config.control_mode, &robot);
        Ok(Self {
            config: config.clone(),
            params,
            slots: Slots::new(&layout),
            observation_dim: layout.flat_dim(),
            action_dim,
            cube_half: config.sim.cube.size / 2.0,
            open_width: robot.gripper().max_width,
            base: *robot.base_pose(),
            hand_down: *robot.hand_down(),
            dof_slots,
            arm_dofs: robot.arm_dofs().to_vec(),
            ik_options: IkOptions {
                max_iterations: 30,
                ..IkOptions::default()
            },
            ik_workspace: IkWorkspace::default(),
            q: robot.start_configuration().to_vec(),
            model,
        })
    }

    /// Length of one action (4 for `ee`, 8 for `joints` control).
    pub fn action_dim(&self) -> usize {
        self.action_dim
    }

    /// Length of one observation.
    pub fn observation_dim(&self) -> usize {
        self.observation_dim
    }

    /// The parameters in use.
    pub fn params(&self) -> &ScriptedParams {
        &self.params
    }

    /// Recognises the phase and picks the hand's target for one flat observation.
    pub fn decide(&self, observation: &[f32]) -> Result<Decision> {
        self.check(observation)?;
        let s = &self.slots;
        let p = &self.params;
        let v3 = |r: &std::ops::Range<usize>| vector_at(observation, r);
        let cube = v3(&s.achieved);
        let goal = v3(&s.desired);
        let tcp = v3(&s.tcp);
        if self.config.task.kind() == TaskKind::Reach {
            // No cube: straight to the goal, slowing down on arrival; the hand stays open.
            let gain = if (goal - tcp).norm() < p.arrival_distance {
                p.arrival_gain
            } else {
                1.0
            };
            return Ok(Decision {
                phase: Phase::Reach,
                tcp_target: goal,
                speed: 1.0,
                gain,
                gripper: 1.0,
            });
        }
        let width = observation[s.width] as f64;
        if self.config.task.kind() == TaskKind::Push {
            return Ok(self.decide_push(observation, cube, goal, tcp, width));
        }
        let horizontal = |v: Vector3<f64>| v.xy().norm();
        let stack = self.config.task.kind() == TaskKind::Stack;
        let target = if stack {
            self.stack_target(observation, cube, goal, tcp)
        } else {
            self.single_target(cube, goal)
        };
        let (cube, goal, goal_surface, hover_height, careful) = (
            target.cube,
            target.goal,
            target.goal_surface,
            target.hover_height,
            target.careful,
        );
        let relative = cube - tcp;
        let tcp_speed = v3(&s.tcp_velocity).norm();
        let finger_speed = self
            .finger_slots()
            .map(|i| (observation[s.joint_velocities.start + i] as f64).abs())
            .fold(0.0, f64::max);

        let around_cube =
            horizontal(relative) < p.in_hand_tolerance && relative.z.abs() < p.in_hand_height;
        // Fingers short of fully open: closing, squeezing something, or shut on nothing.
        let hand_closed = width < 0.9 * self.open_width;
        let squeezing = hand_closed && width > 0.5 * self.cube_half;
        // `stack`: besides, the fingers are on the cube (not still closing on it), and a cube
        // off the surface under it stays held even while the fingers jiggle (taken for let go,
        // it would be released in mid-air over the stack).
        let grip = self.grip(target.rotation.as_ref());
        let touching = !stack || width < grip.extent + p.stack_touch_margin;
        let steady = finger_speed < 0.02 || (stack && self.aloft(cube));
        let held = around_cube && squeezing && touching && steady;
        let air_goal = goal.z > goal_surface + self.cube_half + 0.01;
        let cube_to_goal = (cube - goal).norm();

        let decision = |phase, tcp_target, speed, gripper| Decision {
            phase,
            tcp_target,
            speed,
            gain: match phase {
                Phase::Descend | Phase::Lower => p.arrival_gain,
                _ => 1.0,
            },
            gripper,
        };
        if stack {
            let held_or_open = held || !squeezing;
            if let Some(d) =
                self.stack_regrasp(&target, &grip, tcp, width, around_cube, held_or_open)
            {
                return Ok(d);
            }
        }
        if held {
            let offset_to_tcp = -relative;
            let off_goal = horizontal(goal - cube);
            let place_tolerance = if careful {
                p.stack_place_tolerance
            } else {
                p.place_tolerance
            };
            // Onto a stack, the cube goes down only once the hand has stopped moving sideways
            // (arriving at speed, the arm overshoots and puts it down on the bottom one's edge).
            let sliding = careful && v3(&s.tcp_velocity).xy().norm() > p.settle_speed;
            if off_goal > place_tolerance || sliding {
                // Carry at the goal's height plus clearance, never lower than the cube is now,
                // and move sideways only where the cube clears every surface on the way.
                let carry_z = (goal.z + if air_goal { 0.0 } else { 0.03 }).max(cube.z);
                let step = (goal - cube)
                    .xy()
                    .map(|d| d.clamp(-self.config.ee_step, self.config.ee_step));
                let clear = self.clears_surfaces(cube, step.x, step.y);
                let (phase, target) = if off_goal < p.arrival_distance {
                    // Close over the goal: come down along a funnel while lining up, so the
                    // cube meets the surface only once it is over the goal.
                    let z = if air_goal {
                        goal.z
                    } else if sliding {
                        cube.z
                    } else {
                        (goal.z + 2.0 * off_goal).min(cube.z)
                    };
                    (Phase::Lower, Vector3::new(goal.x, goal.y, z))
                } else if clear {
                    (Phase::Carry, Vector3::new(goal.x, goal.y, carry_z))
                } else {
                    let z = carry_z.max(cube.z + 0.05);
                    (Phase::Lift, Vector3::new(cube.x, cube.y, z))
                };
                return Ok(decision(phase, target + offset_to_tcp, 1.0, -1.0));
            }
            if air_goal {
                return Ok(decision(Phase::Hold, goal + offset_to_tcp, 1.0, -1.0));
            }
            // The environment keeps the hand a clearance above surfaces; a cube held low in
            // the hand is let go from there (a few millimetres' drop).
            let hand_floor =
                self.config.surface_height(tcp.x, tcp.y) + self.config.ee_surface_clearance;
            let hand_lowest = tcp.z < hand_floor + 0.003;
            if cube.z - goal.z > p.release_height && !hand_lowest {
                return Ok(decision(Phase::Lower, goal + offset_to_tcp, 1.0, -1.0));
            }
            return Ok(decision(Phase::Release, tcp, 0.0, 1.0));
        }
        if cube_to_goal < self.config.success_threshold && !air_goal {
            // Placed (or being let go): open, then back off upwards.
            if hand_closed && around_cube {
                return Ok(decision(Phase::Release, tcp, 1.0, 1.0));
            }
            let up = Vector3::new(tcp.x, tcp.y, goal.z + p.retreat_height);
            return Ok(decision(Phase::Retreat, up, 1.0, 1.0));
        }
        let misalignment = horizontal(relative);
        let at_cube_height = tcp.z - cube.z < p.in_hand_tolerance;
        let settled = tcp_speed < p.settle_speed;
        let centred = misalignment < p.in_hand_tolerance - 0.01;
        if around_cube && (hand_closed || (centred && at_cube_height && settled)) {
            // Squeeze with the hand held still: a hand still moving, or chasing the cube while
            // the fingers push it, shoves the cube out of the grasp.
            let gripper = if stack {
                self.stack_close_command(width, grip.extent)
            } else {
                -1.0
            };
            return Ok(decision(Phase::Close, tcp, 0.0, gripper));
        }
        if around_cube && centred && at_cube_height {
            // In place but still moving: let the hand come to rest over the cube.
            return Ok(decision(Phase::Descend, cube, 1.0, 1.0));
        }
        if hand_closed {
            // A closed hand away from the cube (a missed or lost grasp): open it, rising to
            // the approach height while it opens.
            let up = Vector3::new(tcp.x, tcp.y, tcp.z.max(cube.z + hover_height));
            return Ok(decision(Phase::Approach, up, 1.0, 1.0));
        }
        // Come in along a funnel over the cube: straight down once lined up, otherwise high
        // enough that the open fingers pass over the cube's top.
        let sideways_settled = !careful || v3(&s.tcp_velocity).xy().norm() < p.settle_speed;
        if misalignment <= p.align_tolerance && sideways_settled {
            return Ok(decision(Phase::Descend, cube, 1.0, 1.0));
        }
        let mut height = (0.045 + 0.5 * (misalignment - p.align_tolerance)).min(hover_height);
        if misalignment < 2.5 * p.align_tolerance && tcp.z > cube.z + p.in_hand_height {
            // Nearly lined up and clear of the cube: hold the height while the hand centres,
            // rather than bouncing up the funnel after every small sideways wobble.
            height = height.min(tcp.z - cube.z);
        }
        let above = Vector3::new(cube.x, cube.y, cube.z + height);
        // Arriving sideways at the second cube of a stack, slow down near it: at full speed the
        // lagging arm dips below its target and sweeps the cube away.
        let speed = if careful && misalignment < p.stack_slow_distance {
            p.stack_approach_speed
        } else {
            1.0
        };
        Ok(decision(Phase::Approach, above, speed, 1.0))
    }

    /// Writes the action for one observation into `action` (length [`Self::action_dim`]) and
    /// returns the recognised phase.
    pub fn act(&mut self, observation: &[f32], action: &mut [f32]) -> Result<Phase> {
        let decision = self.decide(observation)?;
        if action.len() != self.action_dim() {
            return Err(Error::WrongLength {
                what: "action buffer".into(),
                expected: self.action_dim(),
                got: action.len(),
            });
        }
        let tcp = vector_at(observation, &self.slots.tcp);
        let lead = self.params.velocity_lead / self.config.control_frequency;
        let ahead = tcp + vector_at(observation, &self.slots.tcp_velocity) * lead;
        let ee_step = self.config.ee_step;
        let limit = decision.speed;
        let gain = decision.gain;
        let delta =
            (decision.tcp_target - ahead).map(|d| (gain * d / ee_step).clamp(-limit, limit));
        match self.config.control_mode {
            ControlMode::Ee => {
                for i in 0..3 {
                    action[i] = delta[i] as f32;
                }
            }
            ControlMode::Joints => {
                let target = tcp + delta * ee_step;
                for (d, &slot) in self.dof_slots.iter().enumerate() {
                    self.q[d] = observation[self.slots.joint_positions.start + slot] as f64;
                }
                let joint_step = self.config.joint_step;
                let solved = self.model.inverse_kinematics_in(
                    &target,
                    Some(&self.hand_down),
                    &self.q,
                    &self.base,
                    &self.ik_options,
                    &mut self.ik_workspace,
                );
                let change = |dof: usize| match solved {
                    Ok(_) => (self.ik_workspace.q[dof] - self.q[dof]) / joint_step,
                    Err(_) => 0.0,
                };
                // Scale all joints together so the hand keeps its direction when some joint
                // would need more than one full step.
                let largest = self
                    .arm_dofs
                    .iter()
                    .map(|&dof| change(dof).abs())
                    .fold(1.0, f64::max);
                for (i, &dof) in self.arm_dofs.iter().enumerate() {
                    action[i] = (change(dof) / largest) as f32;
                }
            }
        }
        let last = action.len() - 1;
        action[last] = decision.gripper;
        Ok(decision.phase)
    }

    /// [`Self::act`] for a batch: `observations` holds `n` rows, `actions` receives `n` rows.
    pub fn act_batch(&mut self, observations: &[f32], actions: &mut [f32]) -> Result<()> {
        let n = observations.len() / self.observation_dim.max(1);
        if observations.len() != n * self.observation_dim {
            return Err(Error::WrongLength {
                what: "observations (n x observation_dim)".into(),
                expected: (n + 1) * self.observation_dim,
                got: observations.len(),
            });
        }
        let a = self.action_dim();
        if actions.len() != n * a {
            return Err(Error::WrongLength {
                what: "actions (n x action_dim)".into(),
                expected: n * a,
                got: actions.len(),
            });
        }
        for (obs, action) in observations
            .chunks(self.observation_dim)
            .zip(actions.chunks_mut(a))
        {
            self.act(obs, action)?;
        }
        Ok(())
    }

    fn check(&self, observation: &[f32]) -> Result<()> {
        if observation.len() != self.observation_dim {
            return Err(Error::WrongLength {
                what: "observation".into(),
                expected: self.observation_dim,
                got: observation.len(),
            });
        }
        if let Some((i, &v)) = observation.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: format!("observation[{i}]"),
                value: v as f64,
            });
        }
        Ok(())
    }

    /// Positions of the finger joints among the observed joints (those driven by the
    /// gripper dof and its mimic).
    fn finger_slots(&self) -> std::ops::Range<usize> {
        self.arm_dofs.len()..self.slots.joint_positions.len()
    }

    /// The cube and where it goes, in the tasks with one cube.
    fn single_target(&self, cube: Vector3<f64>, goal: Vector3<f64>) -> stack::Target {
        stack::Target {
            cube,
            goal,
            goal_surface: self.config.surface_height(goal.x, goal.y),
            hover_height: self.params.hover_height,
            careful: false,
            rotation: None,
        }
    }

    /// Whether the cube, moved sideways by `(dx, dy)`, keeps its bottom `carry_clearance`
    /// above every surface under its footprint.
    fn clears_surfaces(&self, cube: Vector3<f64>, dx: f64, dy: f64) -> bool {
        let h = self.cube_half;
        let bottom = cube.z - h;
        let (x, y) = (cube.x + dx, cube.y + dy);
        [(-h, -h), (-h, h), (h, -h), (h, h), (0.0, 0.0)]
            .iter()
            .all(|&(ox, oy)| {
                self.config.surface_height(x + ox, y + oy) + self.params.carry_clearance < bottom
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy() -> ScriptedPolicy {
        ScriptedPolicy::new(&EnvConfig::default()).unwrap()
    }

    #[test]
    fn phase_names_are_distinct() {
        let names: std::collections::HashSet<_> = Phase::ALL.iter().map(|p| p.as_str()).collect();
        assert_eq!(names.len(), Phase::ALL.len());
    }

    #[test]
    fn a_cube_lifted_off_the_floor_clears_it_and_one_level_with_the_platform_does_not() {
        let policy = policy();
        let p = EnvConfig::default().sim.platform;
        let floor_cube = Vector3::new(0.5, -0.1, 0.05);
        assert!(policy.clears_surfaces(floor_cube, 0.0, 0.05));
        let near_platform = Vector3::new(p.top_center[0], p.top_center[1], p.top_center[2]);
        assert!(!policy.clears_surfaces(near_platform, 0.0, 0.0));
        let above = near_platform + Vector3::new(0.0, 0.0, 0.05);
        assert!(policy.clears_surfaces(above, 0.0, 0.0));
    }

    #[test]
    fn action_sizes_follow_the_control_mode() {
        assert_eq!(policy().action_dim(), 4);
        let joints = EnvConfig {
            control_mode: ControlMode::Joints,
            ..EnvConfig::default()
        };
        assert_eq!(ScriptedPolicy::new(&joints).unwrap().action_dim(), 8);
        assert_eq!(policy().observation_dim(), 47);
    }
}
