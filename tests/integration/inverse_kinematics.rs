//! Inverse kinematics over the work space: every target in the pick-and-place region (x 0.3 to
//! 0.65 m, |y| < 0.3 m, z 0.02 to 0.35 m) with the hand pointing down is solved to 1 um / 10 urad within the joint limits. Prints the
//! solve-time distribution and the errors (timings are reported, never asserted).

use std::time::Instant;

use panda_rapier::demo::hand_down;
use panda_rapier::nalgebra::{UnitQuaternion, Vector3};
use panda_rapier::{IkOptions, RobotModel, PANDA_READY};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn ik_solves_the_work_space_with_the_hand_down() {
    let model = RobotModel::panda().unwrap();
    let base = panda_rapier::nalgebra::Isometry3::identity();
    let options = IkOptions::default();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut times = Vec::new();
    let mut iterations = Vec::new();
    let (mut worst_position, mut worst_orientation) = (0.0f64, 0.0f64);
    for _ in 0..500 {
        let target = Vector3::new(
            rng.random_range(0.3..0.65),
            rng.random_range(-0.3..0.3),
            rng.random_range(0.02..0.35),
        );
        let yaw = rng.random_range(-0.8..0.8);
        let orientation = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw) * hand_down();
        let start = Instant::now();
        let solution = model
            .inverse_kinematics(&target, Some(&orientation), &PANDA_READY, &base, &options)
            .unwrap();
        times.push(start.elapsed().as_secs_f64() * 1e6);
        assert!(
            solution.converged,
            "target {target:?} yaw {yaw}: {:.2e} m, {:.2e} rad",
            solution.position_error, solution.orientation_error
        );
        iterations.push(solution.iterations);
        // Check the answer independently with forward kinematics.
        let reached = model.tcp_pose(&solution.q, &base).unwrap();
        worst_position = worst_position.max((reached.translation.vector - target).norm());
        worst_orientation = worst_orientation.max(reached.rotation.angle_to(&orientation));
        for (&j, &v) in model.actuated_joints().iter().zip(&solution.q) {
            let joint = &model.joints()[j];
            assert!(v >= joint.lower && v <= joint.upper, "{} = {v}", joint.name);
        }
    }
    times.sort_by(f64::total_cmp);
    iterations.sort_unstable();
    println!(
        "IK over 500 targets from the ready pose: median {:.1} us, p95 {:.1} us, median {} iterations (max {}), worst error {:.1e} m / {:.1e} rad",
        times[250], times[475], iterations[250], iterations[499], worst_position, worst_orientation
    );
    assert!(worst_position < 1e-6);
    assert!(worst_orientation < 1e-5);
}

#[test]
fn warm_started_ik_tracks_a_path_in_few_iterations() {
    let model = RobotModel::panda().unwrap();
    let base = panda_rapier::nalgebra::Isometry3::identity();
    let mut q = PANDA_READY.to_vec();
    let start = model.tcp_pose(&q, &base).unwrap().translation.vector;
    let mut most = 0;
    for k in 1..=100 {
        let t = k as f64 / 100.0;
        let target = start + Vector3::new(0.2 * t, -0.3 * t, -0.25 * t);
        let solution = model
            .inverse_kinematics(
                &target,
                Some(&hand_down()),
                &q,
                &base,
                &IkOptions::default(),
            )
            .unwrap()
            .into_result()
            .unwrap();
        most = most.max(solution.iterations);
        q = solution.q;
    }
    println!("warm-started path of 100 waypoints: at most {most} iterations per solve");
    assert!(most <= 10, "{most} iterations for a 4 mm step");
}
