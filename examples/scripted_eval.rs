//! Evaluates the scripted pick-and-place policy on seeded episodes and prints the success
//! rate, steps to placing, returns and throughput.
//!
//! `cargo run --release --example scripted_eval -- [episodes] [ee|joints] [max_episode_steps] [num_envs]`

use std::time::Instant;

use panda_rapier::policies::evaluate;
use panda_rapier::task::{ControlMode, EnvConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let episodes: usize = args.first().map_or(Ok(200), |s| s.parse())?;
    let mode = match args.get(1).map(String::as_str) {
        None | Some("ee") => ControlMode::Ee,
        Some("joints") => ControlMode::Joints,
        Some(other) => return Err(format!("control mode must be ee or joints, got {other}").into()),
    };
    let limit: u32 = args.get(2).map_or(Ok(50), |s| s.parse())?;
    let num_envs: usize = args.get(3).map_or(Ok(32), |s| s.parse())?;
    let config = EnvConfig {
        control_mode: mode,
        max_episode_steps: Some(limit),
        ..EnvConfig::default()
    };
    let start = Instant::now();
    let report = evaluate(&config, episodes, num_envs, None, 0, |done| {
        eprint!("\r{done}/{episodes} episodes");
    })?;
    let seconds = start.elapsed().as_secs_f64();
    eprintln!();
    let mut steps: Vec<u32> = report
        .episodes
        .iter()
        .filter_map(|e| e.steps_to_placed)
        .collect();
    steps.sort_unstable();
    let percentile = |p: f64| {
        steps
            .get(((steps.len() as f64 - 1.0) * p).round() as usize)
            .copied()
    };
    println!(
        "{} control, {} steps: placed {:.1} % of {} episodes, success at the end {:.1} %",
        mode.as_str(),
        limit,
        100.0 * report.placed_rate(),
        episodes,
        100.0 * report.success_rate()
    );
    println!(
        "steps to placed: mean {:.1}, median {:?}, 95th percentile {:?}, max {:?}",
        report.mean_steps_to_placed(),
        percentile(0.5),
        percentile(0.95),
        steps.last()
    );
    println!(
        "failed (seed, env index): {:?}; {:.0} env-steps/s",
        report.failed_episodes(),
        report.env_steps as f64 / seconds
    );
    Ok(())
}
