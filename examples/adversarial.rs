//! Adversarial dynamics: the hardest inputs a policy can give, for many steps, counting what
//! happens. Scenarios (the first two on every task and both arm models):
//!
//! - `joints_bang_bang`: `joints` control, every joint commanded at +-1 (the largest delta),
//!   signs flipping at random every 1-5 steps.
//! - `ee_into_table`: `ee` control pushing the hand down (z = -1) with random x, y and gripper,
//!   so the hand and fingers are driven into the table, the platform and the cube.
//! - `torque_bang_bang`: the dynamic arm in torque control at +-the effort limit of every joint
//!   (through the robot API; the environment's actions are position targets), signs flipping
//!   at random every 1-5 control steps, checked with the environment's blow-up thresholds.
//!
//! For each: environment steps, episodes, observations or rewards with a NaN (must be 0),
//! blow-ups detected (`physics_unstable`), resets after them that worked, and the fastest body.
//!
//! `cargo run --release --example adversarial -- [TOTAL_ENV_STEPS]` (default 1,000,000: 40,000
//! for each task, scenario and arm, 200,000 of torque bang-bang).

use std::time::Instant;

use panda_rapier::task::{ControlMode, EnvConfig, TaskKind, TaskThresholds};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use panda_rapier::{ArmFidelity, JointControl, SimConfig, Simulation};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

#[derive(Debug, Default, Clone)]
struct Tally {
    steps: u64,
    episodes: u64,
    nan: u64,
    blow_ups: u64,
    resets_after_blow_up: u64,
    fastest: f64,
}

fn env_scenario(
    name: &str,
    task: TaskKind,
    mode: ControlMode,
    arm: ArmFidelity,
    steps: u64,
) -> panda_rapier::Result<Tally> {
    let n = 64;
    let config = EnvConfig {
        task: task.into(),
        control_mode: mode,
        arm,
        max_episode_steps: Some(if task == TaskKind::Stack { 150 } else { 70 }),
        ..EnvConfig::default()
    };
    let mut env = PandaVecEnv::new(config, n, None, AutoresetMode::SameStep)?;
    env.reset(Some(1))?;
    let a = env.action_dim();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut signs = vec![1.0f32; n * a];
    let mut hold = vec![0u32; n * a];
    let mut actions = vec![0.0f32; n * a];
    let mut tally = Tally::default();
    let rounds = steps / n as u64;
    for _ in 0..rounds {
        for (i, action) in actions.iter_mut().enumerate() {
            match name {
                "joints_bang_bang" => {
                    if hold[i] == 0 {
                        signs[i] = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                        hold[i] = rng.random_range(1..=5);
                    }
                    hold[i] -= 1;
                    *action = signs[i];
                }
                _ => {
                    *action = match i % a {
                        2 => -1.0,
                        _ => rng.random_range(-1.0..=1.0),
                    }
                }
            }
        }
        env.step(&actions)?;
        tally.steps += n as u64;
        tally.nan += env.observations().iter().filter(|v| !v.is_finite()).count() as u64
            + env.rewards().iter().filter(|v| !v.is_finite()).count() as u64;
        let dim = env.observation_dim();
        for i in 0..n {
            if env.info(i)?.physics_unstable {
                tally.blow_ups += 1;
                // Same-step autoreset: the row already holds the next episode's first state.
                let row = &env.observations()[i * dim..(i + 1) * dim];
                if row.iter().all(|v| v.is_finite()) && env.env(i)?.simulation().is_finite() {
                    tally.resets_after_blow_up += 1;
                }
            }
            let (linear, _) = env.env(i)?.simulation().max_body_speeds();
            tally.fastest = tally.fastest.max(linear);
        }
        tally.episodes += env.has_final_observation().iter().filter(|&&e| e).count() as u64;
    }
    Ok(tally)
}

