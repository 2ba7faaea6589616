//! Contact between the peg and the box while the scripted expert inserts it: per episode, the
//! deepest penetration and the largest normal force between the two (read after every control
//! step, from its last physics step), the deepest the leading end went while on the hole's
//! axis line (a peg through the hole's bottom would show as more than the hole's depth), and success; then the median, 95th
//! percentile and largest over the episodes.
//!
//! `cargo run --release --example peg_contacts -- [episodes] [ee_pose|joints] [clearance]`

use panda_rapier::env::PandaEnv;
use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions, TaskConfig, TaskKind};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let episodes: u64 = args.first().map_or(Ok(100), |s| s.parse())?;
    let (mode, joint_step) = match args.get(1).map(String::as_str) {
        None | Some("ee_pose") => (ControlMode::EePose, 0.05),
        Some("joints") => (ControlMode::Joints, 0.1),
        Some(other) => return Err(format!("mode must be ee_pose or joints, got {other}").into()),
    };
    let clearance: f64 = args.get(2).map_or(Ok(0.003), |s| s.parse())?;
    let TaskConfig::PegInsertion(mut section) = TaskConfig::defaults(TaskKind::PegInsertion) else {
        unreachable!("the peg insertion section")
    };
    section.clearance = clearance;
    let depth = section.insertion_depth;
    let config = EnvConfig {
        task: TaskConfig::PegInsertion(section),
        control_mode: mode,
        joint_step,
        max_episode_steps: Some(TaskKind::PegInsertion.descriptor().episode_steps),
        ..EnvConfig::default()
    };
    let mut env = PandaEnv::new(config.clone())?;
    let mut policy = ScriptedPolicy::new(&config)?;
    let peg = env.simulation().object("peg")?;
    let hole = env.simulation().object("hole_box")?;
    let mut action = vec![0.0; policy.action_dim()];
    let (mut penetrations, mut forces, mut depths) = (Vec::new(), Vec::new(), Vec::new());
    let mut successes = 0;
    for seed in 0..episodes {
        env.reset(Some(seed), &ResetOptions::default())?;
        let (mut penetration, mut force, mut deepest) = (0.0f64, 0.0f64, f64::NEG_INFINITY);
        loop {
            let obs = env.observation().to_vec();
            policy.act(&obs, &mut action)?;
            let t = env.step(&action)?;
            let contact = env.simulation().contact_between(peg, hole);
            penetration = penetration.max(contact.penetration);
            force = force.max(contact.normal_force);
            // The depth counts only with the peg in the hole (on its axis line).
            if t.info.number("peg_axis_offset") < clearance + 0.01 {
                deepest = deepest.max(t.info.number("insertion_depth"));
            }
            if t.truncated || t.terminated {
                successes += usize::from(t.info.is_success);
                break;
            }
        }
        penetrations.push(penetration);
        forces.push(force);
        depths.push(deepest);
        eprint!("\r{}/{episodes} episodes", seed + 1);
    }
    eprintln!();
    let summary = |name: &str, unit: &str, scale: f64, values: &mut Vec<f64>| {
        values.sort_by(f64::total_cmp);
        let at = |p: f64| values[((values.len() - 1) as f64 * p).round() as usize] * scale;
        println!(
            "{name}: median {:.2} {unit}, 95th percentile {:.2} {unit}, largest {:.2} {unit}",
            at(0.5),
            at(0.95),
            at(1.0)
        );
    };
    println!(
        "peg_insertion, {} control, clearance {clearance} m: success {:.1} % of {episodes}",
        mode.as_str(),
        100.0 * successes as f64 / episodes as f64
    );
    summary("deepest penetration peg-box", "mm", 1e3, &mut penetrations);
    summary("largest normal force peg-box", "N", 1.0, &mut forces);
    summary(
        &format!("deepest insertion (hole {:.0} mm deep)", depth * 1e3),
        "mm",
        1e3,
        &mut depths,
    );
    Ok(())
}
