//! Contract: the vector env's autoreset modes.
//! - same-step: the step that ends an episode returns the next episode's first observation and
//!   keeps the last one as the final observation (what stable-baselines3 expects);
//! - next-step: the ending step returns the last observation; the next step resets that env,
//!   ignores its action and returns reward 0 (Gymnasium's default);
//! - disabled: stepping an ended env is an error until it is reset.

use panda_rapier::env::PandaEnv;
use panda_rapier::task::{EnvConfig, ResetOptions};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use panda_rapier::Error;

const LEN: u32 = 5;

fn config() -> EnvConfig {
    EnvConfig {
        max_episode_steps: Some(LEN),
        ..EnvConfig::default()
    }
}

fn row(env: &PandaVecEnv, buffer: &[f32], i: usize) -> Vec<f32> {
    let d = env.observation_dim();
    buffer[i * d..(i + 1) * d].to_vec()
}

/// The observations a standalone env 0 goes through: episode 1 (reset + LEN steps), then the
/// first observation of episode 2 (the stream continues).
fn standalone_trajectory(action: &[f32]) -> (Vec<Vec<f32>>, Vec<f32>) {
    let mut env = PandaEnv::with_index(config(), 0).unwrap();
    env.reset(Some(3), &ResetOptions::default()).unwrap();
    let mut obs = vec![env.observation().to_vec()];
    for _ in 0..LEN {
        env.step(action).unwrap();
        obs.push(env.observation().to_vec());
    }
    env.reset(None, &ResetOptions::default()).unwrap();
    (obs, env.observation().to_vec())
}

#[test]
fn same_step_resets_in_the_ending_step_and_keeps_the_final_observation() {
    let action = [0.3f32, -0.2, 0.1, 1.0];
    let (episode, next_first) = standalone_trajectory(&action);
    let mut env = PandaVecEnv::new(config(), 2, Some(1), AutoresetMode::SameStep).unwrap();
    env.reset(Some(3)).unwrap();
    assert_eq!(row(&env, env.observations(), 0), episode[0]);
    let actions: Vec<f32> = action.iter().chain(action.iter()).copied().collect();
    for (t, expected) in episode.iter().enumerate().skip(1) {
        env.step(&actions).unwrap();
        let ending = t == LEN as usize;
        assert_eq!(env.truncated()[0], ending);
        assert!(!env.terminated()[0]);
        assert_eq!(env.has_final_observation()[0], ending);
        if ending {
            assert_eq!(&row(&env, env.final_observations(), 0), expected);
            assert_eq!(row(&env, env.observations(), 0), next_first);
            // The info is the ending step's; the reset's info is kept apart.
            assert_eq!(env.info(0).unwrap().elapsed_steps, LEN);
            assert_eq!(env.reset_info(0).unwrap().elapsed_steps, 0);
        } else {
            assert_eq!(&row(&env, env.observations(), 0), expected);
        }
    }
    // The new episode runs on normally.
    env.step(&actions).unwrap();
    assert!(!env.truncated()[0] && !env.has_final_observation()[0]);
    assert_eq!(env.info(0).unwrap().elapsed_steps, 1);
}

#[test]
fn next_step_returns_the_last_observation_then_resets() {
    let action = [0.3f32, -0.2, 0.1, 1.0];
    let (episode, next_first) = standalone_trajectory(&action);
    let mut env = PandaVecEnv::new(config(), 1, Some(1), AutoresetMode::NextStep).unwrap();
    env.reset(Some(3)).unwrap();
    for (t, expected) in episode.iter().enumerate().skip(1) {
        env.step(&action).unwrap();
        assert_eq!(&row(&env, env.observations(), 0), expected);
        assert_eq!(env.truncated()[0], t == LEN as usize);
        assert!(!env.was_reset()[0]);
    }
    // This action must be ignored: a wild one gives the same result as any other.
    env.step(&[-1.0, -1.0, -1.0, -1.0]).unwrap();
    assert!(env.was_reset()[0]);
    assert_eq!(env.rewards()[0], 0.0);
    assert!(!env.truncated()[0] && !env.terminated()[0]);
    assert_eq!(row(&env, env.observations(), 0), next_first);
    assert!(!env.has_final_observation()[0]);
    env.step(&action).unwrap();
    assert!(!env.was_reset()[0]);
    assert_eq!(env.info(0).unwrap().elapsed_steps, 1);
}

#[test]
fn disabled_requires_an_explicit_reset() {
    let action = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let mut env = PandaVecEnv::new(config(), 2, Some(2), AutoresetMode::Disabled).unwrap();
    env.reset(Some(0)).unwrap();
    for _ in 0..LEN {
        env.step(&action).unwrap();
    }
    assert!(env.truncated().iter().all(|&t| t));
    let before = env.observations().to_vec();
    assert!(matches!(env.step(&action), Err(Error::ResetNeeded { .. })));
    assert_eq!(
        env.observations(),
        &before[..],
        "a refused step must change nothing"
    );
    // Reset only env 1: env 0 still refuses.
    env.reset_masked(&[false, true], &[]).unwrap();
    assert_eq!(env.was_reset(), &[false, true]);
    assert_eq!(
        row(&env, env.observations(), 0),
        before[..env.observation_dim()]
    );
    assert!(matches!(env.step(&action), Err(Error::ResetNeeded { .. })));
    env.reset_masked(&[true, false], &[Some(0), None]).unwrap();
    env.step(&action).unwrap();
    assert!(env.truncated().iter().all(|&t| !t));
}

#[test]
fn terminate_on_success_ends_with_terminated() {
    let config = EnvConfig {
        terminate_on_success: true,
        ..EnvConfig::default()
    };
    let mut env = PandaVecEnv::new(config, 1, Some(1), AutoresetMode::SameStep).unwrap();
    env.reset(Some(0)).unwrap();
    // Put the goal where the cube is: the first step succeeds.
    let cube = env.env(0).unwrap().observation()[..3].to_vec();
    let goal = [cube[0] as f64, cube[1] as f64, cube[2] as f64];
    let options = ResetOptions {
        goal: Some(goal),
        ..ResetOptions::default()
    };
    env.env_mut(0).unwrap().reset(Some(0), &options).unwrap();
    env.step(&[0.0, 0.0, 0.0, 1.0]).unwrap();
    assert!(env.terminated()[0] && !env.truncated()[0]);
    assert!(env.info(0).unwrap().is_success);
    assert_eq!(env.rewards()[0], 0.0);
    assert!(env.has_final_observation()[0]);
}
