//! Vector-env throughput with random actions: env-steps per second and simulated seconds per
//! wall-clock second for N environments on 1 and 2 threads, the thread counts alternating
//! within one run so the ratio is not skewed by drift.
//!
//! `cargo run --release --example throughput -- [N ...]` (default N = 1 16 64).

use std::time::Instant;

use panda_rapier::task::EnvConfig;
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const STEPS: usize = 100;
const ROUNDS: usize = 3;

fn rate(num_envs: usize, threads: usize) -> panda_rapier::Result<f64> {
    let mut env = PandaVecEnv::new(
        EnvConfig::default(),
        num_envs,
        Some(threads),
        AutoresetMode::SameStep,
    )?;
    env.reset(Some(0))?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let actions: Vec<f32> = (0..STEPS * num_envs * env.action_dim())
        .map(|_| rng.random_range(-1.0..=1.0))
        .collect();
    let row = num_envs * env.action_dim();
    let start = Instant::now();
    for k in 0..STEPS {
        env.step(&actions[k * row..(k + 1) * row])?;
    }
    Ok((STEPS * num_envs) as f64 / start.elapsed().as_secs_f64())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> panda_rapier::Result<()> {
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if sizes.is_empty() {
        vec![1, 16, 64]
    } else {
        sizes
    };
    let period = EnvConfig::default().sim_config()?.physics.solver.dt
        * EnvConfig::default().substeps()? as f64;
    println!("{STEPS} steps of random actions, median of {ROUNDS} alternating rounds");
    println!(
        "{:>5} {:>16} {:>16} {:>8} {:>14}",
        "N", "1 thread /s", "2 threads /s", "ratio", "sim s / s (2)"
    );
    for &n in &sizes {
        let (mut one, mut two) = (Vec::new(), Vec::new());
        for _ in 0..ROUNDS {
            one.push(rate(n, 1)?);
            two.push(rate(n, 2)?);
        }
        let (one, two) = (median(one), median(two));
        println!(
            "{n:>5} {one:>16.0} {two:>16.0} {:>8.2} {:>14.1}",
            two / one,
            two * period
        );
    }
    Ok(())
}
