//! Diagnoses the scripted Stack expert's failures: runs a seeded evaluation (the same episodes
//! as `scripted_eval` with the same arguments) and, for every failed episode, prints its phase
//! sequence (step ranges) and the cubes' final state, then how often the top cube was carried
//! tilted and how those episodes ended.
//!
//! `cargo run --release --example stack_diagnose -- [episodes] [ee|joints] [steps] [num_envs] [arm] [v|-] [first_seed]`
//!
//! `v` prints every step of the failed episodes. Environment variables: `GRASPS=1` prints, per
//! episode and cube, the hand's offset and velocity when the fingers start closing and the
//! cube's tilt 8 steps later; `P=name=value,...` overrides `stack_*` parameters (e.g.
//! `P=stack_max_tilt=10` turns the re-grasp of tilted cubes off).

use panda_rapier::policies::{Evaluation, Phase, ScriptedPolicy};
use panda_rapier::task::{ControlMode, EnvConfig, TaskKind};
use panda_rapier::ArmFidelity;

struct Row {
    phase: Phase,
    tcp: [f32; 3],
    c1: [f32; 3],
    c2: [f32; 3],
    q1: [f32; 4],
    q2: [f32; 4],
    width: f32,
    success: bool,
}

/// Angle between the cube's nearest axis and the vertical (0 when it rests on any face).
fn tilt90(q: [f32; 4]) -> f32 {
    let (x, y, z, w) = (q[0], q[1], q[2], q[3]);
    let col = [
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    ];
    col.iter()
        .map(|c| c.abs())
        .fold(0.0, f32::max)
        .clamp(-1.0, 1.0)
        .acos()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let episodes: usize = args.first().map_or(Ok(300), |s| s.parse())?;
    let mode = match args.get(1).map(String::as_str) {
        Some("joints") => ControlMode::Joints,
        _ => ControlMode::Ee,
    };
    let limit: u32 = args.get(2).map_or(Ok(150), |s| s.parse())?;
    let num_envs: usize = args.get(3).map_or(Ok(32), |s| s.parse())?;
    let arm = match args.get(4).map(String::as_str) {
        Some("kinematic") => ArmFidelity::Kinematic,
        _ => ArmFidelity::Dynamic,
    };
    let verbose = args.get(5).is_some_and(|v| v == "v");
    let first_seed: u64 = args.get(6).map_or(Ok(0), |s| s.parse())?;
    let config = EnvConfig {
        task: TaskKind::Stack.into(),
        control_mode: mode,
        max_episode_steps: Some(limit),
        arm,
        ..EnvConfig::default()
    };
    let mut params = panda_rapier::policies::ScriptedParams::default();
    if let Ok(list) = std::env::var("P") {
        for item in list.split(',').filter(|s| !s.is_empty()) {
            let (k, v) = item.split_once('=').ok_or("P: name=value")?;
            let v: f64 = v.parse()?;
            match k {
                "stack_hover_height" => params.stack_hover_height = v,
                "stack_place_tolerance" => params.stack_place_tolerance = v,
                "stack_slow_distance" => params.stack_slow_distance = v,
                "stack_approach_speed" => params.stack_approach_speed = v,
                "stack_max_tilt" => params.stack_max_tilt = v,
                "stack_regrasp_height" => params.stack_regrasp_height = v,
                "stack_close_gap" => params.stack_close_gap = v,
                "stack_squeeze_from" => params.stack_squeeze_from = v,
                "stack_touch_margin" => params.stack_touch_margin = v,
                "stack_aloft_height" => params.stack_aloft_height = v,
                "release_height" => params.release_height = v,
                _ => return Err(format!("unknown param {k}").into()),
            }
        }
    }
    let mut policy = ScriptedPolicy::with_params(&config, params)?;
    let mut evaluation = Evaluation::new(&config, episodes, num_envs, Some(1), first_seed)?;
    let n = evaluation.num_envs();
    let dim = policy.observation_dim();
    let a = policy.action_dim();
    let layout = evaluation.envs().layout().clone();
    let slot = |name: &str| layout.slot(name).unwrap();
    let (tcp_s, w_s) = (slot("tcp_position"), slot("gripper_width"));
    let (p1, p2, o1, o2) = (
        slot("cube1_position"),
        slot("cube2_position"),
        slot("cube1_orientation"),
        slot("cube2_orientation"),
    );
    let goal_s = layout.desired_goal();
    let mut logs: Vec<Vec<Row>> = (0..n).map(|_| Vec::new()).collect();
    let mut goals: Vec<[f32; 6]> = vec![[0.0; 6]; n];
    let mut actions = vec![0.0; n * a];
    let mut failures = 0;
    // (max tilt90 of cube2 while carried above 6 cm, success) per episode
    let mut carried: Vec<(f32, bool)> = Vec::new();
    while !evaluation.is_done() {
        let obs = evaluation.observations().to_vec();
        let running = evaluation.running().to_vec();
        let mut phases = Vec::with_capacity(n);
        for i in 0..n {
            let o = &obs[i * dim..(i + 1) * dim];
            phases.push(policy.act(o, &mut actions[i * a..(i + 1) * a])?);
            goals[i].copy_from_slice(&o[goal_s.clone()]);
        }
        evaluation.step(&actions)?;
        for i in 0..n {
            let Some(episode) = running[i] else { continue };
            let o = &obs[i * dim..(i + 1) * dim];
            let info = evaluation.envs().info(i)?;
            let g = |r: &std::ops::Range<usize>| [o[r.start], o[r.start + 1], o[r.start + 2]];
            let q = |r: &std::ops::Range<usize>| {
                [o[r.start], o[r.start + 1], o[r.start + 2], o[r.start + 3]]
            };
            logs[i].push(Row {
                phase: phases[i],
                tcp: g(&tcp_s),
                c1: g(&p1),
                c2: g(&p2),
                q1: q(&o1),
                q2: q(&o2),
                width: o[w_s.start],
                success: info.is_success,
            });
            let done = evaluation.envs().terminated()[i] || evaluation.envs().truncated()[i];
            if done {
                let log = std::mem::take(&mut logs[i]);
                let carry_tilt = log
                    .iter()
                    .filter(|r| {
                        r.c2[2] > 0.06
                            && r.width < 0.075
                            && matches!(r.phase, Phase::CARRY | Phase::LOWER)
                    })
                    .map(|r| tilt90(r.q2))
                    .fold(0.0, f32::max);
                carried.push((carry_tilt, info.is_success));
                if std::env::var("GRASPS").is_ok() {
                    for (cube, which) in [(0usize, "c1"), (1, "c2")] {
                        let pos = |r: &Row| if cube == 0 { r.c1 } else { r.c2 };
                        let q = |r: &Row| if cube == 0 { r.q1 } else { r.q2 };
                        if let Some(k) = log.iter().position(|r| {
                            r.phase == Phase::CLOSE
                                && pos(r)[2] < 0.04
                                && (pos(r)[0] - r.tcp[0]).hypot(pos(r)[1] - r.tcp[1]) < 0.03
                        }) {
                            let r = &log[k];
                            let prev = &log[k.saturating_sub(1)];
                            let after = &log[(k + 8).min(log.len() - 1)];
                            let yaw = {
                                let qq = q(r);
                                2.0 * qq[2].atan2(qq[3])
                            };
                            println!(
                                "GRASP {which} ep {episode} k {} dx {:.4} dy {:.4} dz {:.4} v {:.4} {:.4} {:.4} yaw {:.3} tilt_after {:.3} success {}",
                                k + 1,
                                pos(r)[0] - r.tcp[0],
                                pos(r)[1] - r.tcp[1],
                                pos(r)[2] - r.tcp[2],
                                r.tcp[0] - prev.tcp[0],
                                r.tcp[1] - prev.tcp[1],
                                r.tcp[2] - prev.tcp[2],
                                yaw,
                                tilt90(q(after)),
                                info.is_success
                            );
                        }
                    }
                }
                if !info.is_success {
                    failures += 1;
                    let first = log.iter().position(|r| r.success);
                    let last = log.last().unwrap();
                    let gl = goals[i];
                    println!(
                        "FAIL ep {episode} env {i} ever_success {:?} c1 {:.3?} c2 {:.3?} goal {:.3?} tilt1 {:.2} tilt2 {:.2}",
                        first,
                        last.c1,
                        last.c2,
                        &gl[..3],
                        tilt90(last.q1),
                        tilt90(last.q2)
                    );
                    let mut s = String::new();
                    let mut k = 0;
                    while k < log.len() {
                        let mut j = k;
                        while j + 1 < log.len() && log[j + 1].phase == log[k].phase {
                            j += 1;
                        }
                        s += &format!("{}:{}-{} ", log[k].phase.as_str(), k + 1, j + 1);
                        k = j + 1;
                    }
                    println!("   {s}");
                    if verbose {
                        for (k, r) in log.iter().enumerate() {
                            println!(
                                "   {:3} {:8} tcp {:.3?} c1 {:.3?} c2 {:.3?} w {:.3} t1 {:.2} t2 {:.2} s {}",
                                k + 1,
                                r.phase.as_str(),
                                r.tcp,
                                r.c1,
                                r.c2,
                                r.width,
                                tilt90(r.q1),
                                tilt90(r.q2),
                                r.success
                            );
                        }
                    }
                }
            }
        }
        evaluation.refill()?;
    }
    for lim in [0.05f32, 0.1, 0.2, 0.3] {
        let over: Vec<_> = carried.iter().filter(|c| c.0 > lim).collect();
        let fails = over.iter().filter(|c| !c.1).count();
        println!(
            "carry tilt2 > {lim}: {} episodes, {fails} failed",
            over.len()
        );
    }
    println!(
        "{failures} failures of {episodes}: success {:.1} %",
        100.0 * (1.0 - failures as f64 / episodes as f64)
    );
    Ok(())
}
