//! Inverse kinematics + joint PD against the operational-space controller (issue 58): the step
//! response of each in position (`ee`, a 0.1 m step sideways) and orientation (`ee_pose`, a
//! 0.5 rad yaw), and the wall-clock cost of one env step of each, the configurations
//! interleaved within every round so drift does not favour one. Numbers: `docs/dynamics.md`.
//!
//! `cargo run --release --example controllers`
//!
//! A step: the goal jumps at t = 0 and every action is the remaining error over the action's
//! scale, clipped to `[-1, 1]` (actions are relative to the measured pose, so an outer loop is
//! how any policy commands a goal). Settling time: the first time after which the error stays
//! within 5 mm (position) or 0.02 rad (orientation) up to 2 s.

use std::time::Instant;

use nalgebra::{UnitQuaternion, Vector3};
use panda_rapier::env::{EeController, PandaEnv};
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const STEPS: usize = 50; // 2 s at 25 Hz

fn config(mode: ControlMode, controller: EeController) -> EnvConfig {
    EnvConfig {
        control_mode: mode,
        ee_controller: controller,
        max_episode_steps: None,
        ..EnvConfig::default()
    }
}

/// Errors after each step of a step response, and the settling time (s).
fn step_response(
    mode: ControlMode,
    controller: EeController,
) -> panda_rapier::Result<(Vec<f64>, Option<f64>)> {
    let config = config(mode, controller);
    let mut env = PandaEnv::new(config.clone())?;
    env.reset(Some(5821), &ResetOptions::default())?;
    let start = env.simulation().tcp_state();
    let goal_position = start.position + Vector3::new(0.0, 0.1, 0.0);
    let goal_orientation = UnitQuaternion::from_scaled_axis(Vector3::z() * 0.5) * start.orientation;
    let orientation = mode == ControlMode::EePose;
    let mut errors = Vec::new();
    for _ in 0..STEPS {
        let tcp = env.simulation().tcp_state();
        let mut action = vec![0.0f32; env.action_dim()];
        if orientation {
            let dp = (start.position - tcp.position) / config.ee_step;
            let dr =
                (goal_orientation * tcp.orientation.inverse()).scaled_axis() / config.ee_rot_step;
            for i in 0..3 {
                action[i] = dp[i].clamp(-1.0, 1.0) as f32;
                action[i + 3] = dr[i].clamp(-1.0, 1.0) as f32;
            }
        } else {
            let dp = (goal_position - tcp.position) / config.ee_step;
            for i in 0..3 {
                action[i] = dp[i].clamp(-1.0, 1.0) as f32;
            }
        }
        *action.last_mut().unwrap() = 1.0;
        env.step(&action)?;
        let tcp = env.simulation().tcp_state();
        errors.push(if orientation {
            tcp.orientation.angle_to(&goal_orientation)
        } else {
            (tcp.position - goal_position).norm()
        });
    }
    let band = if orientation { 0.02 } else { 0.005 };
    let settled = match errors.iter().rposition(|&e| e > band) {
        None => Some(0.0),
        Some(k) if k + 1 < errors.len() => Some((k + 2) as f64 * env.dt()),
        Some(_) => None,
    };
    Ok((errors, settled))
}

fn seconds_per_step(config: &EnvConfig) -> panda_rapier::Result<f64> {
    let mut env = PandaVecEnv::new(config.clone(), 1, Some(1), AutoresetMode::SameStep)?;
    env.reset(Some(5822))?;
    let mut rng = ChaCha8Rng::seed_from_u64(5823);
    let n = 200;
    let actions: Vec<f32> = (0..n * env.action_dim())
        .map(|_| rng.random_range(-1.0..=1.0))
        .collect();
    let a = env.action_dim();
    let start = Instant::now();
    for k in 0..n {
        env.step(&actions[k * a..(k + 1) * a])?;
    }
    Ok(start.elapsed().as_secs_f64() / n as f64)
}

fn main() -> panda_rapier::Result<()> {
    let cases = [
        (ControlMode::Ee, EeController::Ik),
        (ControlMode::Ee, EeController::Osc),
        (ControlMode::EePose, EeController::Ik),
        (ControlMode::EePose, EeController::Osc),
    ];
    println!("step responses (seed 5821; position: ee, 0.1 m along y; orientation: ee_pose, 0.5 rad yaw)");
    for (mode, controller) in cases {
        let (errors, settled) = step_response(mode, controller)?;
        let unit = if mode == ControlMode::EePose {
            "rad"
        } else {
            "m"
        };
        let at = |k: usize| errors[k];
        println!(
            "{:>8} {:>4}: error {:.4} {unit} at 0.2 s, {:.4} at 0.4 s, {:.5} at 1 s, {:.5} at 2 s; settled {}",
            mode.as_str(),
            controller.as_str(),
            at(4),
            at(9),
            at(24),
            at(STEPS - 1),
            settled.map_or("never".into(), |s| format!("at {s:.2} s")),
        );
    }
    println!("wall-clock per env step (1 env, 1 thread, 200 random actions, median of 5 interleaved rounds)");
    let mut times = vec![Vec::new(); cases.len()];
    for _ in 0..5 {
        for (i, &(mode, controller)) in cases.iter().enumerate() {
            times[i].push(seconds_per_step(&config(mode, controller))?);
        }
    }
    for ((mode, controller), mut t) in cases.into_iter().zip(times) {
        t.sort_by(f64::total_cmp);
        println!(
            "{:>8} {:>4}: {:.1} us per step (min {:.1}, max {:.1})",
            mode.as_str(),
            controller.as_str(),
            t[2] * 1e6,
            t[0] * 1e6,
            t[4] * 1e6
        );
    }
    Ok(())
}
