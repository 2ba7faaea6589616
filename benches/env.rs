//! Criterion benches of the RL environment: one env step (random actions, both control modes),
//! a reset, the vector env at N = 1, 16, 64, 256 on 1 and 2 threads, batched `compute_reward`
//! and the scripted policy's batched actions.
//!
//! `cargo bench --bench env` (throughput is reported as env-steps per second).

use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use panda_rapier::env::PandaEnv;
use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions, RewardType};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Pre-drawn random actions, so drawing them is not timed.
fn random_actions(count: usize, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count).map(|_| rng.random_range(-1.0..=1.0)).collect()
}

fn env_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("env_step");
    group.throughput(Throughput::Elements(1));
    for mode in [ControlMode::Ee, ControlMode::Joints] {
        let config = EnvConfig {
            control_mode: mode,
            ..EnvConfig::default()
        };
        let mut env = PandaEnv::new(config).unwrap();
        env.reset(Some(0), &ResetOptions::default()).unwrap();
        let a = env.action_dim();
        let actions = random_actions(a * 1000, 1);
        let mut k = 0;
        group.bench_function(mode.as_str(), |b| {
            b.iter(|| {
                let action = &actions[(k % 1000) * a..(k % 1000 + 1) * a];
                k += 1;
                let t = env.step(action).unwrap();
                if t.truncated {
                    env.reset(None, &ResetOptions::default()).unwrap();
                }
            })
        });
    }
    group.finish();
}

fn env_reset(c: &mut Criterion) {
    let mut group = c.benchmark_group("env_reset");
    let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
    env.reset(Some(0), &ResetOptions::default()).unwrap();
    let options = ResetOptions::default();
    group.bench_function("restore_and_redraw", |b| {
        b.iter(|| env.reset(None, &options).unwrap().is_success)
    });
    group.bench_function("build_new_env", |b| {
        b.iter(|| PandaEnv::new(EnvConfig::default()).unwrap().action_dim())
    });
    group.finish();
}

fn vector_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("vec_env_step");
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(6));
    for &n in &[1usize, 16, 64, 256] {
        for &threads in &[1usize, 2] {
            let mut env = PandaVecEnv::new(
                EnvConfig::default(),
                n,
                Some(threads),
                AutoresetMode::SameStep,
            )
            .unwrap();
            env.reset(Some(0)).unwrap();
            let a = env.action_dim();
            let batches = 50;
            let actions = random_actions(n * a * batches, 2);
            let mut k = 0;
            group.throughput(Throughput::Elements(n as u64));
            group.bench_with_input(
                BenchmarkId::new(format!("threads_{threads}"), n),
                &n,
                |b, _| {
                    b.iter(|| {
                        let batch = k % batches;
                        k += 1;
                        env.step(&actions[batch * n * a..(batch + 1) * n * a])
                            .unwrap();
                    })
                },
            );
        }
    }
    group.finish();
}

fn compute_reward(c: &mut Criterion) {
    let mut group = c.benchmark_group("compute_reward");
    let n = 2048;
    group.throughput(Throughput::Elements(n as u64));
    let achieved = random_actions(3 * n, 3);
    let desired = random_actions(3 * n, 4);
    let contexts = vec![0.0f32; 7 * n];
    let mut out = vec![0.0f32; n];
    for reward_type in [RewardType::Sparse, RewardType::Dense] {
        let config = EnvConfig {
            reward_type,
            ..EnvConfig::default()
        };
        let env = PandaEnv::new(config).unwrap();
        group.bench_function(format!("{}_batch_{n}", reward_type.as_str()), |b| {
            b.iter(|| {
                env.compute_rewards(&achieved, &desired, &contexts, &mut out)
                    .unwrap()
            })
        });
    }
    group.finish();
}

fn scripted_policy(c: &mut Criterion) {
    let mut group = c.benchmark_group("scripted_policy_batch");
    for mode in [ControlMode::Ee, ControlMode::Joints] {
        let config = EnvConfig {
            control_mode: mode,
            ..EnvConfig::default()
        };
        // Observations from the middle of real episodes, so every phase's code runs.
        let n = 256;
        let mut env =
            PandaVecEnv::new(config.clone(), n, Some(1), AutoresetMode::SameStep).unwrap();
        env.reset(Some(0)).unwrap();
        let mut policy = ScriptedPolicy::new(&config).unwrap();
        let mut actions = vec![0.0; n * policy.action_dim()];
        for _ in 0..20 {
            policy.act_batch(env.observations(), &mut actions).unwrap();
            env.step(&actions).unwrap();
        }
        let observations = env.observations().to_vec();
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(format!("{}_{n}", mode.as_str()), |b| {
            b.iter(|| policy.act_batch(&observations, &mut actions).unwrap())
        });
    }
    group.finish();
}

// criterion_group! generates an undocumented public function.
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group!(
        benches,
        env_step,
        env_reset,
        vector_step,
        compute_reward,
        scripted_policy
    );
}
use group::benches;
criterion_main!(benches);
