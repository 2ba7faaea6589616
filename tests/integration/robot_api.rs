//! The robot API: introspection, teleporting, the three control modes, the gripper, and forward
//! kinematics that agree with the simulated link poses.

use panda_rapier::nalgebra::{Isometry3, Vector3};
use panda_rapier::{ArmFidelity, JointControl, JointType, SimConfig, Simulation, PANDA_READY};

fn sim() -> Simulation {
    Simulation::new(SimConfig::default()).unwrap()
}

#[test]
fn introspection_lists_every_joint_and_link() {
    let sim = sim();
    let model = sim.model();
    assert_eq!(
        model.joints().len(),
        11,
        "7 arm + flange + hand + 2 fingers"
    );
    let j1 = &model.joints()[model.joint_index("panda_joint1").unwrap()];
    assert_eq!(j1.joint_type, JointType::Revolute);
    assert_eq!(
        (j1.lower, j1.upper, j1.max_force, j1.max_velocity),
        (-2.8973, 2.8973, 87.0, 2.175)
    );
    assert_eq!(
        (j1.parent_link.as_str(), j1.child_link.as_str()),
        ("panda_link0", "panda_link1")
    );
    assert_eq!(j1.axis, Vector3::z());
    let j7 = &model.joints()[model.joint_index("panda_joint7").unwrap()];
    assert_eq!((j7.max_force, j7.max_velocity), (12.0, 2.61));
    let hand = &model.joints()[model.joint_index("panda_hand_joint").unwrap()];
    assert_eq!(hand.joint_type, JointType::Fixed);

    let links = sim.link_states();
    assert_eq!(links.len(), 12);
    let total_mass: f64 = links.iter().map(|l| l.mass).sum();
    // The identified link masses (about 16.1 kg) plus the hand and fingers.
    assert!(
        (total_mass - 17.452).abs() < 1e-3,
        "total mass {total_mass}"
    );
    let finger = sim.link_state("panda_leftfinger").unwrap();
    assert_eq!(finger.friction, 1.0);
    assert_eq!(finger.mass, 0.015);
    for l in &links {
        assert!(l.state.position.iter().all(|v| v.is_finite()), "{}", l.name);
    }
}

#[test]
fn simulated_link_poses_match_forward_kinematics() {
    let mut sim = sim();
    let configurations = [
        PANDA_READY.to_vec(),
        vec![0.5, 0.3, -0.4, -1.5, 0.7, 2.0, -0.3, 0.01],
        vec![-1.2, -1.0, 1.5, -2.8, -2.0, 0.5, 2.5, 0.03],
    ];
    for q in configurations {
        sim.set_joint_positions(&q).unwrap();
        let fk = sim.model().link_poses(&q, sim.base_pose()).unwrap();
        for link in sim.link_states() {
            let expected = fk[link.index];
            let err = (link.state.position - expected.translation.vector).norm();
            let angle = link.state.orientation.angle_to(&expected.rotation);
            assert!(
                err < 2e-5 && angle < 1e-4,
                "{}: {err} m, {angle} rad",
                link.name
            );
        }
        let tcp = sim.tcp_state();
        let tcp_fk = sim.model().tcp_pose(&q, sim.base_pose()).unwrap();
        assert!((tcp.position - tcp_fk.translation.vector).norm() < 2e-5);
        let back = sim.joint_positions();
        for (a, b) in back.iter().zip(&q) {
            assert!(
                (a - b).abs() < 1e-5,
                "teleport read back {back:?} for {q:?}"
            );
        }
        assert!((sim.gripper_width() - 2.0 * q[7]).abs() < 1e-5);
    }
}

