//! Where the scripted expert's slides end: for seeded `slide` episodes, the final cube
//! position relative to the goal along the line from the cube's start to the goal (positive:
//! beyond it) and across it, with the success rate. For tuning the slide expert.
//!
//! `cargo run --release --example slide_diagnose -- [episodes] [ee|joints] [arm]`

use panda_rapier::env::PandaEnv;
use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions, TaskKind};
use panda_rapier::ArmFidelity;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let episodes: u64 = args.first().map_or(Ok(200), |s| s.parse())?;
    let mode = match args.get(1).map(String::as_str) {
        Some("joints") => ControlMode::Joints,
        _ => ControlMode::Ee,
    };
    let arm = match args.get(2).map(String::as_str) {
        Some("kinematic") => ArmFidelity::Kinematic,
        _ => ArmFidelity::Dynamic,
    };
    let mut config = EnvConfig {
        arm,
        control_mode: mode,
        ..EnvConfig::for_task(TaskKind::Slide)
    };
    if let Some(step) = args.get(3) {
        config.joint_step = step.parse()?;
    }
    let mut env = PandaEnv::new(config.clone())?;
    let mut policy = ScriptedPolicy::new(&config)?;
    let layout = env.layout().clone();
    let mut action = vec![0.0; policy.action_dim()];
    let (mut along, mut across, mut successes) = (Vec::new(), Vec::new(), 0);
    for seed in 0..episodes {
        env.reset(Some(seed), &ResetOptions::default())?;
        let obs = env.observation().to_vec();
        let start = obs[layout.achieved_goal()].to_vec();
        let goal = obs[layout.desired_goal()].to_vec();
        let mut success;
        loop {
            let obs = env.observation().to_vec();
            policy.act(&obs, &mut action)?;
            let t = env.step(&action)?;
            success = t.info.is_success;
            if t.truncated || t.terminated {
                break;
            }
        }
        let end = env.observation()[layout.achieved_goal()].to_vec();
        let (ux, uy) = (goal[0] - start[0], goal[1] - start[1]);
        let n = (ux * ux + uy * uy).sqrt();
        let (ux, uy) = (ux / n, uy / n);
        let (ex, ey) = (end[0] - goal[0], end[1] - goal[1]);
        along.push((ex * ux + ey * uy) as f64);
        across.push((ey * ux - ex * uy) as f64);
        successes += usize::from(success);
        if std::env::var("VERBOSE").is_ok() {
            println!(
                "seed {seed:3} start {:.3?} goal {:.3?} end {:.3?} along {:+.3} across {:+.3} {success}",
                &start[..2],
                &goal[..2],
                &end[..2],
                along.last().unwrap(),
                across.last().unwrap()
            );
        }
    }
    let stats = |v: &[f64]| {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
        (mean, sd)
    };
    let (am, asd) = stats(&along);
    let (cm, csd) = stats(&across);
    println!(
        "success {:.1} % of {episodes}; along the line {am:+.4} +- {asd:.4} m, across {cm:+.4} +- {csd:.4} m; short by > 5 cm {}, beyond by > 5 cm {}",
        100.0 * successes as f64 / episodes as f64,
        along.iter().filter(|&&a| a < -0.05).count(),
        along.iter().filter(|&&a| a > 0.05).count(),
    );
    Ok(())
}
