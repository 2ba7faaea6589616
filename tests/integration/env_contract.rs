//! Contract: rewards, success logic and `compute_reward`, and typed errors for bad input.

use panda_rapier::env::PandaEnv;
use panda_rapier::task::{
    ControlMode, EnvConfig, PickAndPlaceConfig, ResetOptions, RewardType, TaskConfig,
};

/// The pick-and-place task with goals in the air with probability `air`.
fn air_goals(air: f64) -> TaskConfig {
    TaskConfig::PickAndPlace(PickAndPlaceConfig {
        goal_air_probability: air,
        ..PickAndPlaceConfig::default()
    })
}
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use panda_rapier::Error;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn configs() -> Vec<EnvConfig> {
    let mut out = Vec::new();
    for control_mode in [ControlMode::Ee, ControlMode::Joints] {
        for reward_type in [RewardType::Sparse, RewardType::Dense] {
            out.push(EnvConfig {
                control_mode,
                reward_type,
                task: air_goals(0.3),
                ..EnvConfig::default()
            });
        }
    }
    out
}

#[test]
fn compute_reward_reproduces_every_step_reward_and_relabels_goals() {
    for config in configs() {
        let mut env = PandaEnv::new(config.clone()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let (mut achieved, mut desired, mut contexts, mut rewards) =
            (vec![], vec![], vec![], vec![]);
        for episode in 0..3 {
            env.reset(Some(episode), &ResetOptions::default()).unwrap();
            for _ in 0..50 {
                let action: Vec<f32> = (0..env.action_dim())
                    .map(|_| rng.random_range(-1.0..=1.0))
                    .collect();
                let t = env.step(&action).unwrap();
                let obs = env.observation();
                let l = env.layout();
                achieved.extend_from_slice(&obs[l.achieved_goal()]);
                desired.extend_from_slice(&obs[l.desired_goal()]);
                let keys = env.task().descriptor().reward_context_keys;
                let mut row = vec![0.0f32; keys.len()];
                t.info.reward_context(keys, &mut row);
                contexts.extend(row);
                rewards.push(t.reward);
                // The success flag is the threshold test on the reported goals.
                assert_eq!(
                    t.info.is_success,
                    t.info.goal_distance < config.success_threshold
                );
                if config.reward_type == RewardType::Sparse {
                    assert_eq!(t.reward, if t.info.is_success { 0.0 } else { -1.0 });
                } else {
                    let terms = env.task().descriptor().reward_terms;
                    let total: f32 = terms.iter().map(|k| t.info.number(k.info_key) as f32).sum();
                    assert_eq!(t.reward, total);
                }
            }
        }
        let mut batch = vec![0.0; rewards.len()];
        env.compute_rewards(&achieved, &desired, &contexts, &mut batch)
            .unwrap();
        let same = batch
            .iter()
            .zip(&rewards)
            .all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(
            same,
            "{:?}: compute_reward differs from the step reward",
            config.reward_type
        );

        // Relabelled with the achieved goal (HER's "final"/"future" strategies): success.
        let mut relabelled = vec![0.0; rewards.len()];
        env.compute_rewards(&achieved, &achieved, &contexts, &mut relabelled)
            .unwrap();
        match config.reward_type {
            RewardType::Sparse => assert!(relabelled.iter().all(|&r| r == 0.0)),
            RewardType::Dense => {
                // Rows of reward_reach, reward_grasp, reward_lift, ... (pick-and-place's keys).
                for (r, c) in relabelled.iter().zip(contexts.chunks(7)) {
                    let floor = c[0] + c[1] + c[2] + 2.0;
                    assert!(*r >= floor, "{r} < {floor}");
                }
            }
        }
    }
}

#[test]
fn goals_lie_on_or_above_the_platform_and_cubes_start_in_the_pick_region() {
    let config = EnvConfig {
        task: air_goals(0.5),
        ..EnvConfig::default()
    };
    let section = PickAndPlaceConfig::default();
    let mut env = PandaEnv::new(config.clone()).unwrap();
    let rest = config.platform().unwrap().top_center[2] + config.cube().unwrap().size / 2.0;
    let mut in_air = 0;
    for seed in 0..200 {
        env.reset(Some(seed), &ResetOptions::default()).unwrap();
        let goal = panda_rapier::nalgebra::Vector3::from_column_slice(env.goal());
        let g = &section.goal_region;
        assert!(
            goal.x >= g.low[0] && goal.x <= g.high[0] && goal.y >= g.low[1] && goal.y <= g.high[1]
        );
        assert!(goal.z >= rest - 1e-9 && goal.z <= rest + 0.2 + 1e-9);
        if goal.z > rest + 1e-6 {
            in_air += 1;
            assert!(goal.z >= rest + 0.05 - 1e-9);
        }
        let cube = &env.observation()[..3];
        let p = &section.cube_region;
        assert!(cube[0] as f64 >= p.low[0] - 1e-6 && cube[0] as f64 <= p.high[0] + 1e-6);
        assert!(cube[1] as f64 >= p.low[1] - 1e-6 && cube[1] as f64 <= p.high[1] + 1e-6);
        assert!((cube[2] as f64 - config.cube().unwrap().size / 2.0).abs() < 1e-4);
        let info = env.info();
        assert!(!info.is_success && !info.flag("is_grasped") && !info.flag("is_placed"));
    }
    assert!(
        (70..=130).contains(&in_air),
        "{in_air} of 200 goals in the air at p = 0.5"
    );
}

#[test]
fn domain_randomisation_draws_within_its_ranges() {
    let mut config = EnvConfig::default();
    config.randomization.cube_size = Some([0.04, 0.06]);
    config.randomization.cube_mass = Some([0.05, 0.3]);
    config.randomization.cube_friction = Some([0.6, 1.2]);
    config.randomization.joint_noise = 0.05;
    let mut env = PandaEnv::new(config).unwrap();
    let mut sizes = Vec::new();
    for seed in 0..20 {
        env.reset(Some(seed), &ResetOptions::default()).unwrap();
        let (size, mass, friction) = env.simulation().object_properties(cube(&env));
        assert!((0.04..=0.06).contains(&size) && (0.05..=0.3).contains(&mass));
        assert!((0.6..=1.2).contains(&friction));
        // The cube rests on the floor whatever its size.
        assert!((env.observation()[2] as f64 - size / 2.0).abs() < 1e-4);
        sizes.push(size);
    }
    sizes.sort_by(f64::total_cmp);
    assert!(sizes[19] - sizes[0] > 0.01, "sizes barely vary: {sizes:?}");
    // Off again: the default cube, same positions for the same seed.
    let mut plain = PandaEnv::new(EnvConfig::default()).unwrap();
    plain.reset(Some(3), &ResetOptions::default()).unwrap();
    assert!((plain.simulation().object_properties(cube(&plain)).0 - 0.05).abs() < 1e-7);
}

#[test]
fn bad_input_gets_typed_errors() {
    let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
    assert!(matches!(
        env.step(&[0.0; 4]),
        Err(Error::ResetNeeded { .. })
    ));
    env.reset(Some(0), &ResetOptions::default()).unwrap();
    let before = env.observation().to_vec();
    match env.step(&[0.0; 3]) {
        Err(e @ Error::InvalidAction { .. }) => {
            assert_eq!(e.to_string(), "action must have 4 values, got 3")
        }
        other => panic!("expected InvalidAction, got {other:?}"),
    }
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        match env.step(&[0.0, bad, 0.0, 0.0]) {
            Err(Error::InvalidAction { what, reason }) => {
                assert_eq!(what, "action[1]");
                assert_eq!(reason, format!("must be finite, got {bad}"));
            }
            other => panic!("expected InvalidAction, got {other:?}"),
        }
    }
    assert_eq!(
        env.observation(),
        &before[..],
        "a refused step must not move the world"
    );
    // Huge values are clipped, not errors.
    env.step(&[1e30, -1e30, 5.0, -7.0]).unwrap();
    assert!(env.observation().iter().all(|v| v.is_finite()));

    let bad_options = ResetOptions {
        goal: Some([0.5, f64::NAN, 0.1]),
        ..ResetOptions::default()
    };
    match env.reset(None, &bad_options) {
        Err(Error::InvalidOption { what, .. }) => assert_eq!(what, "options.goal[1]"),
        other => panic!("expected InvalidOption, got {other:?}"),
    }
    let short_q = ResetOptions {
        joint_positions: Some(vec![0.0; 3]),
        ..ResetOptions::default()
    };
    assert!(matches!(
        env.reset(None, &short_q),
        Err(Error::InvalidOption { .. })
    ));

    let bad_config = EnvConfig {
        success_threshold: 0.0,
        ..EnvConfig::default()
    };
    assert!(matches!(
        PandaEnv::new(bad_config.clone()),
        Err(Error::InvalidConfig { .. })
    ));
    assert!(matches!(
        PandaVecEnv::new(bad_config, 2, None, AutoresetMode::SameStep),
        Err(Error::InvalidConfig { .. })
    ));
    assert!(matches!(
        PandaVecEnv::new(EnvConfig::default(), 0, None, AutoresetMode::SameStep),
        Err(Error::InvalidConfig { .. })
    ));
    assert!(matches!(
        PandaVecEnv::new(EnvConfig::default(), 2, Some(0), AutoresetMode::SameStep),
        Err(Error::InvalidConfig { .. })
    ));

    let mut vec_env =
        PandaVecEnv::new(EnvConfig::default(), 3, Some(2), AutoresetMode::SameStep).unwrap();
    assert!(matches!(
        vec_env.step(&[0.0; 12]),
        Err(Error::ResetNeeded { .. })
    ));
    vec_env.reset(Some(0)).unwrap();
    match vec_env.step(&[0.0; 11]) {
        Err(e @ Error::InvalidAction { .. }) => assert!(e.to_string().contains("12 values"), "{e}"),
        other => panic!("expected InvalidAction, got {other:?}"),
    }
    let mut actions = [0.0f32; 12];
    actions[9] = f32::NAN;
    let before = vec_env.observations().to_vec();
    match vec_env.step(&actions) {
        Err(Error::InvalidAction { what, .. }) => assert_eq!(what, "action[1] of environment 2"),
        other => panic!("expected InvalidAction, got {other:?}"),
    }
    assert_eq!(
        vec_env.observations(),
        &before[..],
        "no env may move when one action is bad"
    );
    let context = [0.0f32; 7];
    let mut out = [0.0; 1];
    assert!(vec_env
        .compute_rewards(&[0.0; 3], &[0.0; 2], &context, &mut out)
        .is_err());
}