#[test]
fn position_control_holds_and_tracks_targets() {
    let mut sim = sim();
    let mut target = PANDA_READY.to_vec();
    target[0] = 0.4;
    target[3] = -2.0;
    sim.set_position_targets(&target).unwrap();
    for _ in 0..50 {
        sim.step_control();
    }
    let q = sim.joint_positions();
    for (i, (a, b)) in q.iter().zip(&target).enumerate().take(7) {
        assert!((a - b).abs() < 3e-3, "joint {i}: {a} vs target {b}");
    }
    // Targets beyond a limit are clamped to it, not overshot.
    let j4 = sim.model().joint_index("panda_joint4").unwrap();
    sim.set_joint_control(j4, JointControl::position(1.0))
        .unwrap();
    for _ in 0..50 {
        sim.step_control();
    }
    let q4 = sim.joint_state(j4).unwrap().position;
    assert!(
        q4 <= -0.0698 + 2e-3,
        "joint 4 went to {q4} beyond its upper limit -0.0698"
    );
}

#[test]
fn velocity_control_reaches_the_target_velocity() {
    let mut sim = sim();
    let j1 = sim.model().joint_index("panda_joint1").unwrap();
    sim.set_joint_control(j1, JointControl::velocity(0.5))
        .unwrap();
    let start = sim.joint_state(j1).unwrap().position;
    for _ in 0..10 {
        sim.step_control();
    }
    let state = sim.joint_state(j1).unwrap();
    assert!(
        (state.velocity - 0.5).abs() < 0.02,
        "velocity {}",
        state.velocity
    );
    let moved = state.position - start;
    assert!(
        (moved - 0.5 * 0.4).abs() < 0.02,
        "moved {moved} rad in 0.4 s"
    );
}

#[test]
fn torque_control_applies_clamped_joint_torques() {
    // With the motor off and no torque, gravity pulls the shoulder down (joint 2 positive).
    let mut sim = sim();
    let j2 = sim.model().joint_index("panda_joint2").unwrap();
    let start = sim.joint_state(j2).unwrap().position;
    sim.set_joint_control(j2, JointControl::Torque(0.0))
        .unwrap();
    for _ in 0..5 {
        sim.step_control();
    }
    let fallen = sim.joint_state(j2).unwrap().position - start;
    assert!(
        fallen > 0.01,
        "joint 2 moved {fallen} rad under gravity with zero torque"
    );

    // A torque lifting the arm against gravity moves joint 2 the other way; beyond the 87 N m
    // effort limit the torque is clamped, so 1e6 N m behaves like 87 N m.
    let run = |torque: f64| {
        let mut sim = Simulation::new(SimConfig::default()).unwrap();
        sim.set_joint_control(j2, JointControl::Torque(torque))
            .unwrap();
        for _ in 0..3 {
            sim.step_control();
        }
        sim.joint_state(j2).unwrap().position
    };
    let lifted = run(-87.0);
    assert!(
        lifted < start - 0.01,
        "joint 2 at {lifted}, started at {start}"
    );
    assert_eq!(run(-1e6).to_bits(), lifted.to_bits());
}

/// Velocities of the seven arm joints.
fn arm_velocities(sim: &Simulation) -> Vec<f64> {
    sim.joint_velocities()[..7].to_vec()
}

/// A simulation without gravity.
fn weightless() -> Simulation {
    let mut config = SimConfig::default();
    config.physics.gravity = [0.0, 0.0, 0.0];
    Simulation::new(config).unwrap()
}

/// What each of `steps` physics steps adds to every entry of the joint velocities.
fn velocity_increments(sim: &mut Simulation, steps: usize) -> Vec<Vec<f64>> {
    let mut previous = sim.joint_velocities();
    (0..steps)
        .map(|_| {
            sim.step();
            let now = sim.joint_velocities();
            let step = now.iter().zip(&previous).map(|(a, b)| a - b).collect();
            previous = now;
            step
        })
        .collect()
}

