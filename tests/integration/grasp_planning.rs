//! Top-down grasps planned from shapes (`ObjectShape::top_grasp`): every shipped object gets
//! one that fits the Panda's hand, and the dynamic arm, sent to it by inverse kinematics with
//! no other knowledge of the object, closes on it and lifts it 15 cm; shapes that no grasp fits
//! get none.

use std::path::Path;

use nalgebra::{UnitQuaternion, Vector3};
use panda_rapier::{
    Gripper, GripperGeometry, IkOptions, JointControl, MeshFile, ObjectShape, ObjectSpec,
    RobotModel, Scene, ShapeCache, SimConfig, Simulation, TopGrasp,
};

const OBJECTS: [&str; 10] = [
    "can",
    "bottle",
    "bowl",
    "mug",
    "banana",
    "tennis_ball",
    "block",
    "hammer",
    "screwdriver",
    "pear",
];

/// A shipped object's collision shape (its convex parts, or its mesh's decomposition).
fn shipped(name: &str) -> ObjectShape {
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/objects");
    let cache = ShapeCache::at(Path::new(env!("CARGO_TARGET_TMPDIR")).join("object-set-cache"));
    MeshFile::with_parts_beside(assets.join(format!("{name}.obj")))
        .load(name, &cache)
        .unwrap()
}

/// The hand pointing down, its fingers closing along the world direction at angle `yaw`.
fn hand(yaw: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw + std::f64::consts::FRAC_PI_2)
        * UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0)
}

struct Arm {
    q: Vec<f64>,
    arm_joints: Vec<usize>,
}

impl Arm {
    fn new(sim: &Simulation) -> Self {
        let gripper = Gripper::of(sim.model()).map(|g| g.joint);
        let arm_joints = sim
            .model()
            .actuated_joints()
            .iter()
            .copied()
            .filter(|&j| Some(j) != gripper)
            .collect();
        Self {
            q: sim.joint_positions(),
            arm_joints,
        }
    }

    /// Moves the tool centre point along a straight line at 0.25 m/s, then waits `settle` s.
    fn move_to(
        &mut self,
        sim: &mut Simulation,
        to: Vector3<f64>,
        orientation: &UnitQuaternion<f64>,
        settle: f64,
    ) {
        let from = sim.tcp_state().position;
        let period = sim.control_period();
        let n = (((to - from).norm() / 0.25) / period).ceil().max(1.0) as usize;
        for k in 1..=n {
            let waypoint = from + (to - from) * (k as f64 / n as f64);
            self.q = sim
                .model()
                .inverse_kinematics(
                    &waypoint,
                    Some(orientation),
                    &self.q,
                    sim.base_pose(),
                    &IkOptions::default(),
                )
                .unwrap()
                .q;
            for &j in &self.arm_joints {
                let dof = sim.model().joints()[j].dof.unwrap();
                sim.set_joint_control(j, JointControl::position(self.q[dof]))
                    .unwrap();
            }
            sim.step_control();
        }
        for _ in 0..(settle / period).ceil() as usize {
            sim.step_control();
        }
    }
}

/// Places the object at `(x, y)` turned by `yaw`, grasps it where planned and lifts it by
/// `lift`; returns how far it rose.
fn pick(shape: ObjectShape, grasp: &TopGrasp, yaw: f64, lift: f64) -> f64 {
    let config = SimConfig::default();
    let model = RobotModel::from_config(&config).unwrap();
    let scene = Scene {
        platform: None,
        objects: vec![ObjectSpec {
            name: "object".into(),
            shape,
            mass: 0.1,
            friction: 1.0,
            position: [0.0; 3],
            fixed: false,
            visuals: Vec::new(),
        }],
        floor_friction: None,
        articulations: Vec::new(),
    };
    let mut sim = Simulation::with_scene(config, model, scene).unwrap();
    let object = sim.object("object").unwrap();
    let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
    let at = Vector3::new(0.5, 0.05, 0.0);
    sim.set_object_pose(object, &at, &turn).unwrap();
    let force = sim.config().robot.motors.gripper_force;
    sim.set_gripper(0.08, Some(force)).unwrap();
    for _ in 0..50 {
        sim.step_control();
    }
    let start = sim.object_state(object).position.z;
    let target = at + turn * grasp.position;
    let orientation = hand(yaw + grasp.yaw);
    let mut arm = Arm::new(&sim);
    arm.move_to(
        &mut sim,
        target + Vector3::new(0.0, 0.0, 0.15),
        &orientation,
        0.3,
    );
    arm.move_to(&mut sim, target, &orientation, 0.3);
    sim.set_gripper(0.0, Some(force)).unwrap();
    for _ in 0..(0.6 / sim.control_period()) as usize {
        sim.step_control();
    }
    arm.move_to(
        &mut sim,
        target + Vector3::new(0.0, 0.0, lift),
        &orientation,
        1.0,
    );
    sim.object_state(object).position.z - start
}

#[test]
fn every_shipped_object_gets_a_grasp_that_lifts_it() {
    let mut failures = Vec::new();
    for (i, name) in OBJECTS.iter().enumerate() {
        let shape = shipped(name);
        let grasp = shape
            .top_grasp(&GripperGeometry::PANDA)
            .unwrap()
            .unwrap_or_else(|| panic!("no grasp for {name}"));
        assert!(
            grasp.width < 0.072 && grasp.width > 0.004,
            "{name}: {grasp:?}"
        );
        assert!((0.0..std::f64::consts::PI).contains(&grasp.yaw));
        let yaw = 0.4 + 0.55 * i as f64;
        let rise = pick(shape, &grasp, yaw, 0.15);
        println!(
            "{name:12} grasp at {:.3?} closing at {:.0} deg, width {:.1} mm: rose {:.3} m",
            grasp.position.as_slice(),
            grasp.yaw.to_degrees(),
            grasp.width * 1e3,
            rise
        );
        if rise < 0.13 {
            failures.push(format!("{name} rose {rise:.3} m"));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn shapes_wider_than_the_gripper_everywhere_get_no_grasp() {
    let wide = ObjectShape::Box {
        half_extents: [0.06, 0.06, 0.03],
    };
    assert_eq!(wide.top_grasp(&GripperGeometry::PANDA).unwrap(), None);
    let ball = ObjectShape::Sphere { radius: 0.06 };
    assert_eq!(ball.top_grasp(&GripperGeometry::PANDA).unwrap(), None);
    // A cube of 4 cm is gripped across a side, at its centre.
    let cube = ObjectShape::cube(0.04);
    let grasp = cube.top_grasp(&GripperGeometry::PANDA).unwrap().unwrap();
    assert!((grasp.width - 0.04).abs() < 1e-3, "{grasp:?}");
    assert!(grasp.position.xy().norm() < 1e-3, "{grasp:?}");
}
