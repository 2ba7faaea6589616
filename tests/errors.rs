//! Contract: bad input is a typed error naming the problem, never a panic.

use panda_rapier::nalgebra::{UnitQuaternion, Vector3};
use panda_rapier::{Error, JointControl, RobotModel, SimConfig, Simulation};

fn sim() -> Simulation {
    Simulation::new(SimConfig::default()).unwrap()
}

#[test]
fn non_finite_commands_are_rejected() {
    let mut sim = sim();
    let j1 = sim.model().joint_index("panda_joint1").unwrap();
    for control in [
        JointControl::position(f64::NAN),
        JointControl::velocity(f64::INFINITY),
        JointControl::Torque(f64::NEG_INFINITY),
        JointControl::Position {
            target: 0.0,
            target_velocity: f64::NAN,
            max_force: None,
        },
        JointControl::Velocity {
            target: 0.0,
            max_force: Some(f64::NAN),
        },
    ] {
        let err = sim.set_joint_control(j1, control).unwrap_err();
        assert!(matches!(err, Error::NonFinite { .. }), "{control:?}: {err}");
        assert!(err.to_string().contains("panda_joint1"), "{err}");
    }
    let err = sim.set_joint_control(
        j1,
        JointControl::Velocity {
            target: 0.0,
            max_force: Some(-1.0),
        },
    );
    assert!(matches!(err, Err(Error::InvalidConfig { .. })));
    let mut q = vec![0.0; 8];
    q[3] = f64::NAN;
    assert!(matches!(
        sim.set_joint_positions(&q),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        sim.set_position_targets(&q),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        sim.set_gripper(f64::NAN, None),
        Err(Error::NonFinite { .. })
    ));
    let err = sim
        .set_cube_pose(
            &Vector3::new(0.0, f64::NAN, 0.0),
            &UnitQuaternion::identity(),
        )
        .unwrap_err();
    assert!(matches!(err, Error::NonFinite { .. }));
    // Nothing was applied: the simulation still steps to a finite state.
    sim.step_control();
    assert!(sim.is_finite());
}

#[test]
fn wrong_lengths_unknown_names_and_indices_are_rejected() {
    let mut sim = sim();
    let err = sim.set_joint_positions(&[0.0; 7]).unwrap_err();
    assert_eq!(
        err,
        Error::WrongLength {
            what: "joint configuration q".into(),
            expected: 8,
            got: 7
        }
    );
    assert!(matches!(
        sim.set_joint_controls(&[]),
        Err(Error::WrongLength { .. })
    ));
    assert!(matches!(
        sim.set_joint_control_by_name("elbow", JointControl::position(0.0)),
        Err(Error::UnknownJoint { .. })
    ));
    assert!(matches!(
        sim.link_state("gripper"),
        Err(Error::UnknownLink { .. })
    ));
    assert!(matches!(
        sim.set_joint_control(42, JointControl::position(0.0)),
        Err(Error::JointIndexOutOfRange {
            index: 42,
            count: 11
        })
    ));
    assert!(matches!(
        sim.joint_state(11),
        Err(Error::JointIndexOutOfRange { .. })
    ));
}

#[test]
fn fixed_and_mimic_joints_cannot_be_commanded() {
    let mut sim = sim();
    let err = sim
        .set_joint_control_by_name("panda_hand_joint", JointControl::position(0.0))
        .unwrap_err();
    assert!(err.to_string().contains("fixed"), "{err}");
    let err = sim
        .set_joint_control_by_name("panda_finger_joint2", JointControl::position(0.0))
        .unwrap_err();
    assert!(err.to_string().contains("panda_finger_joint1"), "{err}");
}

#[test]
fn invalid_configs_and_assets_are_rejected() {
    let mut config = SimConfig::default();
    config.cube.mass = 0.0;
    assert!(
        matches!(Simulation::new(config), Err(Error::InvalidConfig { field, .. }) if field == "cube.mass")
    );

    let config = SimConfig {
        robot_urdf: Some("/does/not/exist.urdf".into()),
        ..Default::default()
    };
    assert!(matches!(
        Simulation::new(config),
        Err(Error::AssetNotFound { .. })
    ));

    let dir = std::env::temp_dir().join(format!("panda_rapier_errors_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let broken = dir.join("broken.urdf");
    std::fs::write(&broken, "<robot name='r'><link name='a'><joint></robot>").unwrap();
    let config = SimConfig {
        robot_urdf: Some(broken),
        ..Default::default()
    };
    assert!(matches!(
        Simulation::new(config),
        Err(Error::MalformedUrdf { .. })
    ));

    let fixed_only = dir.join("fixed.urdf");
    std::fs::write(
        &fixed_only,
        r#"<robot name="r"><link name="a"/><link name="b"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
           <joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint></robot>"#,
    )
    .unwrap();
    let config = SimConfig {
        robot_urdf: Some(fixed_only),
        ..Default::default()
    };
    let err = Simulation::new(config).unwrap_err();
    assert!(matches!(err, Error::MalformedUrdf { .. }), "{err}");

    let config = SimConfig {
        initial_configuration: Some(vec![0.0; 3]),
        ..Default::default()
    };
    // A configuration error, not an argument's: the value came from the configuration.
    assert!(matches!(
        Simulation::new(config),
        Err(Error::InvalidConfig { field, .. }) if field == "initial_configuration"
    ));
    std::fs::remove_dir_all(&dir).unwrap();

    assert!(RobotModel::from_urdf_str("not xml at all", ".").is_err());
}