#[test]
fn a_constant_torque_adds_the_same_velocity_every_step() {
    // Without gravity, a constant torque on every arm joint from rest: each physics step adds
    // about the same velocity (the mass matrix barely changes over a few steps). Issue 33: the
    // torque used to pile up, the increments growing linearly (1x, 2x, 3x, ...).
    let mut sim = weightless();
    let torques = [2.0, -3.0, 1.5, 2.5, -0.5, 0.8, 0.3];
    for (dof, torque) in torques.iter().enumerate() {
        let joint = sim.model().actuated_joints()[dof];
        sim.set_joint_control(joint, JointControl::Torque(*torque))
            .unwrap();
    }
    let increments: Vec<Vec<f64>> = velocity_increments(&mut sim, 4)
        .into_iter()
        .map(|step| step[..7].to_vec())
        .collect();
    // Coupling (Coriolis) moves the small ones a little; a piled-up torque would double them.
    let largest = increments[0].iter().map(|v| v.abs()).fold(0.0, f64::max);
    for step in &increments[1..] {
        for (dof, (a, b)) in step.iter().zip(&increments[0]).enumerate() {
            assert!(
                (a - b).abs() <= 0.02 * largest,
                "joint {}: increment {a} after {b} in the first step ({increments:?})",
                dof + 1
            );
        }
    }
    // Switched back to zero torque, the arm coasts: no torque stays behind.
    for dof in 0..7 {
        let joint = sim.model().actuated_joints()[dof];
        sim.set_joint_control(joint, JointControl::Torque(0.0))
            .unwrap();
    }
    let before = arm_velocities(&sim);
    sim.step();
    let after = arm_velocities(&sim);
    let change: f64 = before
        .iter()
        .zip(&after)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let first: f64 = increments[0].iter().map(|v| v.abs()).fold(0.0, f64::max);
    assert!(
        change < 0.05 * first,
        "coasting changed a velocity by {change} (a torque step by {first})"
    );
}

#[test]
fn no_hidden_joint_damping_and_an_explicit_one_acts() {
    // Zero gravity, zero torque, a spinning wrist: with no damping configured (the URDF has no
    // `<dynamics>`) the joint keeps its speed; `joint_damping` slows it.
    let spin = |damping: Option<f64>| {
        let mut config = SimConfig::default();
        config.physics.gravity = [0.0, 0.0, 0.0];
        config.robot.joint_damping = damping;
        let mut sim = Simulation::new(config).unwrap();
        let j7 = sim.model().joint_index("panda_joint7").unwrap();
        sim.set_joint_control(j7, JointControl::Torque(1.0))
            .unwrap();
        for _ in 0..5 {
            sim.step();
        }
        sim.set_joint_control(j7, JointControl::Torque(0.0))
            .unwrap();
        let start = sim.joint_velocities()[6];
        for _ in 0..20 {
            sim.step();
        }
        (start, sim.joint_velocities()[6])
    };
    let (start, end) = spin(None);
    assert!(start > 1.0, "the wrist spun up to {start} rad/s");
    assert!(
        (end - start).abs() < 0.01 * start,
        "undamped wrist: {start} -> {end} rad/s in 0.2 s"
    );
    let (start, end) = spin(Some(0.1));
    assert!(
        end < 0.9 * start,
        "damped wrist: {start} -> {end} rad/s in 0.2 s"
    );
    let mut config = SimConfig::default();
    config.robot.joint_damping = Some(-1.0);
    assert!(Simulation::new(config).is_err());
}

#[test]
fn a_moved_robot_base_moves_the_dynamic_and_the_kinematic_arm() {
    // Issue 33: the dynamic arm ignored `robot_base` while kinematics honoured it.
    for arm in [ArmFidelity::Dynamic, ArmFidelity::Kinematic] {
        let mut config = SimConfig {
            arm,
            ..SimConfig::default()
        };
        config.robot.base = [0.2, -0.1, 0.05];
        let mut sim = Simulation::new(config).unwrap();
        let base = sim.link_state("panda_link0").unwrap();
        assert!(
            (base.state.position - Vector3::new(0.2, -0.1, 0.05)).norm() < 1e-6,
            "{arm:?}: link0 at {:?}",
            base.state.position
        );
        let q = vec![0.3, -0.2, 0.1, -2.0, 0.2, 1.9, 0.5, 0.03];
        sim.set_joint_positions(&q).unwrap();
        let fk = sim.model().link_poses(&q, sim.base_pose()).unwrap();
        for link in sim.link_states() {
            let err = (link.state.position - fk[link.index].translation.vector).norm();
            assert!(err < 2e-5, "{arm:?} {}: {err} m from kinematics", link.name);
        }
        let tcp = sim.tcp_state().position;
        let expected = sim.model().tcp_pose(&q, sim.base_pose()).unwrap();
        assert!((tcp - expected.translation.vector).norm() < 2e-5);
        // Held by position control, it stays there.
        for _ in 0..25 {
            sim.step_control();
        }
        assert!(
            (sim.tcp_state().position - tcp).norm() < 2e-3,
            "{arm:?} drifted"
        );
    }
}

