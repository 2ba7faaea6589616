//! The environment contracts, for every task ([`TaskKind::ALL`]): determinism across thread
//! counts and batch sizes, snapshot round trips, typed errors for bad input, `compute_reward`
//! reproducing every step reward, the observation schema, and the scripted expert solving the
//! task. One parametrised copy of each check, not one per task.

use panda_rapier::env::PandaEnv;
use panda_rapier::policies::{evaluate, ScriptedPolicy};
use panda_rapier::task::{
    ControlMode, EnvConfig, InfoValue, ObservationLayout, ResetOptions, RewardType, StackConfig,
    TaskConfig, TaskKind,
};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use panda_rapier::{ArmFidelity, Error};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn config(task: TaskKind, control_mode: ControlMode, reward_type: RewardType) -> EnvConfig {
    EnvConfig {
        task: task.into(),
        control_mode,
        reward_type,
        ..EnvConfig::default()
    }
}

fn random_actions(rng: &mut ChaCha8Rng, n: usize) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-1.0..=1.0)).collect()
}

/// Observation and reward bits of environment `lane` of a vector env of `num_envs` on
/// `threads` threads, under seeded random actions (every environment gets its own row).
fn lane_bits(config: &EnvConfig, num_envs: usize, threads: usize, lane: usize) -> Vec<u32> {
    let mut envs = PandaVecEnv::new(
        config.clone(),
        num_envs,
        Some(threads),
        AutoresetMode::NextStep,
    )
    .unwrap();
    envs.reset(Some(11)).unwrap();
    let d = envs.observation_dim();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut bits = Vec::new();
    for _ in 0..25 {
        // Lane `lane` sees the same actions whatever the batch size.
        let row = random_actions(&mut rng, envs.action_dim());
        let actions: Vec<f32> = (0..num_envs).flat_map(|_| row.iter().copied()).collect();
        envs.step(&actions).unwrap();
        let obs = &envs.observations()[lane * d..(lane + 1) * d];
        bits.extend(obs.iter().map(|x| x.to_bits()));
        bits.push(envs.rewards()[lane].to_bits());
    }
    bits
}

#[test]
fn every_task_is_deterministic_across_threads_and_batch_sizes() {
    for &task in TaskKind::ALL {
        let config = config(task, ControlMode::Ee, RewardType::Dense);
        let alone = lane_bits(&config, 1, 1, 0);
        assert_eq!(alone, lane_bits(&config, 3, 1, 0), "{task:?}: batch of 3");
        assert_eq!(alone, lane_bits(&config, 3, 2, 0), "{task:?}: two threads");
    }
}

