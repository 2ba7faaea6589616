//! Contract: stepping a vector env allocates nothing beyond what the physics engine itself
//! allocates. rapier builds small per-step buffers inside its multibody solver; everything of
//! ours is preallocated (observation and output buffers, IK workspace, joint scratch).
//!
//! The env's steps are counted (dhat's testing mode counts every heap block), then the same
//! physics is replayed from a snapshot with the recorded joint commands: the env may not add
//! allocations of its own.

use panda_rapier::task::{ControlMode, EnvConfig};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use panda_rapier::JointControl;

#[global_allocator]
static ALLOC: dhat::Alloc = dhat::Alloc;

fn blocks() -> u64 {
    dhat::HeapStats::get().total_blocks
}

const STEPS: usize = 60;

#[test]
fn env_steps_allocate_only_what_the_physics_allocates() {
    let _profiler = dhat::Profiler::builder().testing().build();
    for mode in [ControlMode::Ee, ControlMode::Joints] {
        let config = EnvConfig {
            control_mode: mode,
            max_episode_steps: Some(10_000),
            ..EnvConfig::default()
        };
        let substeps = config.substeps().unwrap();
        let mut env = PandaVecEnv::new(config, 1, Some(1), AutoresetMode::SameStep).unwrap();
        env.reset(Some(0)).unwrap();
        let actions: Vec<Vec<f32>> = (0..STEPS)
            .map(|t| {
                (0..env.action_dim())
                    .map(|i| ((t * 7 + i * 3) % 11) as f32 / 5.0 - 1.0)
                    .collect()
            })
            .collect();
        // One step first: the IK workspace is sized on first use.
        env.step(&actions[0]).unwrap();
        let snapshot = env.env(0).unwrap().snapshot();
        let num_dofs = env.env(0).unwrap().simulation().model().num_dofs();
        let mut commands = vec![vec![JointControl::Torque(0.0); num_dofs]; STEPS];

        let before = blocks();
        for (action, command) in actions.iter().zip(commands.iter_mut()) {
            env.step(action).unwrap();
            command.copy_from_slice(env.env(0).unwrap().simulation().joint_controls());
        }
        let env_blocks = blocks() - before;

        let lane = env.env_mut(0).unwrap();
        lane.restore(&snapshot).unwrap();
        let sim = lane.simulation_mut();
        let before = blocks();
        for command in &commands {
            sim.set_joint_controls(command).unwrap();
            for _ in 0..substeps {
                sim.step();
            }
        }
        let physics_blocks = blocks() - before;
        println!(
            "{mode:?}: {:.1} allocations per env step, the physics alone {:.1}",
            env_blocks as f64 / STEPS as f64,
            physics_blocks as f64 / STEPS as f64
        );
        // Not exactly equal: a restored world's buffers start with other capacities, so rapier
        // regrows them at other moments. One allocation of ours per step would add STEPS.
        assert!(
            env_blocks <= physics_blocks + (STEPS / 4) as u64,
            "{mode:?}: the env allocates on its own: {env_blocks} blocks vs {physics_blocks}"
        );
    }
}