#[test]
fn gripper_opens_and_closes_with_coupled_fingers() {
    let mut sim = sim();
    sim.set_gripper(0.02, None).unwrap();
    for _ in 0..20 {
        sim.step_control();
    }
    let left = sim
        .joint_state(sim.model().joint_index("panda_finger_joint1").unwrap())
        .unwrap();
    let right = sim
        .joint_state(sim.model().joint_index("panda_finger_joint2").unwrap())
        .unwrap();
    assert!(
        (sim.gripper_width() - 0.02).abs() < 1e-3,
        "width {}",
        sim.gripper_width()
    );
    assert!(
        (left.position - right.position).abs() < 1e-4,
        "fingers {left:?} vs {right:?}"
    );
    sim.set_gripper(0.08, None).unwrap();
    for _ in 0..20 {
        sim.step_control();
    }
    assert!((sim.gripper_width() - 0.08).abs() < 1e-3);
}

#[test]
fn cube_teleports_and_rests_on_the_floor() {
    let mut sim = sim();
    let target = Vector3::new(0.6, 0.0, 0.1);
    let cube = sim.object("cube").unwrap();
    sim.set_object_pose(cube, &target, &Isometry3::identity().rotation)
        .unwrap();
    assert_eq!(
        sim.object_state(sim.object("cube").unwrap())
            .position
            .map(|v| (v * 1e6).round()),
        target.map(|v| (v * 1e6).round())
    );
    for _ in 0..25 {
        sim.step_control();
    }
    let cube = sim.object_state(sim.object("cube").unwrap());
    assert!(
        (cube.position.z - 0.025).abs() < 1e-3,
        "cube at z = {}",
        cube.position.z
    );
    assert!(sim.object_contacts(sim.object("cube").unwrap()).floor);
    assert!(!sim.object_contacts(sim.object("cube").unwrap()).platform);
    assert!(sim
        .object_contacts(sim.object("cube").unwrap())
        .robot_links
        .is_empty());
}

#[test]
fn the_hand_collides_with_the_platform_and_the_floor() {
    // Drive the hand straight down onto the platform and onto the floor with position control:
    // the arm is dynamic, so the surfaces stop it instead of letting it sink in.
    use panda_rapier::demo::hand_down;
    use panda_rapier::IkOptions;
    for (x, y, surface) in [(0.5, 0.3, 0.1), (0.5, -0.15, 0.0)] {
        let mut sim = sim();
        let below = Vector3::new(x, y, surface - 0.05);
        let ik = sim
            .model()
            .inverse_kinematics(
                &below,
                Some(&hand_down()),
                &sim.joint_positions(),
                sim.base_pose(),
                &IkOptions::default(),
            )
            .unwrap();
        let mut targets = ik.q.clone();
        targets[7] = 0.0;
        let cube = sim.object("cube").unwrap();
        sim.set_object_pose(cube, &Vector3::new(0.3, -0.4, 0.025), &Default::default())
            .unwrap();
        sim.set_position_targets(&targets).unwrap();
        for _ in 0..75 {
            sim.step_control();
        }
        let lowest = sim
            .link_states()
            .iter()
            .filter(|l| l.num_colliders > 0 && l.name != "panda_link0")
            .map(|l| l.state.position.z)
            .fold(f64::INFINITY, f64::min);
        let fingertip = sim.tcp_state().position.z - 0.0084;
        assert!(
            fingertip > surface - 0.003,
            "fingertips at z = {fingertip:.4}, the surface is at {surface}"
        );
        assert!(
            lowest > surface - 0.01,
            "a link frame went below the surface: {lowest}"
        );
        assert!(sim.is_finite());
    }
}

