//! The pick-object expert per object: placed rate, and where the failed episodes ended.
//!
//! `cargo run --release --example pick_object_eval -- [episodes] [ee_pose|joints] [first_seed]`
//!
//! Runs `episodes` seeded episodes (seeds from `first_seed`) of `pick_object` with the
//! registered ids' settings (100 steps; `joints` at 0.1 rad per step) and prints, per object
//! of the shipped set, how many episodes drew it, the share placed, and the failed seeds with
//! the expert's last phase, whether it was ever lifted and how near the goal it came (m).

use std::collections::BTreeMap;

use panda_rapier::env::PandaEnv;
use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::task::{ControlMode, EnvConfig, PickObjectConfig, ResetOptions, TaskKind};

/// A failed episode: its seed, the expert's last phase, whether the object was ever lifted,
/// and how near its goal it came (m).
type Failure = (u64, &'static str, bool, f64);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let episodes: u64 = args.first().map_or(Ok(200), |s| s.parse())?;
    let mode = match args.get(1).map(String::as_str) {
        Some("joints") => ControlMode::Joints,
        _ => ControlMode::EePose,
    };
    let first: u64 = args.get(2).map_or(Ok(0), |s| s.parse())?;
    // PICK_OBJECT_TRACE=SEED prints that episode step by step.
    let trace: Option<u64> = std::env::var("PICK_OBJECT_TRACE")
        .ok()
        .and_then(|s| s.parse().ok());
    let kind = TaskKind::PickObject;
    let config = EnvConfig {
        task: kind.into(),
        control_mode: mode,
        joint_step: kind.id_joint_step().unwrap_or(0.05),
        max_episode_steps: Some(kind.descriptor().episode_steps),
        ..EnvConfig::default()
    };
    let labels: Vec<String> = PickObjectConfig::default()
        .objects
        .iter()
        .map(|o| o.label())
        .collect();
    let mut env = PandaEnv::new(config.clone())?;
    let mut policy = ScriptedPolicy::new(&config)?;
    let mut action = vec![0.0; policy.action_dim()];
    let object = env.simulation().object("object")?;
    // Per object: episodes, placed, failures (seed, last phase).
    let mut table: BTreeMap<usize, (u32, u32, Vec<Failure>)> = BTreeMap::new();
    for seed in first..first + episodes {
        env.reset(Some(seed), &ResetOptions::default())?;
        let which = env.simulation().object_variant(object) as usize;
        let mut placed = false;
        let mut lifted = false;
        let mut nearest = f64::INFINITY;
        let phase = loop {
            let obs = env.observation().to_vec();
            let phase = policy.act(&obs, &mut action)?.as_str();
            let t = env.step(&action)?;
            if trace == Some(seed) {
                let get = |name: &str| obs[env.layout().slot(name).unwrap_or(0..0)].to_vec();
                println!(
                    "{:9} tcp {:6.3?} grasp {:6.3?} dir {:5.2?} gw {:.3} centre {:6.3?} goal {:6.3?} w {:.4} grasped {} rel/rest/plat {}{}{} v {:5.3?} a {:5.2?}",
                    phase,
                    get("tcp_position"),
                    get("grasp_position"),
                    get("grasp_direction"),
                    get("grasp_width")[0],
                    get("achieved_goal"),
                    get("desired_goal"),
                    get("gripper_width")[0],
                    t.info.flag("is_grasped"),
                    u8::from(t.info.flag("cube_released")),
                    u8::from(t.info.flag("cube_at_rest")),
                    u8::from(t.info.flag("cube_on_platform")),
                    get("object_linear_velocity"),
                    action,
                );
            }
            placed |= t.info.flag("is_placed");
            lifted |= t.info.flag("is_lifted");
            nearest = nearest.min(t.info.goal_distance);
            if t.truncated || t.terminated {
                break phase;
            }
        };
        let row = table.entry(which).or_default();
        row.0 += 1;
        if placed {
            row.1 += 1;
        } else {
            row.2
                .push((seed, phase, lifted, (nearest * 100.0).round() / 100.0));
        }
        eprint!("\r{}/{episodes}", seed - first + 1);
    }
    eprintln!();
    let (mut n, mut ok) = (0, 0);
    for (which, (count, placed, failed)) in &table {
        n += count;
        ok += placed;
        println!(
            "{:12} {:4} episodes, placed {:5.1} %; failed {:?}",
            labels[*which],
            count,
            100.0 * f64::from(*placed) / f64::from(*count),
            &failed[..failed.len().min(8)]
        );
    }
    println!(
        "pick_object {} control: placed {:.1} % of {n} episodes",
        mode.as_str(),
        100.0 * f64::from(ok) / f64::from(n)
    );
    Ok(())
}