#[test]
fn a_blow_up_truncates_keeps_the_last_valid_observation_and_needs_a_reset() {
    // A speed limit any brisk motion exceeds stands in for a real blow-up: the detector, the
    // truncation and the recovery are what is tested.
    let mut config = EnvConfig::default();
    config.thresholds.unstable_linear_speed = 0.3;
    let mut env = PandaEnv::new(config.clone()).unwrap();
    env.reset(Some(0), &ResetOptions::default()).unwrap();
    let mut blown = None;
    for step in 0..20 {
        let before = env.observation().to_vec();
        let t = env.step(&[1.0, 1.0, 1.0, 1.0]).unwrap();
        if t.info.physics_unstable {
            assert!(t.truncated, "a blow-up must truncate the episode");
            assert_eq!(
                env.observation(),
                &before[..],
                "the last valid observation is kept"
            );
            blown = Some(step);
            break;
        }
        assert!(!t.truncated);
    }
    assert!(blown.is_some(), "the arm never exceeded 0.3 m/s");
    assert!(matches!(
        env.step(&[0.0; 4]),
        Err(Error::ResetNeeded { .. })
    ));
    env.reset(None, &ResetOptions::default()).unwrap();
    env.step(&[0.0; 4]).unwrap();

    // In a vector env the blown-up lane is reset automatically and the others carry on.
    let mut vec_env = PandaVecEnv::new(config, 2, Some(1), AutoresetMode::SameStep).unwrap();
    vec_env.reset(Some(0)).unwrap();
    let mut resets = 0;
    for _ in 0..20 {
        vec_env
            .step(&[1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0])
            .unwrap();
        assert!(vec_env.observations().iter().all(|v| v.is_finite()));
        if vec_env.has_final_observation()[0] {
            assert!(vec_env.info(0).unwrap().physics_unstable && vec_env.truncated()[0]);
            resets += 1;
        }
        assert!(
            !vec_env.has_final_observation()[1],
            "the calm env must not be reset"
        );
    }
    assert!(resets >= 1);
}

