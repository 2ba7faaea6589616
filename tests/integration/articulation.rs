//! Articulated objects (`ArticulationSpec`): the shipped cabinet stands beside the robot with
//! its drawer on a prismatic joint, in both joint models (multibody, impulse joints). A drawer
//! set to an opening reads it back and its handle moves with it; left alone it stays put (its
//! friction holds it); tilted so gravity pulls it open, it slides out and stops at its limit;
//! snapshots restore it exactly; bad URDFs and massless moving links are refused by name.

use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use panda_rapier::{
    ArticulationJoints, ArticulationSpec, Error, RobotModel, Scene, SimConfig, Simulation,
};

fn cabinet_at(pose: Isometry3<f64>, joints: ArticulationJoints) -> Simulation {
    let scene = Scene {
        articulations: vec![ArticulationSpec {
            name: "cabinet".into(),
            model: Arc::new(RobotModel::cabinet().unwrap()),
            pose,
            friction: 0.8,
            joints,
        }],
        ..Scene::default()
    };
    let config = SimConfig::default();
    let model = RobotModel::from_config(&config).unwrap();
    Simulation::with_scene(config, model, scene).unwrap()
}

/// The cabinet 0.75 m in front of the robot, its front (and drawer) facing it.
fn facing_the_robot() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.75, 0.0, 0.0),
        UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::PI),
    )
}

fn run(sim: &mut Simulation, seconds: f64) {
    let end = sim.time() + seconds;
    while sim.time() < end - 1e-9 {
        sim.step();
    }
}

const MODES: [ArticulationJoints; 2] = [ArticulationJoints::Multibody, ArticulationJoints::Impulse];

#[test]
fn a_drawer_set_open_reads_its_opening_and_its_handle_moves_with_it() {
    for mode in MODES {
        let mut sim = cabinet_at(facing_the_robot(), mode);
        let id = sim.articulation("cabinet").unwrap();
        let model = sim.articulation_model(id).unwrap().clone();
        let joint = model.joint_index("drawer_joint").unwrap();
        let handle = model.link_index("handle").unwrap();
        let shut = sim.articulation_joint_state(id, joint).unwrap();
        assert!(shut.position.abs() < 1e-5, "{mode:?}: {shut:?}");
        let before = sim.articulation_link_state(id, handle).unwrap().position;
        // The handle sits in front of the cabinet (towards the robot), 23.5 cm up.
        assert!(
            (before - Vector3::new(0.75 - 0.1975, 0.0, 0.235)).norm() < 1e-5,
            "{before}"
        );

        sim.set_articulation(id, &facing_the_robot(), &[0.1])
            .unwrap();
        let open = sim.articulation_joint_state(id, joint).unwrap();
        assert!((open.position - 0.1).abs() < 1e-5, "{mode:?}: {open:?}");
        let after = sim.articulation_link_state(id, handle).unwrap().position;
        assert!(
            (after - before - Vector3::new(-0.1, 0.0, 0.0)).norm() < 1e-5,
            "{mode:?}: {after}"
        );
        // Past the limit: clamped.
        sim.set_articulation(id, &facing_the_robot(), &[0.4])
            .unwrap();
        let clamped = sim.articulation_joint_state(id, joint).unwrap().position;
        assert!((clamped - 0.25).abs() < 1e-5, "{mode:?}: {clamped}");
    }
}

#[test]
fn a_drawer_left_alone_stays_where_it_is() {
    for mode in MODES {
        let mut sim = cabinet_at(facing_the_robot(), mode);
        let id = sim.articulation("cabinet").unwrap();
        let pose = Isometry3::from_parts(
            Translation3::new(0.7, 0.1, 0.0),
            UnitQuaternion::from_euler_angles(0.0, 0.0, 3.0),
        );
        sim.set_articulation(id, &pose, &[0.12]).unwrap();
        let root = sim.articulation_link_state(id, 0).unwrap();
        run(&mut sim, 2.0);
        let state = sim.articulation_joint_state(id, 0).unwrap();
        assert!((state.position - 0.12).abs() < 1e-3, "{mode:?}: {state:?}");
        assert!(state.velocity.abs() < 1e-3, "{mode:?}: {state:?}");
        let moved = sim.articulation_link_state(id, 0).unwrap().position - root.position;
        assert!(moved.norm() < 1e-9, "{mode:?}: the root moved {moved}");
        assert!(sim.is_finite());
    }
}

