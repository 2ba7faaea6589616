//! Contract: random actions in both control modes never blow the physics up, never put a NaN
//! into an observation or a reward, and never fling a body faster than a real arm could move
//! it (the fastest Panda link moves at about 2-3 m/s; finger spikes from fingertips dragged
//! along a surface were the reason for `ee_surface_clearance`).

use panda_rapier::task::{ControlMode, EnvConfig};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use panda_rapier::ArmFidelity;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn random_actions_stay_physical() {
    for (mode, arm) in [
        (ControlMode::Ee, ArmFidelity::Dynamic),
        (ControlMode::Joints, ArmFidelity::Dynamic),
        (ControlMode::Ee, ArmFidelity::Kinematic),
        (ControlMode::Joints, ArmFidelity::Kinematic),
    ] {
        let config = EnvConfig {
            control_mode: mode,
            arm,
            max_episode_steps: Some(50),
            ..EnvConfig::default()
        };
        let n = 16;
        let mut env = PandaVecEnv::new(config, n, Some(2), AutoresetMode::SameStep).unwrap();
        env.reset(Some(21)).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(22);
        let mut actions = vec![0.0f32; n * env.action_dim()];
        let mut fastest = 0.0f64;
        let mut episodes = 0;
        for _ in 0..250 {
            for a in actions.iter_mut() {
                *a = rng.random_range(-1.0..=1.0);
            }
            env.step(&actions).unwrap();
            assert!(env.observations().iter().all(|v| v.is_finite()));
            assert!(env.rewards().iter().all(|v| v.is_finite()));
            for i in 0..n {
                assert!(
                    !env.info(i).unwrap().physics_unstable,
                    "{mode:?} {arm:?}: env {i} blew up"
                );
                let (linear, _) = env.env(i).unwrap().simulation().max_body_speeds();
                fastest = fastest.max(linear);
            }
            episodes += env.has_final_observation().iter().filter(|&&f| f).count();
        }
        println!(
            "{mode:?} {arm:?}: {} env steps, {episodes} episodes, fastest body {fastest:.2} m/s",
            n * 250
        );
        assert_eq!(episodes, n * 5, "every 50-step episode ends by truncation");
        assert!(
            fastest < 8.0,
            "{mode:?} {arm:?}: a body reached {fastest:.1} m/s"
        );
    }
}
