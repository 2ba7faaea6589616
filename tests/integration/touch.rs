//! Contract: touch reads forces in newtons. A free hand at rest reads its own weight at the
//! wrist; a cube held still by friction rests on the fingers with its weight (their summed
//! vertical contact force) and adds its weight to the wrist reading, each within 5 %; the
//! reading survives a snapshot round trip bit for bit.

use panda_rapier::demo::{self, TutorialSequence};
use panda_rapier::nalgebra::{UnitQuaternion, Vector3};
use panda_rapier::{ArmFidelity, SimConfig, Simulation, TouchReading};

const G: f64 = 9.81;

/// The hand's orientation in the world.
fn hand_rotation(sim: &Simulation) -> UnitQuaternion<f64> {
    sim.link_state("panda_hand").unwrap().state.orientation
}

/// The world-frame wrist force, the fingers' summed force and normal force, each the mean
/// over `steps` physics steps (one touch window).
fn mean_readings(sim: &mut Simulation, steps: usize) -> (Vector3<f64>, Vector3<f64>, f64) {
    sim.begin_touch_window();
    for _ in 0..steps {
        sim.step();
    }
    let touch = sim.touch();
    let [a, b] = touch.fingers;
    (
        hand_rotation(sim) * touch.wrist.force,
        a.force + b.force,
        a.normal_force + b.normal_force,
    )
}

fn assert_weight(what: &str, measured: f64, expected: f64) {
    println!("{what}: {measured:.4} N, expected {expected:.4} N");
    assert!(
        (measured - expected).abs() <= 0.05 * expected,
        "{what}: {measured:.4} N, expected {expected:.4} N within 5 %"
    );
}

#[test]
fn a_free_hand_at_rest_reads_its_own_weight() {
    for arm in [ArmFidelity::Dynamic, ArmFidelity::Kinematic] {
        let config = SimConfig {
            arm,
            ..SimConfig::default()
        };
        let mut sim = Simulation::new(config).unwrap();
        let mass = sim.hand_subtree_mass();
        assert!(mass > 0.5 && mass < 1.5, "hand subtree of {mass} kg");
        // Before any step nothing touches and nothing moves: the reading is the static weight.
        let start = hand_rotation(&sim) * sim.wrist_wrench().force;
        assert!((start - Vector3::new(0.0, 0.0, -mass * G)).norm() < 1e-6 * mass * G);
        for _ in 0..50 {
            sim.step();
        }
        let (wrist, fingers, normal) = mean_readings(&mut sim, 25);
        assert_eq!(
            (fingers, normal),
            (Vector3::zeros(), 0.0),
            "{arm:?}: nothing touches"
        );
        assert_weight(&format!("{arm:?} empty hand, wrist -z"), -wrist.z, mass * G);
        assert!(wrist.xy().norm() < 0.05 * mass * G, "{arm:?}: {wrist:?}");
        // The torque about the flange is that of the weight at the subtree's centre of mass,
        // which lies below the flange, close to the hand's axis: small.
        let torque = sim.wrist_wrench().torque;
        assert!(torque.norm() < 0.2 * mass * G, "{arm:?}: {torque:?}");
    }
}

#[test]
fn a_cube_held_still_reads_its_weight_on_the_fingers_and_at_the_wrist() {
    let mut sim = Simulation::new(SimConfig::default()).unwrap();
    let empty = sim.hand_subtree_mass();
    let plan = TutorialSequence::for_scene(&sim);
    let report = demo::run_until(&mut sim, &plan, Some("lift")).unwrap();
    assert!(report.lift > 0.2, "lifted {:.3} m", report.lift);
    // Hold still a moment longer, with the lift's commands.
    for _ in 0..100 {
        sim.step();
    }
    let cube = sim.object("cube").unwrap();
    let (_, cube_mass, _) = sim.object_properties(cube);
    let touch = sim.object_touch(cube);
    assert!(!touch.floor && touch.finger_forces.iter().all(|&f| f > 0.0));
    let (wrist, fingers, normal) = mean_readings(&mut sim, 50);
    let speed = sim.object_state(cube).linear_velocity.norm();
    assert!(speed < 0.01, "the cube moves at {speed} m/s in the hand");
    // The cube rests on the fingers: they carry its weight (it pushes them down).
    assert_weight("fingers' vertical force", -fingers.z, cube_mass * G);
    assert!(fingers.xy().norm() < 0.05 * cube_mass * G, "{fingers:?}");
    // Friction carries the weight; the squeeze (both fingers' normal forces) is far larger.
    assert!(normal > 5.0 * cube_mass * G, "squeeze {normal} N");
    assert_weight("wrist -z with the cube", -wrist.z, (empty + cube_mass) * G);
    assert_weight(
        "wrist's change by the cube",
        -wrist.z - empty * G,
        cube_mass * G,
    );
}

#[test]
fn the_reading_survives_a_snapshot_round_trip() {
    let mut sim = Simulation::new(SimConfig::default()).unwrap();
    let plan = TutorialSequence::for_scene(&sim);
    demo::run_until(&mut sim, &plan, Some("close")).unwrap();
    let bits = |t: TouchReading| t.observation().map(f32::to_bits);
    let snapshot = sim.snapshot();
    let held = sim.touch();
    assert!(
        held.fingers.iter().all(|f| f.normal_force > 1.0),
        "{held:?}"
    );
    sim.step_control();
    let next = bits(sim.touch());
    let mut other = Simulation::new(SimConfig::default()).unwrap();
    other.restore(&snapshot).unwrap();
    assert_eq!(bits(other.touch()), bits(held));
    other.step_control();
    assert_eq!(bits(other.touch()), next);
}

#[test]
fn the_observation_follows_the_layout() {
    let reading = TouchReading {
        fingers: [
            panda_rapier::FingerTouch {
                normal_force: 1.0,
                force: Vector3::new(2.0, 3.0, 4.0),
            },
            panda_rapier::FingerTouch {
                normal_force: 5.0,
                force: Vector3::new(6.0, 7.0, 8.0),
            },
        ],
        wrist: panda_rapier::Wrench {
            force: Vector3::new(9.0, 10.0, 11.0),
            torque: Vector3::new(12.0, 13.0, 5000.0),
        },
    };
    let obs = reading.observation();
    assert_eq!(
        obs,
        [1.0, 5.0, 2.0, 3.0, 4.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 1000.0]
    );
    // The parts tile the entry, in order.
    let mut next = 0;
    for (_, start, count) in TouchReading::LAYOUT {
        assert_eq!(start, next);
        next += count;
    }
    assert_eq!(next, TouchReading::LEN);
}
