//! Prints a fingerprint (hash of every observation, reward and info bit) of seeded episodes
//! under random and scripted actions, for every task, both arms and both control modes: run it
//! before and after a change that must not alter behaviour, and compare.
//!
//! `cargo run --release --example fingerprint`

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};

use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions, RewardType, TaskKind};
use panda_rapier::{ArmFidelity, PandaEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    for &task in TaskKind::ALL {
        for arm in [ArmFidelity::Dynamic, ArmFidelity::Kinematic] {
            for mode in [ControlMode::Ee, ControlMode::Joints] {
                let mut config = EnvConfig {
                    task: task.into(),
                    control_mode: mode,
                    reward_type: RewardType::Dense,
                    ..EnvConfig::default()
                };
                config.arm = arm;
                for scripted in [false, true] {
                    let mut env = PandaEnv::new(config.clone())?;
                    let mut policy = ScriptedPolicy::new(&config)?;
                    let mut rng = ChaCha8Rng::seed_from_u64(7);
                    let mut hasher = DefaultHasher::new();
                    let mut action = vec![0.0f32; env.action_dim()];
                    for episode in 0..3u64 {
                        env.reset(Some(100 + episode), &ResetOptions::default())?;
                        hash_step(&mut hasher, env.observation(), 0.0, env.info());
                        for _ in 0..task.descriptor().episode_steps {
                            if scripted {
                                policy.act(env.observation(), &mut action)?;
                            } else {
                                for a in action.iter_mut() {
                                    *a = rng.random_range(-1.0..1.0);
                                }
                            }
                            let t = env.step(&action)?;
                            hash_step(&mut hasher, env.observation(), t.reward, &t.info);
                        }
                    }
                    println!(
                        "{:15} {:9} {:6} {:8} {:016x}",
                        task.as_str(),
                        arm.as_str(),
                        mode.as_str(),
                        if scripted { "scripted" } else { "random" },
                        hasher.finish()
                    );
                }
            }
        }
    }
    Ok(())
}

fn hash_step(
    h: &mut DefaultHasher,
    observation: &[f32],
    reward: f32,
    info: &panda_rapier::task::StepInfo,
) {
    use panda_rapier::task::InfoValue;
    for v in observation {
        v.to_bits().hash(h);
    }
    reward.to_bits().hash(h);
    for (field, value) in info.entries() {
        field.key.hash(h);
        match value {
            InfoValue::Bool(b) => b.hash(h),
            InfoValue::Float(x) => x.to_bits().hash(h),
            InfoValue::Int(n) => n.hash(h),
        }
    }
}
