//! Contract: the friction grasp is real. The tutorial's manual sequence (open, move 25 cm above
//! the cube with the hand pointing down, descend, close, lift, carry over the platform, lower,
//! open) lifts the cube at least 20 cm, carries it at least 30 cm with at most 5 mm of slip in
//! the hand, and leaves it resting on the platform within 2 cm of the intended spot; no NaN
//! appears and nothing but friction holds the cube.

use panda_rapier::demo::{self, TutorialSequence};
use panda_rapier::{SimConfig, Simulation};

#[test]
fn tutorial_pick_and_place_holds_the_cube_by_friction() {
    let mut sim = Simulation::new(SimConfig::default()).unwrap();
    let plan = TutorialSequence::for_scene(&sim);
    let report = demo::run(&mut sim, &plan).unwrap();
    println!("{report:#?}");

    assert!(report.lift >= 0.20, "lifted only {:.3} m", report.lift);
    assert!(
        report.carry_distance >= 0.30,
        "carried only {:.3} m",
        report.carry_distance
    );
    assert!(
        report.carry_slip <= 0.005,
        "cube slipped {:.2} mm in the hand during the carry",
        report.carry_slip * 1e3
    );
    assert!(
        report.grip_width > 0.045 && report.grip_width < 0.052,
        "fingers closed to {:.4} m on a 0.05 m cube: they must touch it, not stop short or pass through",
        report.grip_width
    );
    assert!(
        report.on_platform,
        "the cube does not rest on the platform: {report:?}"
    );
    assert!(
        report.placement_error <= 0.02,
        "placed {:.1} mm from the target",
        report.placement_error * 1e3
    );
    let resting_height = sim.config().platform.top_center[2] + sim.config().cube.size / 2.0;
    assert!(
        (report.final_position.z - resting_height).abs() < 0.003,
        "cube centre at z = {:.4}, expected {:.4} resting on the platform",
        report.final_position.z,
        resting_height
    );
    assert!(
        report.final_speed < 0.01,
        "cube still moving at {} m/s",
        report.final_speed
    );
    assert!(!report.non_finite_seen);
    assert_eq!(report.max_constraints_on_cube, 0);
    assert!(report.max_ik_error < 1e-5);
}

#[test]
fn an_open_hand_does_not_lift_the_cube() {
    // The same motion with the gripper left open: if anything but the fingers' friction
    // carried the cube (a stale contact, an attachment), it would rise.
    let mut sim = Simulation::new(SimConfig::default()).unwrap();
    let mut plan = TutorialSequence::for_scene(&sim);
    plan.grip_force = 0.0;
    let report = demo::run(&mut sim, &plan).unwrap();
    assert!(
        report.lift < 0.01,
        "an open hand lifted the cube {:.3} m",
        report.lift
    );
    assert!(!report.on_platform);
}
