//! Prints what the scripted policy sees and does in one seeded episode, step by step.
//!
//! `cargo run --release --example scripted_trace -- [seed] [ee|ee_pose|joints] [max_episode_steps] [env_index] [task] [arm]`
//!
//! `task` is a [`TaskKind`] name (default `pick_and_place`), `arm` `dynamic` (default) or
//! `kinematic`.

use panda_rapier::env::PandaEnv;
use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions, TaskKind};
use panda_rapier::ArmFidelity;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seed: u64 = args.first().map_or(Ok(0), |s| s.parse())?;
    let mode = match args.get(1).map(String::as_str) {
        Some("joints") => ControlMode::Joints,
        Some("ee_pose") => ControlMode::EePose,
        _ => ControlMode::Ee,
    };
    let limit: u32 = args.get(2).map_or(Ok(50), |s| s.parse())?;
    let task = match args.get(4) {
        None => TaskKind::PickAndPlace,
        Some(name) => TaskKind::from_name(name).ok_or_else(|| format!("unknown task {name}"))?,
    };
    let arm = match args.get(5).map(String::as_str) {
        Some("kinematic") => ArmFidelity::Kinematic,
        _ => ArmFidelity::Dynamic,
    };
    let config = EnvConfig {
        task: task.into(),
        control_mode: mode,
        max_episode_steps: Some(limit),
        arm,
        ..EnvConfig::default()
    };
    let index: u64 = args.get(3).map_or(Ok(0), |s| s.parse())?;
    let mut env = PandaEnv::with_index(config.clone(), index)?;
    let mut policy = ScriptedPolicy::new(&config)?;
    env.reset(Some(seed), &ResetOptions::default())?;
    let mut action = vec![0.0; policy.action_dim()];
    let layout = env.layout().clone();
    for step in 1..=limit {
        let obs = env.observation().to_vec();
        let phase = policy.act(&obs, &mut action)?;
        let t = env.step(&action)?;
        let get = |name: &str| obs[layout.slot(name).unwrap_or(0..0)].to_vec();
        println!(
            "{step:3} {:9} a {:5.2?} tcp {:6.3?} cubes {:6.3?} goals {:6.3?} w {:.4} grasp {} placed {} d {:.3}{}",
            phase.as_str(),
            action,
            get("tcp_position"),
            get("achieved_goal"),
            get("desired_goal"),
            get("gripper_width")[0],
            t.info.flag("is_grasped"),
            t.info.flag("is_placed"),
            t.info.goal_distance,
            // Tasks with more to say (peg insertion: the peg's depth and offset from the axis).
            ["insertion_depth", "peg_axis_offset"]
                .iter()
                .filter_map(|k| t.info.get(k).map(|_| format!(" {k} {:.4}", t.info.number(k))))
                .collect::<String>()
        );
        if t.truncated || t.terminated {
            break;
        }
    }
    Ok(())
}