#[test]
fn every_task_continues_bit_identically_from_a_snapshot() {
    for &task in TaskKind::ALL {
        let mut env = PandaEnv::new(config(task, ControlMode::Joints, RewardType::Dense)).unwrap();
        env.reset(Some(2), &ResetOptions::default()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for _ in 0..10 {
            env.step(&random_actions(&mut rng, env.action_dim()))
                .unwrap();
        }
        let snapshot = env.snapshot();
        let actions: Vec<Vec<f32>> = (0..15)
            .map(|_| random_actions(&mut rng, env.action_dim()))
            .collect();
        let run = |env: &mut PandaEnv| {
            let mut bits = Vec::new();
            for a in &actions {
                let t = env.step(a).unwrap();
                bits.extend(env.observation().iter().map(|x| x.to_bits()));
                bits.push(t.reward.to_bits());
            }
            bits
        };
        let first = run(&mut env);
        env.restore(&snapshot).unwrap();
        assert_eq!(first, run(&mut env), "{task:?}");
    }
}

#[test]
fn every_task_refuses_bad_input_with_typed_errors() {
    for &task in TaskKind::ALL {
        let mut env = PandaEnv::new(config(task, ControlMode::Ee, RewardType::Sparse)).unwrap();
        assert!(
            matches!(env.step(&[0.0; 4]), Err(Error::ResetNeeded { .. })),
            "{task:?}"
        );
        env.reset(Some(0), &ResetOptions::default()).unwrap();
        assert!(matches!(
            env.step(&[0.0; 3]),
            Err(Error::InvalidAction { .. })
        ));
        assert!(matches!(
            env.step(&[0.0, f32::NAN, 0.0, 0.0]),
            Err(Error::InvalidAction { .. })
        ));
        let options = ResetOptions {
            goal: Some([0.5, f64::INFINITY, 0.2]),
            ..ResetOptions::default()
        };
        assert!(matches!(
            env.reset(Some(0), &options),
            Err(Error::InvalidOption { .. })
        ));
        let mut out = [0.0f32; 1];
        assert!(env
            .compute_rewards(&[0.0; 3], &[0.0; 2], &[0.0; 7], &mut out)
            .is_err());
        assert!(env
            .compute_rewards(&[f32::NAN, 0.0, 0.0], &[0.0; 3], &[], &mut out)
            .is_err());
        // The environment still works after refusing.
        env.reset(Some(0), &ResetOptions::default()).unwrap();
        env.step(&[0.0; 4]).unwrap();
    }
}

#[test]
fn every_task_reproduces_its_step_rewards_from_goals_and_infos() {
    for &task in TaskKind::ALL {
        // The dense reward with its default weights, and with every term on (the terms that
        // are off by default, such as `release` and Stack's `lift`, included).
        for (reward_type, all_terms) in [
            (RewardType::Sparse, false),
            (RewardType::Dense, false),
            (RewardType::Dense, true),
        ] {
            let mut config = config(task, ControlMode::Ee, reward_type);
            if all_terms {
                let terms = task.descriptor().reward_terms;
                config.reward_weights = terms.iter().map(|t| (t.name.to_string(), 1.5)).collect();
            }
            let mut env = PandaEnv::new(config).unwrap();
            let layout = env.layout().clone();
            let mut policy = ScriptedPolicy::new(env.config()).unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(4);
            let (mut achieved, mut desired, mut contexts, mut rewards) =
                (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            let keys = env.task().descriptor().reward_context_keys;
            let lift_key = keys.iter().position(|k| *k == "reward_lift");
            let mut most_lift = 0.0f32;
            for episode in 0..2 {
                env.reset(Some(episode), &ResetOptions::default()).unwrap();
                let mut action = vec![0.0; env.action_dim()];
                for step in 0..80 {
                    // Expert and random steps, so successes and failures are both covered.
                    if step % 3 == 0 {
                        action = random_actions(&mut rng, env.action_dim());
                    } else {
                        policy.act(env.observation(), &mut action).unwrap();
                    }
                    let t = env.step(&action).unwrap();
                    achieved.extend_from_slice(&env.observation()[layout.achieved_goal()]);
                    desired.extend_from_slice(&env.observation()[layout.desired_goal()]);
                    let mut row = vec![0.0f32; keys.len()];
                    t.info.reward_context(keys, &mut row);
                    if let Some(k) = lift_key {
                        most_lift = most_lift.max(row[k]);
                    }
                    contexts.extend(row);
                    rewards.push(t.reward);
                }
            }
            let mut batch = vec![0.0; rewards.len()];
            env.compute_rewards(&achieved, &desired, &contexts, &mut batch)
                .unwrap();
            let same = batch
                .iter()
                .zip(&rewards)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{task:?} {reward_type:?}: compute_reward differs");
            // A lift term read back from the info pays once the expert lifts the cube.
            if all_terms && lift_key.is_some() {
                assert!(most_lift > 0.0, "{task:?}: the lift term never paid");
            }
            // Relabelled with the achieved goal (HER): success, and never less reward.
            let mut relabelled = vec![0.0; rewards.len()];
            env.compute_rewards(&achieved, &achieved, &contexts, &mut relabelled)
                .unwrap();
            for (r, original) in relabelled.iter().zip(&rewards) {
                assert!(r >= original, "{task:?} {reward_type:?}: {r} < {original}");
                if reward_type == RewardType::Sparse {
                    assert_eq!(*r, 0.0);
                }
            }
        }
    }
}

#[test]
fn every_task_lays_its_observation_out_as_its_schema_says() {
    for &task in TaskKind::ALL {
        let config = config(task, ControlMode::Ee, RewardType::Sparse);
        let mut env = PandaEnv::new(config.clone()).unwrap();
        let layout = ObservationLayout::for_config(&config).unwrap();
        assert_eq!(&layout, env.layout(), "{task:?}");
        assert_eq!(env.task().name(), task.as_str());
        // `ee` targets keep clear of the platform exactly in the tasks that have it, and the
        // descriptor says so.
        assert_eq!(
            env.task().scene(&config).platform.as_ref(),
            config.platform()
        );
        assert_eq!(config.has_platform(), task.descriptor().has_platform);
        env.reset(Some(1), &ResetOptions::default()).unwrap();
        let obs = env.observation();
        assert_eq!(obs.len(), layout.flat_dim());
        // The goal slot holds the environment's goal.
        for (seen, goal) in obs[layout.desired_goal()].iter().zip(env.goal()) {
            assert_eq!(*seen, *goal as f32);
        }
        let tcp = env.simulation().tcp_state().position;
        for (seen, real) in obs[layout.slot("tcp_position").unwrap()]
            .iter()
            .zip(tcp.iter())
        {
            assert_eq!(*seen, *real as f32);
        }
    }
}

/// Success (pick-and-place: placed) rate of the scripted expert over `episodes` seeded episodes.
fn expert_rate(task: TaskKind, mode: ControlMode, arm: ArmFidelity, episodes: usize) -> f64 {
    let mut config = config(task, mode, RewardType::Sparse);
    config.arm = arm;
    config.max_episode_steps = Some(task.descriptor().episode_steps);
    let report = evaluate(&config, episodes, 25, Some(2), 0, |_| {}).unwrap();
    if task == TaskKind::PickAndPlace {
        report.placed_rate()
    } else {
        report.success_rate()
    }
}

#[test]
fn the_scripted_expert_solves_every_task() {
    // The same 100 seeded episodes per task, mode and arm every run. The bar of 99 % in `ee`
    // control and 95 % in `joints` holds over 1,000 episodes (`docs/benchmarks.md`); on these
    // 100, one `ee` failure is allowed (Push with the kinematic arm has one).
    for task in [
        TaskKind::Reach,
        TaskKind::Lift,
        TaskKind::Push,
        TaskKind::Stack,
    ] {
        for arm in [ArmFidelity::Dynamic, ArmFidelity::Kinematic] {
            let ee = expert_rate(task, ControlMode::Ee, arm, 100);
            let joints = expert_rate(task, ControlMode::Joints, arm, 100);
            assert!(ee >= 0.98, "{task:?} {arm:?} ee: {ee}");
            assert!(joints >= 0.95, "{task:?} {arm:?} joints: {joints}");
        }
    }
}

#[test]
fn the_peg_insertion_expert_inserts_the_peg_in_its_ids_action_modes() {
    // The task's ids turn the hand: `ee_pose` actions, and `joints` at 0.1 rad per step. Over
    // 1,000 seeds the expert inserts in 100.0 % and 99.7 % (`docs/tasks/peg_insertion.md`);
    // on these 100 seeded episodes, at most one failure per mode.
    let task = TaskKind::PegInsertion;
    for (mode, joint_step) in [(ControlMode::EePose, 0.05), (ControlMode::Joints, 0.1)] {
        let mut config = config(task, mode, RewardType::Sparse);
        config.joint_step = joint_step;
        config.max_episode_steps = Some(task.descriptor().episode_steps);
        let report = evaluate(&config, 100, 25, Some(2), 0, |_| {}).unwrap();
        assert!(
            report.success_rate() >= 0.99,
            "{mode:?}: {}",
            report.success_rate()
        );
    }
}

#[test]
fn the_pick_object_expert_places_the_shipped_objects_in_its_ids_action_modes() {
    // The task's ids turn the hand: `ee_pose` actions, and `joints` at 0.1 rad per step. Over
    // seeds 1000-1999 the expert places 90.3 % and 92.0 % (`examples/pick_object_eval.rs`;
    // the bottle, held by its neck, about 70 % of the time); on these 100 seeded episodes
    // (89 and 94 placed), the bars below are a few episodes under what it does.
    let task = TaskKind::PickObject;
    for (mode, joint_step, bar) in [
        (ControlMode::EePose, 0.05, 0.86),
        (ControlMode::Joints, 0.1, 0.9),
    ] {
        let mut config = config(task, mode, RewardType::Sparse);
        config.joint_step = joint_step;
        config.max_episode_steps = Some(task.descriptor().episode_steps);
        let report = evaluate(&config, 100, 25, Some(2), 0, |_| {}).unwrap();
        let placed = report.placed_rate();
        println!("{mode:?}: placed {placed}");
        assert!(placed >= bar, "{mode:?}: {placed}");
    }
}

#[test]
fn the_open_drawer_expert_opens_the_drawer_in_its_ids_action_modes() {
    // Over seeds 0-999 the expert opens the drawer to the goal in 100 % (`ee_pose`) and 99.9 %
    // (`joints`) of episodes (scripts/expert_figures.py); every one of these 100 is the bar.
    let task = TaskKind::OpenDrawer;
    for (mode, joint_step) in [(ControlMode::EePose, 0.05), (ControlMode::Joints, 0.1)] {
        let mut config = config(task, mode, RewardType::Sparse);
        config.joint_step = joint_step;
        config.max_episode_steps = Some(task.descriptor().episode_steps);
        let report = evaluate(&config, 100, 25, Some(2), 0, |_| {}).unwrap();
        let success = report.success_rate();
        println!("{mode:?}: success {success}");
        assert!(success >= 0.99, "{mode:?}: {success}");
    }
}

/// Stack's `stage` term (off by default), with the weight its documentation names (3, and
/// `lift` 1): the scripted expert's stacks reach all four milestones (one more with each of
/// `task.stage_at_rest` and `task.stage_let_go`), and each milestone, the first step it holds,
/// pays more than any step before it (letting go of each cube included).
#[test]
fn stack_s_stage_term_pays_each_milestone_more_than_any_step_before_it() {
    let weight = 3.0;
    for (at_rest, let_go, seed) in [
        (false, false, 0),
        (false, false, 1),
        (false, false, 2),
        (false, false, 3),
        (true, false, 0),
        (true, false, 1),
        (false, true, 0),
        (false, true, 1),
        (true, true, 0),
        (true, true, 1),
    ] {
        stage_milestones_pay_more(weight, at_rest, let_go, seed);
    }
}

/// `StackDense` (`ee`) with these reward weights and Stack's optional milestones.
fn stack_dense(weights: &[(&str, f64)], at_rest: bool, let_go: bool) -> EnvConfig {
    let mut config = config(TaskKind::Stack, ControlMode::Ee, RewardType::Dense);
    config.reward_weights = weights
        .iter()
        .map(|&(name, w)| (name.to_string(), w))
        .collect();
    config.task = TaskConfig::Stack(StackConfig {
        stage_at_rest: at_rest,
        stage_let_go: let_go,
        ..StackConfig::default()
    });
    config
}

fn stage_milestones_pay_more(weight: f64, at_rest: bool, let_go: bool, seed: u64) {
    let config = stack_dense(&[("stage", weight), ("lift", 1.0)], at_rest, let_go);
    let mut env = PandaEnv::new(config).unwrap();
    let mut policy = ScriptedPolicy::new(env.config()).unwrap();
    {
        env.reset(Some(seed), &ResetOptions::default()).unwrap();
        let mut action = vec![0.0; env.action_dim()];
        let (mut reached, mut best) = (0, f32::NEG_INFINITY);
        for step in 0..TaskKind::Stack.descriptor().episode_steps {
            policy.act(env.observation(), &mut action).unwrap();
            let t = env.step(&action).unwrap();
            let Some(InfoValue::Float(stage)) = t.info.get("reward_stage") else {
                panic!("no reward_stage in Stack's info");
            };
            let milestones = (stage / weight).round() as usize;
            assert_eq!(stage, milestones as f64 * weight, "seed {seed} step {step}");
            if milestones > reached {
                assert!(
                    t.reward > best,
                    "seed {seed} step {step}: milestone {milestones} pays {} after {best}",
                    t.reward
                );
                reached = milestones;
            }
            best = best.max(t.reward);
        }
        let all = 4 + usize::from(at_rest) + usize::from(let_go);
        assert_eq!(
            reached, all,
            "seed {seed}, at rest {at_rest}, let go {let_go}: the expert's stack reached \
             {reached} milestones"
        );
    }
}

/// Stack's `release` term (off by default): along the scripted expert's stacks it pays its
/// weight times the commanded gripper opening exactly while cube2 is within the threshold
/// with cube1 placed and let go and both cubes at rest (with `task.stage_at_rest`), and 0
/// otherwise; it pays while the expert opens its hand on the stack; `compute_reward`
/// recomputes every step's reward with it bit for bit; and at weight 0 the rewards are the
/// id's own.
#[test]
fn stack_s_release_term_pays_the_opening_while_cube2_is_ready_to_be_let_go() {
    let (weight, threshold) = (2.0, EnvConfig::default().success_threshold as f32);
    let with = |release: f64| {
        stack_dense(
            &[("stage", 3.0), ("lift", 1.0), ("release", release)],
            true,
            true,
        )
    };
    for seed in [0, 1] {
        let mut rewards = [vec![], vec![]];
        let (mut achieved, mut desired, mut contexts) = (vec![], vec![], vec![]);
        let mut paid = 0;
        for (k, release) in [0.0, weight].into_iter().enumerate() {
            let mut env = PandaEnv::new(with(release)).unwrap();
            let mut policy = ScriptedPolicy::new(env.config()).unwrap();
            env.reset(Some(seed), &ResetOptions::default()).unwrap();
            let mut action = vec![0.0; env.action_dim()];
            let keys = env.task().descriptor().reward_context_keys;
            for step in 0..TaskKind::Stack.descriptor().episode_steps {
                policy.act(env.observation(), &mut action).unwrap();
                let t = env.step(&action).unwrap();
                rewards[k].push(t.reward);
                let (l, obs) = (env.layout(), env.observation());
                let (a, d) = (&obs[l.achieved_goal()], &obs[l.desired_goal()]);
                let gap = |i: usize| {
                    (0..3)
                        .map(|j| (a[3 * i + j] - d[3 * i + j]).powi(2))
                        .sum::<f32>()
                        .sqrt()
                };
                let ready = gap(0) < threshold
                    && !t.info.flag("cube1_grasped")
                    && gap(1) < threshold
                    && t.info.flag("cube_at_rest");
                let opening = t.info.number("gripper_opening");
                let expected = if ready { release * opening } else { 0.0 };
                let term = t.info.number("reward_release");
                assert_eq!(term, expected, "seed {seed} step {step} weight {release}");
                paid += usize::from(term > 0.0);
                if release > 0.0 {
                    achieved.extend_from_slice(a);
                    desired.extend_from_slice(d);
                    let mut row = vec![0.0f32; keys.len()];
                    t.info.reward_context(keys, &mut row);
                    contexts.extend(row);
                }
            }
            if release > 0.0 {
                let mut batch = vec![0.0; rewards[k].len()];
                env.compute_rewards(&achieved, &desired, &contexts, &mut batch)
                    .unwrap();
                let bits = |r: &[f32]| r.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&batch), bits(&rewards[k]), "seed {seed}");
            }
        }
        assert!(paid > 0, "seed {seed}: the expert's release paid nothing");
        // Only the release term differs between the two weights.
        let differ = rewards[0].iter().zip(&rewards[1]).filter(|(a, b)| a != b);
        assert_eq!(differ.count(), paid, "seed {seed}");
    }
    let mut id =
        PandaEnv::new(config(TaskKind::Stack, ControlMode::Ee, RewardType::Dense)).unwrap();
    id.reset(Some(0), &ResetOptions::default()).unwrap();
    let t = id.step(&[0.0, 0.0, 0.0, 1.0]).unwrap();
    assert_eq!(t.info.number("reward_release"), 0.0);
}

