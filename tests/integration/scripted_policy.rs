//! Contract: the scripted pick-and-place baseline places the cube within the default episode
//! length in both action modes and with both arm models, reads nothing but the observation (the same observation gives
//! the same action, in any environment), and recovers when the cube is taken from its hand.

use panda_rapier::env::PandaEnv;
use panda_rapier::nalgebra::{UnitQuaternion, Vector3};
use panda_rapier::policies::{evaluate, Phase, ScriptedPolicy};
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions};
use panda_rapier::ArmFidelity;

fn config(mode: ControlMode) -> EnvConfig {
    EnvConfig {
        control_mode: mode,
        ..EnvConfig::default()
    }
}

/// Placed in 99.3 % (ee) and 99.7 % (joints) of 1,000 episodes when measured (2026-11-25).
/// At 200 episodes a 98 % bar failed on chance alone: which episodes fail moves with any
/// float-level change of the physics (5 of the first 200 after the hidden joint damping went,
/// 1 with it, the same 99.3-99.4 % over 1,000). Over 1,000 episodes a 99.3 % expert stays
/// above 98.5 % with probability 0.998, and a 97 % one never does.
#[test]
fn places_the_cube_in_at_least_98_5_percent_of_1000_seeded_episodes() {
    for mode in [ControlMode::Ee, ControlMode::Joints] {
        let report = evaluate(&config(mode), 1000, 32, Some(2), 0, |_| {}).unwrap();
        println!(
            "{}: placed {:.1} %, mean {:.1} steps, failed {:?}",
            mode.as_str(),
            100.0 * report.placed_rate(),
            report.summary().mean_steps_to_placed.unwrap_or(f64::NAN),
            report.failed_episodes()
        );
        assert_eq!(report.episodes.len(), 1000);
        assert!(
            report.placed_rate() >= 0.985,
            "{}: placed in {:.1} % of episodes",
            mode.as_str(),
            100.0 * report.placed_rate()
        );
    }
}

#[test]
fn places_the_cube_with_the_kinematic_arm_too() {
    for mode in [ControlMode::Ee, ControlMode::Joints] {
        let cfg = EnvConfig {
            arm: ArmFidelity::Kinematic,
            ..config(mode)
        };
        let report = evaluate(&cfg, 200, 32, Some(2), 0, |_| {}).unwrap();
        println!(
            "kinematic {}: placed {:.1} %, mean {:.1} steps, failed {:?}",
            mode.as_str(),
            100.0 * report.placed_rate(),
            report.summary().mean_steps_to_placed.unwrap_or(f64::NAN),
            report.failed_episodes()
        );
        assert!(
            report.placed_rate() >= 0.98,
            "kinematic {}: placed in {:.1} % of episodes",
            mode.as_str(),
            100.0 * report.placed_rate()
        );
    }
}

#[test]
fn actions_depend_on_the_observation_only() {
    let cfg = config(ControlMode::Joints);
    let mut env = PandaEnv::new(cfg.clone()).unwrap();
    let mut policy = ScriptedPolicy::new(&cfg).unwrap();
    env.reset(Some(3), &ResetOptions::default()).unwrap();
    let mut action = vec![0.0; policy.action_dim()];
    let mut again = action.clone();
    for _ in 0..30 {
        let obs = env.observation().to_vec();
        policy.act(&obs, &mut action).unwrap();
        // A policy that never saw the episode acts the same: nothing is remembered.
        ScriptedPolicy::new(&cfg)
            .unwrap()
            .act(&obs, &mut again)
            .unwrap();
        assert_eq!(action, again);
        env.step(&action).unwrap();
    }
    let batch: Vec<f32> = [env.observation(), env.observation()].concat();
    let mut actions = vec![0.0; 2 * policy.action_dim()];
    policy.act_batch(&batch, &mut actions).unwrap();
    policy.act(env.observation(), &mut action).unwrap();
    assert_eq!(&actions[..action.len()], &action[..]);
    assert_eq!(&actions[action.len()..], &action[..]);
}

#[test]
fn recovers_when_the_cube_is_taken_from_the_hand() {
    let cfg = EnvConfig {
        max_episode_steps: Some(200),
        ..config(ControlMode::Ee)
    };
    let mut env = PandaEnv::new(cfg.clone()).unwrap();
    let mut policy = ScriptedPolicy::new(&cfg).unwrap();
    env.reset(Some(7), &ResetOptions::default()).unwrap();
    let mut action = [0.0f32; 4];
    let mut phases = Vec::new();
    let mut snatched = false;
    let mut placed_at = None;
    for step in 0..200 {
        let phase = policy.act(env.observation(), &mut action).unwrap();
        phases.push(phase);
        if phase == Phase::CARRY && !snatched {
            // Put the cube back on the floor, away from the hand.
            let cube = env.simulation().object("cube").unwrap();
            env.simulation_mut()
                .set_object_pose(
                    cube,
                    &Vector3::new(0.45, -0.15, 0.025),
                    &UnitQuaternion::identity(),
                )
                .unwrap();
            env.refresh().unwrap();
            snatched = true;
            continue;
        }
        let t = env.step(&action).unwrap();
        if t.info.flag("is_placed") {
            placed_at = Some(step);
            break;
        }
    }
    assert!(snatched, "never carried: {phases:?}");
    let after = phases.iter().rposition(|&p| p == Phase::CARRY).unwrap();
    let first_carry = phases.iter().position(|&p| p == Phase::CARRY).unwrap();
    assert!(
        phases[first_carry..after].contains(&Phase::APPROACH),
        "no re-approach after losing the cube: {phases:?}"
    );
    assert!(
        placed_at.is_some(),
        "not placed after the snatch: {phases:?}"
    );
}

#[test]
fn bad_observations_are_errors() {
    let cfg = config(ControlMode::Ee);
    let mut policy = ScriptedPolicy::new(&cfg).unwrap();
    let mut action = [0.0f32; 4];
    assert!(policy.act(&[0.0; 10], &mut action).is_err());
    let mut obs = vec![0.0f32; policy.observation_dim()];
    obs[5] = f32::NAN;
    assert!(policy.act(&obs, &mut action).is_err());
    assert!(policy
        .act(&vec![0.0; policy.observation_dim()], &mut [0.0; 3])
        .is_err());
}