#[test]
fn control_frequency_sets_the_step_duration() {
    for (hz, dt) in [(25.0, 0.04), (50.0, 0.02), (10.0, 0.1)] {
        let config = EnvConfig {
            control_frequency: hz,
            ..EnvConfig::default()
        };
        let mut env = PandaEnv::new(config).unwrap();
        assert!((env.dt() - dt).abs() < 1e-12, "{hz} Hz: dt {}", env.dt());
        env.reset(Some(0), &ResetOptions::default()).unwrap();
        let t0 = env.simulation().time();
        env.step(&[0.0; 4]).unwrap();
        assert!((env.simulation().time() - t0 - dt).abs() < 1e-9);
    }
}

#[test]
fn refresh_follows_a_teleported_cube() {
    let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
    assert!(matches!(env.refresh(), Err(Error::ResetNeeded { .. })));
    env.reset(Some(0), &ResetOptions::default()).unwrap();
    let goal = panda_rapier::nalgebra::Vector3::from_column_slice(env.goal());
    let cube = cube(&env);
    env.simulation_mut()
        .set_object_pose(
            cube,
            &goal,
            &panda_rapier::nalgebra::UnitQuaternion::identity(),
        )
        .unwrap();
    assert!(!env.info().is_success, "the info is stale until refreshed");
    let info = *env.refresh().unwrap();
    assert!(info.is_success && info.goal_distance < 1e-6);
    assert_eq!(&env.observation()[..3], &env.observation()[3..6]);
}

/// The pick-and-place cube of `env`'s world.
fn cube(env: &PandaEnv) -> panda_rapier::ObjectId {
    env.simulation().object("cube").unwrap()
}
