//! Criterion benches of the simulation core: one physics step of the scene (arm moving with the
//! cube held, and at rest), one IK solve, and building a world (which resets must avoid).
//!
//! `cargo bench --bench physics`

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use panda_rapier::demo::{self, hand_down, TutorialSequence};
use panda_rapier::nalgebra::Vector3;
use panda_rapier::{IkOptions, SimConfig, Simulation, PANDA_READY};

/// A simulation with the cube lifted in a closed hand.
fn holding_cube() -> Simulation {
    let mut sim = Simulation::new(SimConfig::default()).expect("default scene");
    let plan = TutorialSequence::for_scene(&sim);
    demo::run_until(&mut sim, &plan, Some("lift")).expect("grasp sequence");
    sim
}

/// Steps of one held-cube scene before a fresh one is built: 10 simulated seconds, well within
/// the time the grasp holds under this swing (see `tests/integration/grasp_sequence.rs`).
const STEPS_PER_SCENE: u64 = 1000;

fn physics_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("physics_step");
    group.bench_function("arm_moving_cube_held", |b| {
        // Only the steps are timed; building the held-cube scene is not.
        b.iter_custom(|iters| {
            let mut timed = Duration::ZERO;
            let mut done = 0;
            while done < iters {
                let mut sim = holding_cube();
                let q1 = sim.joint_positions()[0];
                let n = STEPS_PER_SCENE.min(iters - done);
                let start = Instant::now();
                for k in 0..n {
                    let t = k as f64 * sim.config().physics.solver.dt;
                    demo::swing_base_joint(&mut sim, q1, t).unwrap();
                    sim.step();
                }
                timed += start.elapsed();
                assert!(
                    sim.object_contacts(sim.object("cube").unwrap())
                        .robot_links
                        .len()
                        >= 2,
                    "the cube fell out of the hand during the bench"
                );
                done += n;
            }
            timed
        })
    });

    let mut idle = Simulation::new(SimConfig::default()).unwrap();
    group.bench_function("arm_holding_pose_cube_resting", |b| b.iter(|| idle.step()));
    group.finish();
}

fn inverse_kinematics(c: &mut Criterion) {
    let sim = Simulation::new(SimConfig::default()).unwrap();
    let model = sim.model().clone();
    let base = *sim.base_pose();
    let start = model
        .tcp_pose(&PANDA_READY, &base)
        .unwrap()
        .translation
        .vector;
    let down = hand_down();
    let mut group = c.benchmark_group("ik");
    let options = IkOptions::default();
    group.bench_function("control_step_1cm_warm_start", |b| {
        let target = start + Vector3::new(0.01, 0.0, -0.005);
        b.iter(|| {
            let s = model
                .inverse_kinematics(&target, Some(&down), &PANDA_READY, &base, &options)
                .unwrap();
            assert!(s.converged);
            s
        })
    });
    group.bench_function("reach_20cm_away", |b| {
        let target = Vector3::new(0.5, -0.15, 0.275);
        b.iter(|| {
            let s = model
                .inverse_kinematics(&target, Some(&down), &PANDA_READY, &base, &options)
                .unwrap();
            assert!(s.converged);
            s
        })
    });
    group.finish();
}

fn build_world(c: &mut Criterion) {
    c.bench_function("build_world", |b| {
        b.iter_batched(
            SimConfig::default,
            |config| Simulation::new(config).unwrap(),
            BatchSize::SmallInput,
        )
    });
}

// criterion_group! generates an undocumented public function.
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group!(benches, physics_step, inverse_kinematics, build_world);
}
use group::benches;
criterion_main!(benches);
