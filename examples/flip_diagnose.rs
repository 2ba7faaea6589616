//! How the scripted expert's flips end: for seeded `flip` episodes, the success rate, the
//! final angle to the goal, the steps to success and the phases the expert spent its steps
//! in. For tuning the flip expert.
//!
//! `cargo run --release --example flip_diagnose -- [episodes] [ee|joints] [arm] [joint_step]`
//! (`VERBOSE=1`: one line per episode; `TRACE=seed`: one line per step of that episode;
//! `FIRST_SEED=n`: seeds from n).

use std::collections::BTreeMap;

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
        ..EnvConfig::for_task(TaskKind::Flip)
    };
    if let Some(step) = args.get(3) {
        config.joint_step = step.parse()?;
    }
    let trace: Option<u64> = std::env::var("TRACE").ok().and_then(|s| s.parse().ok());
    let mut env = PandaEnv::new(config.clone())?;
    let mut policy = ScriptedPolicy::new(&config)?;
    let layout = env.layout().clone();
    let mut action = vec![0.0; policy.action_dim()];
    let (mut successes, mut first_success) = (0, Vec::new());
    let mut phases: BTreeMap<&'static str, usize> = BTreeMap::new();
    let mut final_angles = Vec::new();
    let first: u64 = std::env::var("FIRST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    for seed in first..first + episodes {
        let mut options = ResetOptions::default();
        if let Ok(g) = std::env::var("GOAL") {
            let v: Vec<f64> = g.split(',').map(|x| x.parse().unwrap_or(0.0)).collect();
            options.goal = Some([v[0], v[1], v[2]]);
        }
        env.reset(Some(seed), &options)?;
        let goal = env.observation()[layout.desired_goal()].to_vec();
        let (mut success, mut angle, mut first) = (false, 0.0, None);
        let mut spins = 0;
        for step in 0.. {
            let obs = env.observation().to_vec();
            let phase = policy.act(&obs, &mut action)?;
            *phases.entry(phase.as_str()).or_default() += 1;
            spins += usize::from(phase.as_str() == "spin");
            let t = env.step(&action)?;
            success = t.info.is_success;
            angle = t.info.goal_distance;
            if success && first.is_none() {
                first = Some(step + 1);
            }
            if trace == Some(seed) {
                let o = env.observation();
                println!(
                    "{step:3} {:8} angle {angle:.3} tcp {:.3?} cube {:.3?} q {:.3?}",
                    phase.as_str(),
                    &o[layout.slot("tcp_position").unwrap()],
                    &o[layout.slot("cube_position").unwrap()],
                    &o[layout.achieved_goal()],
                );
            }
            if t.truncated || t.terminated {
                break;
            }
        }
        successes += usize::from(success);
        final_angles.push(angle);
        if let Some(f) = first.filter(|_| success) {
            first_success.push(f);
        }
        if std::env::var("VERBOSE").is_ok() {
            println!(
                "seed {seed:3} goal {goal:.3?} angle {angle:.3} {success} first {first:?} spin steps {spins}"
            );
        }
    }
    first_success.sort_unstable();
    let pct = |q: f64| {
        first_success
            .get(((first_success.len() as f64 - 1.0) * q) as usize)
            .copied()
            .unwrap_or(0)
    };
    println!(
        "success {:.1} % of {episodes}; steps to success median {} p95 {} max {}; final angle > 1.2 rad: {}",
        100.0 * successes as f64 / episodes as f64,
        pct(0.5),
        pct(0.95),
        pct(1.0),
        final_angles.iter().filter(|&&a| a > 1.2).count(),
    );
    println!("steps by phase: {phases:?}");
    Ok(())
}