/// Stack's start-state curriculum (`task.cube1_on_goal_probability`): cube1 starts resting on
/// its goal in about that share of episodes and nowhere near it otherwise; at 0 the episodes
/// are bit for bit the id's; a probability outside [0, 1] is refused by name.
#[test]
fn stack_s_cube1_starts_on_its_goal_with_the_curriculum_s_probability() {
    let with = |p: f64| {
        let mut config = config(TaskKind::Stack, ControlMode::Ee, RewardType::Dense);
        config.task = TaskConfig::Stack(StackConfig {
            cube1_on_goal_probability: p,
            ..StackConfig::default()
        });
        config
    };
    let starts = |config: EnvConfig, episodes: u64| {
        let mut env = PandaEnv::new(config).unwrap();
        let layout = env.layout().clone();
        (0..episodes)
            .map(|seed| {
                env.reset(Some(seed), &ResetOptions::default()).unwrap();
                let obs = env.observation();
                let (a, d) = (&obs[layout.achieved_goal()], &obs[layout.desired_goal()]);
                let gap = (0..3).map(|i| (a[i] - d[i]).powi(2)).sum::<f32>().sqrt();
                (gap, obs.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
            })
            .collect::<Vec<_>>()
    };
    let default = config(TaskKind::Stack, ControlMode::Ee, RewardType::Dense);
    assert_eq!(starts(with(0.0), 20), starts(default, 20));
    let on_goal = |p: f64| {
        let gaps = starts(with(p), 200);
        assert!(
            gaps.iter().all(|(g, _)| *g < 1e-3 || *g > 0.05),
            "p {p}: cube1's distances to its goal {:?}",
            gaps.iter().map(|(g, _)| g).collect::<Vec<_>>()
        );
        gaps.iter().filter(|(g, _)| *g < 1e-3).count()
    };
    assert_eq!(on_goal(1.0), 200);
    let half = on_goal(0.5);
    assert!((70..=130).contains(&half), "p 0.5: {half} of 200");
    for bad in [1.5, -0.1, f64::NAN] {
        let Err(err) = PandaEnv::new(with(bad)) else {
            panic!("cube1_on_goal_probability {bad} was accepted");
        };
        let message = err.to_string();
        assert!(
            message.contains("task.cube1_on_goal_probability"),
            "{message}"
        );
    }
}

/// Stack's `task.reward_distance_rate` and `task.reach_hover_height`: `reach` and `carry` are
/// `1 - tanh(k d)` with the rate given (5 by default), `reach` aims `min(h, horizontal
/// distance)` above the handled cube (0 by default), `compute_reward` recomputes the reward
/// with them, the episode itself does not change, and values out of range are refused by name.
#[test]
fn stack_s_reach_and_carry_fall_off_at_the_distance_rate_and_hover_height_given() {
    let with = |rate: f64, hover: f64| {
        let mut config = config(TaskKind::Stack, ControlMode::Ee, RewardType::Dense);
        config.task = TaskConfig::Stack(StackConfig {
            reward_distance_rate: rate,
            reach_hover_height: hover,
            ..StackConfig::default()
        });
        config
    };
    let threshold = EnvConfig::default().success_threshold;
    let run = |config: EnvConfig, rate: f32, hover: f32| {
        let mut env = PandaEnv::new(config).unwrap();
        let mut policy = ScriptedPolicy::new(env.config()).unwrap();
        let layout = env.layout().clone();
        let keys = env.task().descriptor().reward_context_keys;
        let cube = |k: usize| layout.slot(&format!("cube{k}_relative_position")).unwrap();
        let closeness = |d: f32| 1.0 - (rate * d).tanh();
        let norm = |v: &[f32]| v.iter().map(|x| x * x).sum::<f32>().sqrt();
        let float = |info: &panda_rapier::task::StepInfo, key: &str| match info.get(key) {
            Some(InfoValue::Float(v)) => v as f32,
            other => panic!("{key}: {other:?}"),
        };
        let (mut bits, mut second_handled) = (Vec::new(), 0);
        let mut action = vec![0.0; env.action_dim()];
        env.reset(Some(0), &ResetOptions::default()).unwrap();
        for step in 0..TaskKind::Stack.descriptor().episode_steps {
            policy.act(env.observation(), &mut action).unwrap();
            let t = env.step(&action).unwrap();
            let obs = env.observation();
            let (a, g) = (&obs[layout.achieved_goal()], &obs[layout.desired_goal()]);
            let d = [
                norm(&[a[0] - g[0], a[1] - g[1], a[2] - g[2]]),
                norm(&[a[3] - g[3], a[4] - g[4], a[5] - g[5]]),
            ];
            let handled = if (d[0] as f64) < threshold { 2 } else { 1 };
            let r = &obs[cube(handled)];
            let horizontal = norm(&r[..2]);
            let reach = closeness(norm(&[r[0], r[1], r[2] + hover.min(horizontal)]));
            // `carry`'s default weight is 2 (`reach`'s 1): the mean over the two cubes, doubled.
            let carry = closeness(d[0]) + closeness(d[1]);
            assert!(
                (float(&t.info, "reward_reach") - reach).abs() < 1e-4,
                "step {step}"
            );
            assert!(
                (float(&t.info, "reward_carry") - carry).abs() < 1e-4,
                "step {step}"
            );
            let mut row = vec![0.0f32; keys.len()];
            t.info.reward_context(keys, &mut row);
            let mut out = [0.0f32];
            env.compute_rewards(a, g, &row, &mut out).unwrap();
            assert_eq!(out[0], t.reward, "step {step}");
            second_handled += usize::from(handled == 2);
            bits.extend(obs.iter().map(|x| x.to_bits()));
        }
        // The expert places cube1, so `reach` was checked against cube2 as well.
        assert!(second_handled > 0, "reach never aimed at cube2");
        bits
    };
    let default = run(
        config(TaskKind::Stack, ControlMode::Ee, RewardType::Dense),
        5.0,
        0.0,
    );
    assert_eq!(run(with(5.0, 0.0), 5.0, 0.0), default);
    assert_eq!(run(with(2.0, 0.0), 2.0, 0.0), default);
    assert_eq!(run(with(2.0, 0.1), 2.0, 0.1), default);
    let refused = [
        (0.0, 0.0),
        (-1.0, 0.0),
        (f64::NAN, 0.0),
        (f64::INFINITY, 0.0),
    ]
    .map(|(rate, hover)| (rate, hover, "task.reward_distance_rate"))
    .into_iter()
    .chain([-0.1, f64::NAN, f64::INFINITY].map(|h| (5.0, h, "task.reach_hover_height")));
    for (rate, hover, option) in refused {
        let Err(err) = PandaEnv::new(with(rate, hover)) else {
            panic!("rate {rate}, hover height {hover} was accepted");
        };
        let message = err.to_string();
        assert!(message.contains(option), "{message}");
    }
}
