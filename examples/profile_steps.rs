//! Steps one environment with random actions, for profilers (callgrind counts instructions
//! reliably on a busy machine, where wall-clock timings drift):
//!
//! `valgrind --tool=callgrind target/release/examples/profile_steps -- [STEPS] [CONFIG.json]`
//!
//! Resets (with seeds 0, 1, ...) whenever an episode ends, so reset cost shows in proportion.

use panda_rapier::env::PandaEnv;
use panda_rapier::task::{EnvConfig, ResetOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() -> panda_rapier::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let steps: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(200);
    let config = match args.get(1) {
        Some(path) => EnvConfig::from_json(&std::fs::read_to_string(path).expect("config file"))?,
        None => EnvConfig::default(),
    };
    let mut env = PandaEnv::new(config)?;
    let options = ResetOptions::default();
    let mut seed = 0;
    env.reset(Some(seed), &options)?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut action = vec![0.0f32; env.action_dim()];
    for _ in 0..steps {
        action
            .iter_mut()
            .for_each(|a| *a = rng.random_range(-1.0..=1.0));
        let t = env.step(&action)?;
        if t.terminated || t.truncated {
            seed += 1;
            env.reset(Some(seed), &options)?;
        }
    }
    println!("{} physics steps", env.simulation().physics_steps());
    Ok(())
}
