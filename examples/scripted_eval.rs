//! Evaluates the scripted pick-and-place policy on seeded episodes and prints the success
//! rate, steps to placing, returns and throughput.
//!
//! `cargo run --release --example scripted_eval -- [episodes] [ee|ee_pose|joints] [max_episode_steps] [num_envs] [task] [arm]`
//!
//! `task` is a [`TaskKind`] name (`pick_and_place`, `reach`, `lift`, `push`), `arm` `dynamic` or
//! `kinematic`.

use std::time::Instant;

use panda_rapier::policies::evaluate;
use panda_rapier::task::{ControlMode, EnvConfig, TaskKind};
use panda_rapier::ArmFidelity;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let episodes: usize = args.first().map_or(Ok(200), |s| s.parse())?;
    let mode = match args.get(1).map(String::as_str) {
        None | Some("ee") => ControlMode::Ee,
        Some("joints") => ControlMode::Joints,
        Some("ee_pose") => ControlMode::EePose,
        Some(other) => {
            return Err(format!("control mode must be ee, ee_pose or joints, got {other}").into())
        }
    };
    let limit: u32 = args.get(2).map_or(Ok(50), |s| s.parse())?;
    let num_envs: usize = args.get(3).map_or(Ok(32), |s| s.parse())?;
    let task = match args.get(4) {
        None => TaskKind::PickAndPlace,
        Some(name) => TaskKind::from_name(name).ok_or_else(|| format!("unknown task {name}"))?,
    };
    let arm = match args.get(5).map(String::as_str) {
        None | Some("dynamic") => ArmFidelity::Dynamic,
        Some("kinematic") => ArmFidelity::Kinematic,
        Some(other) => return Err(format!("arm must be dynamic or kinematic, got {other}").into()),
    };
    let config = EnvConfig {
        task: task.into(),
        control_mode: mode,
        max_episode_steps: Some(limit),
        arm,
        ..EnvConfig::default()
    };
    // Optional overrides as JSON, e.g. '{"cube_yaw_range": [0, 0]}' (merged over the above).
    let config = match std::env::var("PANDA_RAPIER_CONFIG") {
        Ok(extra) => {
            let mut value = serde_json::to_value(&config)?;
            let extra: serde_json::Value = serde_json::from_str(&extra)?;
            if let (Some(base), Some(extra)) = (value.as_object_mut(), extra.as_object()) {
                for (k, v) in extra {
                    base.insert(k.clone(), v.clone());
                }
            }
            EnvConfig::from_json(&value.to_string())?
        }
        Err(_) => config,
    };
    let start = Instant::now();
    let report = evaluate(&config, episodes, num_envs, None, 0, |done| {
        eprint!("\r{done}/{episodes} episodes");
    })?;
    let seconds = start.elapsed().as_secs_f64();
    eprintln!();
    // Pick-and-place counts placing; the other tasks have no platform to place on and count
    // the first success.
    let placing = task == TaskKind::PickAndPlace;
    let what = if placing { "placed" } else { "success" };
    let mut steps: Vec<u32> = report
        .episodes
        .iter()
        .filter_map(|e| {
            if placing {
                e.steps_to_placed
            } else {
                e.steps_to_success
            }
        })
        .collect();
    steps.sort_unstable();
    let percentile = |p: f64| {
        steps
            .get(((steps.len() as f64 - 1.0) * p).round() as usize)
            .copied()
    };
    println!(
        "{} {} {} control, {} steps: placed {:.1} % of {} episodes, success at the end {:.1} %",
        task.as_str(),
        arm.as_str(),
        mode.as_str(),
        limit,
        100.0 * report.placed_rate(),
        episodes,
        100.0 * report.success_rate()
    );
    let mean = steps.iter().map(|&s| f64::from(s)).sum::<f64>() / steps.len().max(1) as f64;
    println!(
        "steps to {what}: mean {mean:.1}, median {:?}, 95th percentile {:?}, max {:?}",
        percentile(0.5),
        percentile(0.95),
        steps.last()
    );
    let failed: Vec<(u64, u64)> = if placing {
        report.failed_episodes()
    } else {
        report
            .episodes
            .iter()
            .filter(|e| !e.success)
            .map(|e| (e.seed, e.env_index))
            .collect()
    };
    println!(
        "failed (seed, env index): {failed:?}; {:.0} env-steps/s",
        report.env_steps as f64 / seconds
    );
    Ok(())
}
