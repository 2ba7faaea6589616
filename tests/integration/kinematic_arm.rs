//! Contract: the kinematic arm (`arm = "kinematic"`, the Fetch-style fidelity level) places its
//! links where the commanded trajectory puts them, keeps the friction grasp of the dynamic
//! arm, refuses motions into the scenery instead of sinking in, rejects torque control with a
//! typed error, and is as deterministic as the dynamic arm.

use panda_rapier::demo::{self, hand_down, TutorialSequence};
use panda_rapier::env::PandaEnv;
use panda_rapier::nalgebra::Vector3;
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions};
use panda_rapier::{ArmFidelity, Error, IkOptions, JointControl, SimConfig, Simulation};

fn kinematic() -> SimConfig {
    SimConfig {
        arm: ArmFidelity::Kinematic,
        ..SimConfig::default()
    }
}

/// Commands the hand (pointing down) to `point` from the configuration `q` and steps 100
/// control periods; returns the lowest TCP height reached.
fn drive_hand_to(sim: &mut Simulation, q: &[f64], point: &Vector3<f64>) -> f64 {
    let target = sim
        .model()
        .inverse_kinematics(
            point,
            Some(&hand_down()),
            q,
            sim.base_pose(),
            &IkOptions::default(),
        )
        .unwrap()
        .q;
    sim.set_position_targets(&target).unwrap();
    let mut lowest = f64::INFINITY;
    for _ in 0..100 {
        sim.step_control();
        lowest = lowest.min(sim.tcp_state().position.z);
    }
    lowest
}

#[test]
fn the_tutorial_grasp_holds_on_the_kinematic_arm() {
    let mut sim = Simulation::new(kinematic()).unwrap();
    assert_eq!(sim.arm_model(), ArmFidelity::Kinematic);
    let plan = TutorialSequence::for_scene(&sim);
    let report = demo::run(&mut sim, &plan).unwrap();
    println!(
        "kinematic arm: lift {:.3} m, carry slip {:.2} mm / {:.2} deg, tracking {:.3} mm, \
         placed {:.1} mm from the target",
        report.lift,
        report.carry_slip * 1e3,
        report.carry_slip_angle.to_degrees(),
        report.max_tracking_error * 1e3,
        report.placement_error * 1e3
    );
    assert!(report.lift >= 0.2, "lifted only {:.3} m", report.lift);
    assert!(
        report.carry_slip <= 0.005,
        "slipped {:.2} mm",
        report.carry_slip * 1e3
    );
    assert!(report.on_platform && report.placement_error < 0.01);
    assert_eq!(report.max_constraints_on_cube, 0);
    assert!(!report.non_finite_seen);
    // The links are placed, not driven: the hand is where the trajectory says.
    assert!(report.max_tracking_error < 0.001);
    assert_eq!(sim.arm_blocked_steps(), 0);
}

#[test]
fn a_hand_driven_into_the_platform_stops_above_it() {
    let mut sim = Simulation::new(kinematic()).unwrap();
    let top = sim.scene().platform.as_ref().unwrap().top_center;
    let q = sim.joint_positions();
    let inside = Vector3::new(top[0], top[1], top[2] - 0.05);
    let lowest = drive_hand_to(&mut sim, &q, &inside);
    println!(
        "lowest TCP {lowest:.4} m over a platform top at {:.3} m; {} physics steps refused",
        top[2],
        sim.arm_blocked_steps()
    );
    assert!(sim.arm_blocked_steps() > 0);
    assert!(
        lowest > top[2],
        "the TCP went {lowest:.4} m, into the platform"
    );
    assert!(sim.is_finite());
    // Away from the platform the arm moves again.
    sim.set_position_targets(&q).unwrap();
    let before = sim.arm_blocked_steps();
    for _ in 0..50 {
        sim.step_control();
    }
    assert_eq!(sim.arm_blocked_steps(), before);
    assert!((sim.tcp_state().position.z - 0.487).abs() < 0.01);
}

#[test]
fn a_hand_driven_into_a_fixture_stops_above_it() {
    // A 10 cm block fixed on the floor where the platform would be, and no platform.
    let config = kinematic();
    let model = panda_rapier::RobotModel::from_config(&config).unwrap();
    let top = panda_rapier::Scene::tutorial().platform.unwrap().top_center;
    let block = panda_rapier::ObjectSpec {
        name: "block".into(),
        shape: panda_rapier::ObjectShape::Box {
            half_extents: [0.05; 3],
        },
        mass: 1.0,
        friction: 0.5,
        position: [top[0], top[1], 0.05],
        fixed: true,
        visuals: Vec::new(),
    };
    let scene = panda_rapier::Scene {
        objects: vec![block],
        ..Default::default()
    };
    let mut sim = Simulation::with_scene(config, model, scene).unwrap();
    let q = sim.joint_positions();
    let inside = Vector3::new(top[0], top[1], 0.05);
    let lowest = drive_hand_to(&mut sim, &q, &inside);
    println!(
        "lowest TCP {lowest:.4} m over a fixture top at 0.100 m; {} physics steps refused",
        sim.arm_blocked_steps()
    );
    assert!(sim.arm_blocked_steps() > 0);
    assert!(lowest > 0.1, "the TCP went {lowest:.4} m, into the fixture");
    let block = sim.object("block").unwrap();
    assert!((sim.object_state(block).position.z - 0.05).abs() < 1e-7);
}

#[test]
fn torque_control_needs_the_dynamic_arm() {
    let mut sim = Simulation::new(kinematic()).unwrap();
    let joint = sim.model().actuated_joints()[1];
    let error = sim
        .set_joint_control(joint, JointControl::Torque(5.0))
        .unwrap_err();
    assert!(
        matches!(error, Error::JointNotCommandable { .. }),
        "{error}"
    );
    assert!(error.to_string().contains("dynamic arm"), "{error}");
    // Velocity control is fine.
    sim.set_joint_control(joint, JointControl::velocity(0.2))
        .unwrap();
    sim.step_control();
    assert!((sim.joint_velocities()[1] - 0.2).abs() < 0.05);
}

#[test]
fn kinematic_episodes_are_bit_identical_and_restore_exactly() {
    let config = EnvConfig {
        arm: ArmFidelity::Kinematic,
        control_mode: ControlMode::Joints,
        ..EnvConfig::default()
    };
    let run = |env: &mut PandaEnv, steps: usize| -> Vec<f32> {
        let mut trace = Vec::new();
        for k in 0..steps {
            let action: Vec<f32> = (0..env.action_dim())
                .map(|i| ((k * 7 + i * 3) % 11) as f32 / 5.0 - 1.0)
                .collect();
            env.step(&action).unwrap();
            trace.extend_from_slice(env.observation());
        }
        trace
    };
    let mut a = PandaEnv::new(config.clone()).unwrap();
    let mut b = PandaEnv::new(config).unwrap();
    a.reset(Some(5), &ResetOptions::default()).unwrap();
    b.reset(Some(5), &ResetOptions::default()).unwrap();
    assert_eq!(run(&mut a, 30), run(&mut b, 30));
    let saved = a.snapshot();
    let first = run(&mut a, 20);
    a.restore(&saved).unwrap();
    assert_eq!(run(&mut a, 20), first);
}