#[test]
fn the_models_gravity_torques_hold_the_simulated_arm() {
    // Issue 33's bar, against the model's own inverse dynamics (MuJoCo's in
    // tests/python/test_dynamics.py): 50 physics steps, every joint below 0.05 rad/s.
    let configurations = [
        PANDA_READY.to_vec(),
        vec![0.3, 0.1, -0.2, -2.1, 0.2, 2.0, 0.4, 0.04],
        vec![-0.3, 0.6, 0.3, -1.6, -0.3, 2.5, 1.1, 0.04],
    ];
    let gravity = Vector3::new(0.0, 0.0, -9.81);
    for q in configurations {
        let mut sim = sim();
        sim.set_joint_positions(&q).unwrap();
        let torques = sim
            .model()
            .gravity_torques(&q, &gravity, sim.base_pose())
            .unwrap();
        for (dof, torque) in torques.iter().enumerate().take(7) {
            let joint = sim.model().actuated_joints()[dof];
            sim.set_joint_control(joint, JointControl::Torque(*torque))
                .unwrap();
        }
        for _ in 0..50 {
            sim.step();
        }
        let fastest = arm_velocities(&sim)
            .iter()
            .map(|v| v.abs())
            .fold(0.0, f64::max);
        assert!(fastest < 0.05, "{q:?}: {fastest} rad/s after 0.5 s");
    }
}

#[test]
fn mass_matrix_and_jacobian_are_consistent_with_kinematics() {
    let sim = sim();
    let model = sim.model();
    let q = vec![0.3, -0.4, 0.2, -2.0, 0.5, 1.8, -0.6, 0.02];
    let m = model.mass_matrix(&q).unwrap();
    assert_eq!(m.shape(), (8, 8));
    assert!((&m - m.transpose()).norm() < 1e-12);
    assert!(m.clone().cholesky().is_some(), "not positive definite: {m}");
    // The Jacobian's columns are the TCP's motion per unit joint motion.
    let tcp_link = &model.links()[model.tcp().link].name;
    let offset = model.tcp().offset.translation.vector;
    let j = model
        .jacobian(tcp_link, &offset, &q, sim.base_pose())
        .unwrap();
    let h = 1e-6;
    for dof in 0..8 {
        let (mut plus, mut minus) = (q.clone(), q.clone());
        plus[dof] += h;
        minus[dof] -= h;
        let a = model.tcp_pose(&plus, sim.base_pose()).unwrap();
        let b = model.tcp_pose(&minus, sim.base_pose()).unwrap();
        let linear = (a.translation.vector - b.translation.vector) / (2.0 * h);
        let angular = (a.rotation * b.rotation.inverse()).scaled_axis() / (2.0 * h);
        for r in 0..3 {
            assert!((j[(r, dof)] - linear[r]).abs() < 1e-6, "dof {dof}: {j}");
            assert!(
                (j[(r + 3, dof)] - angular[r]).abs() < 1e-6,
                "dof {dof}: {j}"
            );
        }
    }
    assert!(model.mass_matrix(&[0.0; 3]).is_err());
    assert!(model
        .inverse_dynamics(
            &q,
            &[f64::NAN; 8],
            &[0.0; 8],
            &Vector3::zeros(),
            sim.base_pose()
        )
        .is_err());
    assert!(model
        .jacobian("no_link", &offset, &q, sim.base_pose())
        .is_err());
}

#[test]
fn a_constant_finger_force_adds_the_same_velocity_every_step() {
    // The prismatic path (body forces) beside the revolute one: no gravity, a closing force
    // on the gripper's drive from fully open, four physics steps before the fingers meet.
    let mut sim = weightless();
    let finger = sim.model().joint_index("panda_finger_joint1").unwrap();
    sim.set_joint_control(finger, JointControl::Torque(-1.0))
        .unwrap();
    let increments: Vec<f64> = velocity_increments(&mut sim, 4)
        .iter()
        .map(|step| step[7])
        .collect();
    assert!(increments[0] < 0.0, "{increments:?}");
    for step in &increments[1..] {
        assert!(
            (step - increments[0]).abs() <= 0.02 * increments[0].abs(),
            "{increments:?}"
        );
    }
}