#[test]
fn a_tilted_drawer_slides_open_and_stops_at_its_limit() {
    for mode in MODES {
        // Pitched so that the cabinet's +x (the drawer's way out) points 30 degrees down:
        // gravity pulls the 1.5 kg drawer with 7.4 N against 2 N of friction.
        let pose = Isometry3::from_parts(
            Translation3::new(1.2, 0.0, 0.4),
            UnitQuaternion::from_euler_angles(0.0, 30f64.to_radians(), 0.0),
        );
        let mut sim = cabinet_at(pose, mode);
        let id = sim.articulation("cabinet").unwrap();
        run(&mut sim, 0.1);
        let early = sim.articulation_joint_state(id, 0).unwrap();
        assert!(early.velocity > 0.05, "{mode:?}: {early:?}");
        run(&mut sim, 2.0);
        let end = sim.articulation_joint_state(id, 0).unwrap();
        assert!((end.position - 0.25).abs() < 3e-3, "{mode:?}: {end:?}");
        assert!(end.velocity.abs() < 1e-2, "{mode:?}: {end:?}");
    }
}

#[test]
fn snapshots_restore_an_articulated_object_exactly() {
    for mode in MODES {
        let pose = Isometry3::from_parts(
            Translation3::new(1.2, 0.0, 0.4),
            UnitQuaternion::from_euler_angles(0.0, 0.5, 0.0),
        );
        let mut sim = cabinet_at(pose, mode);
        let id = sim.articulation("cabinet").unwrap();
        run(&mut sim, 0.1);
        let snapshot = sim.snapshot();
        run(&mut sim, 0.2);
        let first = sim.articulation_joint_state(id, 0).unwrap();
        sim.restore(&snapshot).unwrap();
        run(&mut sim, 0.2);
        let second = sim.articulation_joint_state(id, 0).unwrap();
        assert_eq!(
            first.position.to_bits(),
            second.position.to_bits(),
            "{mode:?}"
        );
        assert_eq!(
            first.velocity.to_bits(),
            second.velocity.to_bits(),
            "{mode:?}"
        );
    }
}

#[test]
fn bad_articulated_objects_are_refused_by_name() {
    let planar = r#"<robot name="x"><link name="a"/><link name="b">
        <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
        <joint name="slide" type="planar"><parent link="a"/><child link="b"/></joint></robot>"#;
    let err = RobotModel::from_urdf_str(planar, ".").unwrap_err();
    assert!(
        matches!(err, Error::MalformedUrdf { .. }) && err.to_string().contains("slide"),
        "{err}"
    );

    let massless = r#"<robot name="x"><link name="a"><collision><geometry><box size="0.1 0.1 0.1"/>
        </geometry></collision></link><link name="b"><collision><geometry><box size="0.1 0.1 0.1"/>
        </geometry></collision></link>
        <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>
        <limit lower="0" upper="0.2" effort="1" velocity="1"/></joint></robot>"#;
    let scene = Scene {
        articulations: vec![ArticulationSpec {
            name: "box".into(),
            model: Arc::new(RobotModel::from_urdf_str(massless, ".").unwrap()),
            pose: Isometry3::identity(),
            friction: 0.5,
            joints: ArticulationJoints::Multibody,
        }],
        ..Scene::default()
    };
    let config = SimConfig::default();
    let robot = RobotModel::from_config(&config).unwrap();
    let err = Simulation::with_scene(config, robot, scene).unwrap_err();
    match &err {
        Error::InvalidConfig { field, reason } => {
            assert_eq!(field, "scene.articulations[0].model");
            assert!(
                reason.contains("link `b`") && reason.contains("mass"),
                "{reason}"
            );
        }
        other => panic!("{other}"),
    }
}
