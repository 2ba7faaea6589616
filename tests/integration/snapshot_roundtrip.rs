//! Contract: restoring a snapshot continues bit-identically, including mid-grasp with contacts
//! active, and a snapshot moves between environments built from the same configuration.

use panda_rapier::env::PandaEnv;
use panda_rapier::task::{EnvConfig, ResetOptions};
use panda_rapier::Error;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn continue_bits(env: &mut PandaEnv, actions: &[[f32; 4]]) -> Vec<u32> {
    let mut bits = Vec::new();
    for a in actions {
        let t = env.step(a).unwrap();
        bits.extend(env.observation().iter().map(|x| x.to_bits()));
        bits.push(t.reward.to_bits());
        bits.push(t.truncated as u32);
    }
    // The random stream continues identically too.
    env.reset(None, &ResetOptions::default()).unwrap();
    bits.extend(env.observation().iter().map(|x| x.to_bits()));
    bits
}

#[test]
fn snapshot_continues_bit_identically() {
    let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
    env.reset(Some(5), &ResetOptions::default()).unwrap();
    // Go down onto the cube and close the hand, so contacts and warm-start state are live.
    let cube = env.observation()[..3].to_vec();
    for _ in 0..30 {
        let l = env.layout();
        let tcp = env.observation()[l.slot("tcp_position").unwrap()].to_vec();
        let close = (0..3)
            .map(|i| (cube[i] - tcp[i]).powi(2))
            .sum::<f32>()
            .sqrt()
            < 0.01;
        let mut a = [0.0f32; 4];
        for i in 0..3 {
            a[i] = ((cube[i] - tcp[i]) / 0.05).clamp(-1.0, 1.0);
        }
        a[3] = if close { -1.0 } else { 1.0 };
        env.step(&a).unwrap();
    }
    assert!(
        env.info().flag("is_grasped"),
        "the set-up should hold the cube"
    );

    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let actions: Vec<[f32; 4]> = (0..40)
        .map(|_| {
            std::array::from_fn(|i| {
                if i == 3 {
                    -1.0
                } else {
                    rng.random_range(-1.0..=1.0)
                }
            })
        })
        .collect();
    let snapshot = env.snapshot();
    let first = continue_bits(&mut env, &actions);
    env.restore(&snapshot).unwrap();
    let second = continue_bits(&mut env, &actions);
    assert!(first == second, "restore did not continue identically");

    // Into another env with the same configuration.
    let mut other = PandaEnv::new(EnvConfig::default()).unwrap();
    other.restore(&snapshot).unwrap();
    assert!(continue_bits(&mut other, &actions) == first);

    // Not into a differently configured one.
    let mut different = PandaEnv::new(EnvConfig {
        physics: panda_rapier::PhysicsConfig {
            floor_friction: 0.5,
            ..Default::default()
        },
        ..EnvConfig::default()
    })
    .unwrap();
    assert!(matches!(
        different.restore(&snapshot),
        Err(Error::SnapshotMismatch { .. })
    ));
}