fn torque_scenario(steps: u64) -> panda_rapier::Result<Tally> {
    let worlds = 32usize;
    let per_world = steps / worlds as u64;
    let thresholds = TaskThresholds::default();
    let tallies: Vec<panda_rapier::Result<Tally>> = (0..worlds)
        .into_par_iter()
        .map(|w| {
            let mut sim = Simulation::new(SimConfig::default())?;
            let start = sim.snapshot();
            let joints: Vec<usize> = sim.model().actuated_joints().to_vec();
            let efforts: Vec<f64> = joints
                .iter()
                .map(|&j| sim.model().joints()[j].max_force)
                .collect();
            let mut rng = ChaCha8Rng::seed_from_u64(100 + w as u64);
            let mut signs = vec![1.0; joints.len()];
            let mut hold = vec![0u32; joints.len()];
            let mut tally = Tally::default();
            for step in 0..per_world {
                for k in 0..joints.len() {
                    if hold[k] == 0 {
                        signs[k] = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                        hold[k] = rng.random_range(1..=5);
                    }
                    hold[k] -= 1;
                    sim.set_joint_control(joints[k], JointControl::Torque(signs[k] * efforts[k]))?;
                }
                sim.step_control();
                tally.steps += 1;
                let (linear, angular) = sim.max_body_speeds();
                let unstable = !sim.is_finite()
                    || linear.is_nan()
                    || angular.is_nan()
                    || linear > thresholds.unstable_linear_speed
                    || angular > thresholds.unstable_angular_speed;
                if linear.is_finite() {
                    tally.fastest = tally.fastest.max(linear);
                }
                if !sim.tcp_state().position.iter().all(|v| v.is_finite()) {
                    tally.nan += 1;
                }
                // Episodes of 70 steps, as the environment's; a blow-up ends one at once.
                if unstable || (step + 1) % 70 == 0 {
                    tally.episodes += 1;
                    if unstable {
                        tally.blow_ups += 1;
                    }
                    sim.restore(&start)?;
                    if unstable && sim.is_finite() {
                        tally.resets_after_blow_up += 1;
                    }
                }
            }
            Ok(tally)
        })
        .collect();
    let mut total = Tally::default();
    for t in tallies {
        let t = t?;
        total.steps += t.steps;
        total.episodes += t.episodes;
        total.nan += t.nan;
        total.blow_ups += t.blow_ups;
        total.resets_after_blow_up += t.resets_after_blow_up;
        total.fastest = total.fastest.max(t.fastest);
    }
    Ok(total)
}

fn main() -> panda_rapier::Result<()> {
    let total: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let tasks = [
        TaskKind::PickAndPlace,
        TaskKind::Reach,
        TaskKind::Lift,
        TaskKind::Push,
        TaskKind::Stack,
    ];
    let runs: [(&str, ControlMode, ArmFidelity); 4] = [
        (
            "joints_bang_bang",
            ControlMode::Joints,
            ArmFidelity::Dynamic,
        ),
        ("ee_into_table", ControlMode::Ee, ArmFidelity::Dynamic),
        (
            "joints_bang_bang",
            ControlMode::Joints,
            ArmFidelity::Kinematic,
        ),
        ("ee_into_table", ControlMode::Ee, ArmFidelity::Kinematic),
    ];
    // A fifth of the steps for torque bang-bang, the rest shared by every task and scenario.
    let share = total * 4 / 5 / (tasks.len() * runs.len()) as u64;
    println!(
        "{:<14} {:<18} {:<10} {:>9} {:>8} {:>5} {:>9} {:>7} {:>9} {:>7}",
        "task", "scenario", "arm", "steps", "episodes", "NaN", "blow-ups", "resets", "fastest", "s"
    );
    let mut all = Tally::default();
    let mut report = |task: &str, name: &str, arm: &str, t: &Tally, seconds: f64| {
        println!(
            "{task:<14} {name:<18} {arm:<10} {:>9} {:>8} {:>5} {:>9} {:>7} {:>7.2} m/s {:>5.0}",
            t.steps, t.episodes, t.nan, t.blow_ups, t.resets_after_blow_up, t.fastest, seconds
        );
        all.steps += t.steps;
        all.nan += t.nan;
        all.blow_ups += t.blow_ups;
        all.resets_after_blow_up += t.resets_after_blow_up;
    };
    for task in tasks {
        for (name, mode, arm) in runs {
            let start = Instant::now();
            let t = env_scenario(name, task, mode, arm, share)?;
            let label = format!("{task:?}");
            report(
                &label,
                name,
                arm.as_str(),
                &t,
                start.elapsed().as_secs_f64(),
            );
        }
    }
    let start = Instant::now();
    let t = torque_scenario(total - share * (tasks.len() * runs.len()) as u64)?;
    report(
        "(robot API)",
        "torque_bang_bang",
        "dynamic",
        &t,
        start.elapsed().as_secs_f64(),
    );
    println!(
        "total: {} steps, {} with a NaN, {} blow-ups, {} of them detected and reset cleanly",
        all.steps, all.nan, all.blow_ups, all.resets_after_blow_up
    );
    Ok(())
}
