//! The classic tutorial's manual pick-and-place sequence, done with the core API: open the hand,
//! move 25 cm above the cube with the hand pointing down, descend, close, lift, carry over the
//! platform, lower, open, retreat. The TCP moves along straight lines at a bounded speed, each
//! control step solving inverse kinematics for the next waypoint (warm-started from the last
//! solution) and commanding the arm joints with position control.
//!
//! It is open loop in the sense of the tutorial: it plans from the cube's initial pose and never
//! re-plans, so it is a test of the physics (does the friction grasp hold?), not a policy.

use panda_rapier_core::nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use panda_rapier_core::{CubeConfig, Gripper, IkOptions, JointControl, Result, Simulation};

/// Parameters of the sequence.
#[derive(Debug, Clone)]
pub struct TutorialSequence {
    /// Where the cube's centre should end up (on top of the platform).
    pub place_at: Vector3<f64>,
    /// Height above the cube for the approach (m).
    pub approach_height: f64,
    /// How high the cube is lifted above its start (m).
    pub lift_height: f64,
    /// TCP speed along each straight segment (m/s).
    pub speed: f64,
    /// Gripper opening when open (m).
    pub open_width: f64,
    /// Gripper drive force when closed (N); each finger presses with half.
    pub grip_force: f64,
    /// How the closed hand holds the cube.
    pub grasp: GraspMode,
}

/// How the tutorial's closed hand holds the cube.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GraspMode {
    /// By friction between the finger pads alone, as in every environment (the default).
    #[default]
    Friction,
    /// The classic PyBullet tutorial's shortcut: once the fingers have closed on the cube, a
    /// fixed constraint holds it to the hand until the release ([`Simulation::attach`]). Only
    /// the joint's solver compliance lets the cube move in the hand (0.23 mm during the default
    /// carry, against 0.55 mm held by friction); the fingers' grip no longer matters. For
    /// demonstrations, not for judging a grasp.
    Attach,
}

impl TutorialSequence {
    /// The sequence for a simulation's default scene: place the cube at the centre of the
    /// platform's top.
    pub fn for_scene(sim: &Simulation) -> Self {
        let scene = sim.scene();
        let p = scene.platform.clone().unwrap_or_default();
        let half = scene
            .objects
            .first()
            .and_then(|cube| cube.shape.cube_size())
            .unwrap_or(CubeConfig::default().size)
            / 2.0;
        Self {
            place_at: Vector3::new(p.top_center[0], p.top_center[1], p.top_center[2] + half),
            approach_height: 0.25,
            lift_height: 0.25,
            speed: 0.3,
            open_width: 0.08,
            grip_force: sim.config().robot.motors.gripper_force,
            grasp: GraspMode::Friction,
        }
    }
}

/// What happened, measured while the sequence ran.
#[derive(Debug, Clone, Default)]
pub struct SequenceReport {
    /// Names and end times (s) of the phases, in order.
    pub phases: Vec<(&'static str, f64)>,
    /// Highest rise of the cube's centre above its start (m).
    pub lift: f64,
    /// Horizontal distance the cube travelled while carried (m).
    pub carry_distance: f64,
    /// Largest displacement of the cube in the hand's frame during lift, carry and lowering,
    /// relative to where it sat when the lift began (m).
    pub max_slip: f64,
    /// Largest rotation of the cube relative to the hand over the same span (rad).
    pub max_slip_angle: f64,
    /// Largest displacement of the cube in the hand's frame during the carry, relative to where
    /// it sat when the carry began (m).
    pub carry_slip: f64,
    /// Largest rotation of the cube relative to the hand during the carry (rad).
    pub carry_slip_angle: f64,
    /// Peak TCP speed while carrying (m/s).
    pub peak_carry_speed: f64,
    /// The cube's final centre.
    pub final_position: Vector3<f64>,
    /// Horizontal distance between the final centre and the intended spot (m).
    pub placement_error: f64,
    /// The cube's final speed (m/s).
    pub final_speed: f64,
    /// Whether the cube finally rests on the platform (contact with it, none with the robot).
    pub on_platform: bool,
    /// Gripper opening once closed on the cube (m).
    pub grip_width: f64,
    /// Joints or constraints attached to the cube at any time (must stay 0).
    pub max_constraints_on_cube: usize,
    /// Whether any state read during the run was not finite.
    pub non_finite_seen: bool,
    /// Largest IK residual along the way (m).
    pub max_ik_error: f64,
    /// Largest gap between the commanded and the reached TCP position at a waypoint (m).
    pub max_tracking_error: f64,
}

enum Phase {
    Gripper { width: f64, force: f64, hold: f64 },
    Move { to: Vector3<f64>, settle: f64 },
}

/// The hand pointing down: the TCP's z axis along world -z.
pub fn hand_down() -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0)
}

