//! Contract: bad input is a typed error naming the problem, never a panic.

use panda_rapier::nalgebra::{UnitQuaternion, Vector3};
use panda_rapier::{Error, JointControl, RobotModel, Scene, SimConfig, Simulation};

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
    let cube = sim.object("cube").unwrap();
    let err = sim
        .set_object_pose(
            cube,
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
    let config = SimConfig::default();
    let mut scene = Scene::tutorial();
    scene.objects[0].mass = 0.0;
    let model = RobotModel::from_config(&config).unwrap();
    assert!(matches!(
        Simulation::with_scene(config, model, scene),
        Err(Error::InvalidConfig { field, .. }) if field == "scene.objects[0].mass"
    ));

    let mut config = SimConfig::default();
    config.robot.urdf = Some("/does/not/exist.urdf".into());
    assert!(matches!(
        Simulation::new(config),
        Err(Error::AssetNotFound { .. })
    ));

    let dir = std::env::temp_dir().join(format!("panda_rapier_errors_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let broken = dir.join("broken.urdf");
    std::fs::write(&broken, "<robot name='r'><link name='a'><joint></robot>").unwrap();
    let mut config = SimConfig::default();
    config.robot.urdf = Some(broken);
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
    let mut config = SimConfig::default();
    config.robot.urdf = Some(fixed_only);
    let err = Simulation::new(config).unwrap_err();
    assert!(matches!(err, Error::MalformedUrdf { .. }), "{err}");

    let mut config = SimConfig::default();
    config.robot.initial_configuration = Some(vec![0.0; 3]);
    // A configuration error, not an argument's: the value came from the configuration.
    assert!(matches!(
        Simulation::new(config),
        Err(Error::InvalidConfig { field, .. }) if field == "initial_configuration"
    ));
    std::fs::remove_dir_all(&dir).unwrap();

    assert!(RobotModel::from_urdf_str("not xml at all", ".").is_err());
}

/// The Python bindings' choice of exception class per variant (`env-py/src/error_class.rs`,
/// plain Rust, compiled here because the bindings crate has no Rust test harness).
#[allow(dead_code)]
#[path = "../../env-py/src/error_class.rs"]
mod error_class;

#[test]
fn every_error_variant_maps_to_its_python_class() {
    use error_class::ErrorClass as Class;
    let text = || String::from("x");
    // One value of every variant; a variant missing here is raised as the base class
    // (`PandaRapierError`) until it is listed with the class it should be.
    let cases = [
        (
            Error::AssetNotFound {
                path: "/nope".into(),
                reason: text(),
            },
            Class::Asset,
        ),
        (
            Error::MalformedUrdf {
                source_name: text(),
                reason: text(),
            },
            Class::Asset,
        ),
        (
            Error::MissingMesh {
                filename: text(),
                urdf: text(),
                tried: text(),
            },
            Class::Asset,
        ),
        (
            Error::BadMesh {
                field: text(),
                path: "/nope.obj".into(),
                reason: text(),
            },
            Class::Asset,
        ),
        (
            Error::UnknownJoint {
                name: text(),
                known: text(),
            },
            Class::InvalidArgument,
        ),
        (
            Error::UnknownLink {
                name: text(),
                known: text(),
            },
            Class::InvalidArgument,
        ),
        (
            Error::JointIndexOutOfRange { index: 9, count: 8 },
            Class::InvalidArgument,
        ),
        (
            Error::JointNotCommandable {
                name: text(),
                reason: text(),
            },
            Class::InvalidArgument,
        ),
        (
            Error::NonFinite {
                what: text(),
                value: f64::NAN,
            },
            Class::InvalidArgument,
        ),
        (
            Error::WrongLength {
                what: text(),
                expected: 3,
                got: 2,
            },
            Class::InvalidArgument,
        ),
        (
            Error::InvalidAction {
                what: text(),
                reason: text(),
            },
            Class::InvalidAction,
        ),
        (
            Error::InvalidOption {
                what: text(),
                reason: text(),
            },
            Class::InvalidArgument,
        ),
        (
            Error::InvalidConfig {
                field: text(),
                reason: text(),
            },
            Class::Config,
        ),
        (
            Error::IkNotConverged {
                position_error: 0.1,
                orientation_error: 0.1,
                iterations: 100,
            },
            Class::PandaRapier,
        ),
        (Error::ResetNeeded { reason: text() }, Class::ResetNeeded),
        (
            Error::SnapshotMismatch { reason: text() },
            Class::InvalidArgument,
        ),
    ];
    for (error, class) in &cases {
        assert_eq!(Class::of(error), *class, "{error:?}");
    }
    // Every class the core can produce is covered, and each has a distinct Python name.
    for class in Class::ALL {
        let produced = cases.iter().any(|(_, c)| *c == class);
        assert!(
            produced || class == Class::Display,
            "{class:?} is never raised"
        );
        let same_name = Class::ALL.iter().filter(|c| c.name() == class.name());
        assert_eq!(same_name.count(), 1, "{}", class.name());
    }
    assert!(Class::ALL.iter().all(|c| c.name().ends_with("Error")));
}
