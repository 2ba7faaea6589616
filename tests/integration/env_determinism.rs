//! Contract: the same seed and actions give bit-identical observations, rewards and flags, for
//! any thread count (1, 2, 4), for environment `i` whatever the number of environments, and for
//! a reset with a seed whatever the environment did before.

use panda_rapier::env::{EeController, EeFrame, PandaEnv};
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_actions(rng: &mut ChaCha8Rng, n: usize) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-1.0f32..=1.0)).collect()
}

/// Everything a vector env outputs over `steps` steps, as bits.
fn vec_rollout(num_envs: usize, threads: usize, steps: usize, config: &EnvConfig) -> Vec<Vec<u32>> {
    let mut env = PandaVecEnv::new(
        config.clone(),
        num_envs,
        Some(threads),
        AutoresetMode::SameStep,
    )
    .unwrap();
    env.reset(Some(7)).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let a = env.action_dim();
    let mut rows: Vec<Vec<u32>> = vec![Vec::new(); num_envs];
    let d = env.observation_dim();
    for _ in 0..steps {
        // Every env gets the same action sequence regardless of N: draw per env from its own rng.
        let mut actions = Vec::with_capacity(num_envs * a);
        let base = random_actions(&mut rng, a);
        for i in 0..num_envs {
            actions.extend(base.iter().map(|x| x * (1.0 - 0.05 * i as f32)));
        }
        env.step(&actions).unwrap();
        for (i, row) in rows.iter_mut().enumerate() {
            row.extend(
                env.observations()[i * d..(i + 1) * d]
                    .iter()
                    .map(|x| x.to_bits()),
            );
            row.push(env.rewards()[i].to_bits());
            row.push(env.terminated()[i] as u32 | (env.truncated()[i] as u32) << 1);
            if env.has_final_observation()[i] {
                row.extend(
                    env.final_observations()[i * d..(i + 1) * d]
                        .iter()
                        .map(|x| x.to_bits()),
                );
            }
        }
    }
    rows
}

fn short_episodes() -> EnvConfig {
    // Short episodes so the autoreset path is exercised too.
    EnvConfig {
        max_episode_steps: Some(12),
        ..EnvConfig::default()
    }
}

/// The default configuration and every other way actions drive the arm: `ee_pose` in both
/// frames, and the operational-space controller for `ee` and `ee_pose`.
fn every_controller() -> Vec<EnvConfig> {
    let with = |control_mode, ee_frame, ee_controller| EnvConfig {
        control_mode,
        ee_frame,
        ee_controller,
        ..short_episodes()
    };
    vec![
        short_episodes(),
        with(ControlMode::EePose, EeFrame::Base, EeController::Ik),
        with(ControlMode::EePose, EeFrame::Hand, EeController::Ik),
        with(ControlMode::Ee, EeFrame::Base, EeController::Osc),
        with(ControlMode::EePose, EeFrame::Hand, EeController::Osc),
    ]
}

#[test]
fn thread_count_does_not_change_results() {
    for config in every_controller() {
        let one = vec_rollout(8, 1, 30, &config);
        for threads in [2, 4] {
            let many = vec_rollout(8, threads, 30, &config);
            assert!(
                one == many,
                "{threads} threads differ from 1 ({:?}, {:?}, {:?})",
                config.control_mode,
                config.ee_frame,
                config.ee_controller
            );
        }
    }
}

#[test]
fn env_i_is_the_same_alone_and_among_sixteen() {
    let config = short_episodes();
    let sixteen = vec_rollout(16, 2, 30, &config);
    let four = vec_rollout(4, 2, 30, &config);
    assert!(
        sixteen[..4] == four[..],
        "the first 4 of 16 envs differ from a 4-env run"
    );

    // Env 5 of the vector env against a standalone env drawing from stream 5.
    let mut alone = PandaEnv::with_index(config.clone(), 5).unwrap();
    alone.reset(Some(7), &ResetOptions::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let mut row = Vec::new();
    for _ in 0..30 {
        let base = random_actions(&mut rng, 4);
        let action: Vec<f32> = base.iter().map(|x| x * (1.0 - 0.05 * 5.0)).collect();
        let t = alone.step(&action).unwrap();
        let done = t.terminated || t.truncated;
        let terminal = alone.observation().to_vec();
        if done {
            alone.reset(None, &ResetOptions::default()).unwrap();
        }
        row.extend(alone.observation().iter().map(|x| x.to_bits()));
        row.push(t.reward.to_bits());
        row.push(t.terminated as u32 | (t.truncated as u32) << 1);
        if done {
            row.extend(terminal.iter().map(|x| x.to_bits()));
        }
    }
    assert!(
        row == sixteen[5],
        "standalone env 5 differs from env 5 of 16"
    );
}

fn episode_bits(env: &mut PandaEnv, seed: u64, steps: usize) -> Vec<u32> {
    env.reset(Some(seed), &ResetOptions::default()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 1000);
    let mut bits: Vec<u32> = env.observation().iter().map(|x| x.to_bits()).collect();
    for _ in 0..steps {
        let action = random_actions(&mut rng, env.action_dim());
        let t = env.step(&action).unwrap();
        bits.extend(env.observation().iter().map(|x| x.to_bits()));
        bits.push(t.reward.to_bits());
    }
    bits
}

#[test]
fn seeded_reset_forgets_history() {
    for mode in ControlMode::ALL {
        let config = EnvConfig {
            control_mode: mode,
            ..EnvConfig::default()
        };
        let mut fresh = PandaEnv::new(config.clone()).unwrap();
        let reference = episode_bits(&mut fresh, 11, 40);
        let mut used = PandaEnv::new(config).unwrap();
        episode_bits(&mut used, 3, 50);
        episode_bits(&mut used, 4, 17);
        assert!(episode_bits(&mut used, 11, 40) == reference, "{mode:?}");
    }
}

#[test]
fn seeds_change_the_episode_and_unseeded_resets_continue_the_stream() {
    let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
    env.reset(Some(1), &ResetOptions::default()).unwrap();
    let first = env.observation().to_vec();
    env.reset(None, &ResetOptions::default()).unwrap();
    let second = env.observation().to_vec();
    env.reset(Some(2), &ResetOptions::default()).unwrap();
    let other_seed = env.observation().to_vec();
    assert_ne!(first, second, "an unseeded reset must draw a new episode");
    assert_ne!(first, other_seed);
    env.reset(Some(1), &ResetOptions::default()).unwrap();
    assert_eq!(env.observation(), &first[..]);
    env.reset(None, &ResetOptions::default()).unwrap();
    assert_eq!(env.observation(), &second[..]);
}