/// Runs the whole sequence on `sim` from its current state.
pub fn run(sim: &mut Simulation, plan: &TutorialSequence) -> Result<SequenceReport> {
    run_until(sim, plan, None)
}

/// Runs the sequence up to and including the phase named `last` (`"open"`, `"move_above"`,
/// `"descend"`, `"close"`, `"lift"`, `"carry"`, `"lower"`, `"release"`, `"retreat"`), or all
/// of it for `None`.
pub fn run_until(
    sim: &mut Simulation,
    plan: &TutorialSequence,
    last: Option<&str>,
) -> Result<SequenceReport> {
    let cube_id = sim.object("cube")?;
    let cube_start = sim.object_state(cube_id).position;
    let above = cube_start + Vector3::new(0.0, 0.0, plan.approach_height);
    let lifted = cube_start + Vector3::new(0.0, 0.0, plan.lift_height);
    let carried = Vector3::new(plan.place_at.x, plan.place_at.y, lifted.z);
    let placed = plan.place_at + Vector3::new(0.0, 0.0, 0.002);
    let retreat = plan.place_at + Vector3::new(0.0, 0.0, 0.2);
    let phases: [(&'static str, Phase); 9] = [
        (
            "open",
            Phase::Gripper {
                width: plan.open_width,
                force: plan.grip_force,
                hold: 0.3,
            },
        ),
        (
            "move_above",
            Phase::Move {
                to: above,
                settle: 0.2,
            },
        ),
        (
            "descend",
            Phase::Move {
                to: cube_start,
                settle: 0.2,
            },
        ),
        (
            "close",
            Phase::Gripper {
                width: 0.0,
                force: plan.grip_force,
                hold: 0.5,
            },
        ),
        (
            "lift",
            Phase::Move {
                to: lifted,
                settle: 0.2,
            },
        ),
        (
            "carry",
            Phase::Move {
                to: carried,
                settle: 0.2,
            },
        ),
        (
            "lower",
            Phase::Move {
                to: placed,
                settle: 0.3,
            },
        ),
        (
            "release",
            Phase::Gripper {
                width: plan.open_width,
                force: plan.grip_force,
                hold: 0.5,
            },
        ),
        (
            "retreat",
            Phase::Move {
                to: retreat,
                settle: 0.5,
            },
        ),
    ];

    let mut report = SequenceReport::default();
    let mut q_command = sim.joint_positions();
    let orientation = hand_down();
    let period = sim.control_period();
    let mut grasp_slip = SlipTracker::default();
    let mut carry_slip = SlipTracker::default();
    let mut carry_start = None;

    for (name, phase) in phases {
        let mut observe = |sim: &Simulation, report: &mut SequenceReport| {
            let cube = sim.object_state(cube_id);
            let tcp = sim.tcp_state();
            let finite = cube.position.iter().all(|v| v.is_finite())
                && cube.linear_velocity.iter().all(|v| v.is_finite())
                && tcp.position.iter().all(|v| v.is_finite());
            report.non_finite_seen |= !finite || !sim.is_finite();
            report.max_constraints_on_cube = report
                .max_constraints_on_cube
                .max(sim.constraints_on(cube_id));
            report.lift = report.lift.max(cube.position.z - cube_start.z);
            let pose = |b: &panda_rapier_core::BodyState| {
                Isometry3::from_parts(Translation3::from(b.position), b.orientation)
            };
            let in_hand = pose(&tcp).inverse() * pose(&cube);
            if matches!(name, "lift" | "carry" | "lower") {
                grasp_slip.update(&in_hand);
            }
            if name == "carry" {
                carry_slip.update(&in_hand);
                let start = *carry_start.get_or_insert(cube.position);
                let d = cube.position - start;
                report.carry_distance = report.carry_distance.max((d.x * d.x + d.y * d.y).sqrt());
                report.peak_carry_speed = report.peak_carry_speed.max(tcp.linear_velocity.norm());
            }
        };
        match phase {
            Phase::Gripper { width, force, hold } => {
                let attach = plan.grasp == GraspMode::Attach;
                if attach && name == "release" {
                    sim.detach(cube_id)?;
                }
                sim.set_gripper(width, Some(force))?;
                for _ in 0..steps_for(hold, period) {
                    sim.step_control();
                    observe(sim, &mut report);
                }
                if name == "close" {
                    report.grip_width = sim.gripper_width();
                    if attach {
                        sim.attach(cube_id)?;
                    }
                }
            }
            Phase::Move { to, settle } => {
                let from = sim.tcp_state().position;
                let n = steps_for((to - from).norm() / plan.speed, period).max(1);
                for k in 1..=n {
                    let waypoint = from + (to - from) * (k as f64 / n as f64);
                    let solution = sim.model().inverse_kinematics(
                        &waypoint,
                        Some(&orientation),
                        &q_command,
                        sim.base_pose(),
                        &IkOptions::default(),
                    )?;
                    report.max_ik_error = report.max_ik_error.max(solution.position_error);
                    q_command = solution.q;
                    command_arm(sim, &q_command)?;
                    sim.step_control();
                    observe(sim, &mut report);
                }
                for _ in 0..steps_for(settle, period) {
                    sim.step_control();
                    observe(sim, &mut report);
                }
                report.max_tracking_error = report
                    .max_tracking_error
                    .max((sim.tcp_state().position - to).norm());
            }
        }
        report.phases.push((name, sim.time()));
        if last == Some(name) {
            break;
        }
    }

    (report.max_slip, report.max_slip_angle) = (grasp_slip.distance, grasp_slip.angle);
    (report.carry_slip, report.carry_slip_angle) = (carry_slip.distance, carry_slip.angle);
    let cube_state = sim.object_state(cube_id);
    report.final_position = cube_state.position;
    let d = cube_state.position - plan.place_at;
    report.placement_error = (d.x * d.x + d.y * d.y).sqrt();
    report.final_speed = cube_state.linear_velocity.norm();
    let contacts = sim.object_contacts(cube_id);
    report.on_platform = contacts.platform && contacts.robot_links.is_empty();
    Ok(report)
}

/// Largest displacement and rotation of the cube in the hand since the first update.
#[derive(Default)]
struct SlipTracker {
    reference: Option<Isometry3<f64>>,
    distance: f64,
    angle: f64,
}

impl SlipTracker {
    fn update(&mut self, cube_in_hand: &Isometry3<f64>) {
        let reference = *self.reference.get_or_insert(*cube_in_hand);
        let moved = cube_in_hand.translation.vector - reference.translation.vector;
        self.distance = self.distance.max(moved.norm());
        self.angle = self
            .angle
            .max(cube_in_hand.rotation.angle_to(&reference.rotation));
    }
}

/// Position control of the base joint swinging about `center`: 0.3 rad at 0.5 Hz, with
/// velocity feed-forward, at time `t`. A sustained motion for grasp endurance tests and benches.
pub fn swing_base_joint(sim: &mut Simulation, center: f64, t: f64) -> Result<()> {
    let j1 = sim.model().actuated_joints()[0];
    let w = std::f64::consts::PI;
    sim.set_joint_control(
        j1,
        JointControl::Position {
            target: center + 0.3 * (w * t).sin(),
            target_velocity: 0.3 * w * (w * t).cos(),
            max_force: None,
        },
    )
}

fn steps_for(seconds: f64, period: f64) -> usize {
    (seconds / period).ceil() as usize
}

/// Position control of the arm joints (all actuated joints but the gripper's).
fn command_arm(sim: &mut Simulation, q: &[f64]) -> Result<()> {
    let gripper = Gripper::of(sim.model()).map(|g| g.joint);
    let arm: Vec<usize> = sim
        .model()
        .actuated_joints()
        .iter()
        .copied()
        .filter(|&j| Some(j) != gripper)
        .collect();
    for j in arm {
        let dof = sim.model().joints()[j].dof.unwrap_or(0);
        sim.set_joint_control(j, JointControl::position(q[dof]))?;
    }
    Ok(())
}
