//! Speed next to accuracy for solver settings: for each
//! `dt:substeps:iterations[:kinematic][:substep][:pd=METRES]` given (the control period
//! `dt * substeps` must stay 0.04 s; `kinematic` selects the kinematic arm, `substep` rebuilds
//! the arm's mass matrix after every solver iteration, `solver.multibody_update = "substep"`;
//! `pd=` sets `solver.contact_prediction_distance`), prints
//! env-steps/s of 16 environments on
//! one thread (random actions), the tutorial grasp's slip and tracking error, the creep of a
//! held cube under a 0.5 Hz base swing, and the scripted policy's placed rate.
//!
//! `cargo run --release --example fidelity -- [EPISODES] [dt:substeps:iterations ...]`
//! (default: 200 episodes, the default settings).

use std::time::Instant;

use panda_rapier::demo::{self, TutorialSequence};
use panda_rapier::policies::evaluate;
use panda_rapier::task::{ControlMode, EnvConfig};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use panda_rapier::{ArmFidelity, MultibodyUpdate, SimConfig, Simulation};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn env_steps_per_second(config: &EnvConfig) -> panda_rapier::Result<f64> {
    let n = 16;
    let mut env = PandaVecEnv::new(config.clone(), n, Some(1), AutoresetMode::SameStep)?;
    env.reset(Some(0))?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let steps = 60;
    let actions: Vec<f32> = (0..steps * n * env.action_dim())
        .map(|_| rng.random_range(-1.0..=1.0))
        .collect();
    let row = n * env.action_dim();
    let start = Instant::now();
    for k in 0..steps {
        env.step(&actions[k * row..(k + 1) * row])?;
    }
    Ok((steps * n) as f64 / start.elapsed().as_secs_f64())
}

fn swing_creep(sim_config: &SimConfig) -> panda_rapier::Result<(f64, f64, bool)> {
    let mut sim = Simulation::new(sim_config.clone())?;
    let plan = TutorialSequence::for_scene(&sim);
    demo::run_until(&mut sim, &plan, Some("lift"))?;
    let in_hand = |sim: &Simulation| {
        let tcp = sim.tcp_state();
        tcp.orientation.inverse()
            * (sim.object_state(sim.object("cube").unwrap()).position - tcp.position)
    };
    let start = in_hand(&sim);
    let q1 = sim.joint_positions()[0];
    let dt = sim_config.physics.solver.dt;
    let (mut within_2s, mut within_10s) = (0.0f64, 0.0f64);
    let steps = (10.0 / dt).round() as usize;
    for k in 1..=steps {
        demo::swing_base_joint(&mut sim, q1, k as f64 * dt)?;
        sim.step();
        let drift = (in_hand(&sim) - start).norm();
        if (k as f64) * dt <= 2.0 {
            within_2s = within_2s.max(drift);
        }
        within_10s = within_10s.max(drift);
    }
    let held = sim
        .object_contacts(sim.object("cube").unwrap())
        .robot_links
        .len()
        >= 2;
    Ok((within_2s, within_10s, held))
}

fn main() -> panda_rapier::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let episodes = match args.first().and_then(|a| a.parse::<usize>().ok()) {
        Some(e) => {
            args.remove(0);
            e
        }
        None => 200,
    };
    if args.is_empty() {
        let s = SimConfig::default().physics.solver;
        args.push(format!(
            "{}:{}:{}",
            s.dt,
            SimConfig::default().substeps,
            s.solver_iterations
        ));
    }
    println!("settings          env-steps/s  slip carry/max (mm, deg)  track (mm)  creep 2s/10s (mm)  placed ee/joints");
    for spec in &args {
        let parts: Vec<&str> = spec.split(':').collect();
        let [dt, substeps, iterations, ref options @ ..] = parts[..] else {
            panic!("expected dt:substeps:iterations[:kinematic][:substep][:pd=METRES], got {spec}");
        };
        let mut arm = ArmFidelity::Dynamic;
        let mut multibody_update = MultibodyUpdate::Step;
        let mut prediction = SimConfig::default()
            .physics
            .solver
            .contact_prediction_distance;
        for option in options {
            match *option {
                "kinematic" => arm = ArmFidelity::Kinematic,
                "substep" => multibody_update = MultibodyUpdate::Substep,
                other => match other.strip_prefix("pd=") {
                    Some(value) => prediction = value.parse().expect("pd=METRES"),
                    None => panic!("unknown option {other:?} in {spec}"),
                },
            }
        }
        let mut config = EnvConfig {
            arm,
            ..EnvConfig::default()
        };
        let dt: f64 = dt.parse().expect("dt");
        let substeps: f64 = substeps.parse().expect("substeps");
        config.control_frequency = 1.0 / (dt * substeps);
        config.physics.solver.dt = dt;
        config.physics.solver.solver_iterations = iterations.parse().expect("iterations");
        config.physics.solver.multibody_update = multibody_update;
        config.physics.solver.contact_prediction_distance = prediction;
        let rate = env_steps_per_second(&config)?;
        let mut sim = Simulation::new(config.sim_config()?)?;
        let plan = TutorialSequence::for_scene(&sim);
        let grasp = demo::run(&mut sim, &plan)?;
        let (creep2, creep10, held) = swing_creep(&config.sim_config()?)?;
        let mut placed = Vec::new();
        for mode in [ControlMode::Ee, ControlMode::Joints] {
            let mut c = config.clone();
            c.control_mode = mode;
            let report = evaluate(&c, episodes, 32, None, 0, |_| {})?;
            placed.push(report.placed_rate() * 100.0);
        }
        println!(
            "{spec:<17} {rate:>11.0}  {:.2}/{:.2}, {:.2}/{:.2}         {:>6.2}      {:.2}/{:.2}{}       {:.1}/{:.1} %",
            grasp.carry_slip * 1e3,
            grasp.max_slip * 1e3,
            grasp.carry_slip_angle.to_degrees(),
            grasp.max_slip_angle.to_degrees(),
            grasp.max_tracking_error * 1e3,
            creep2 * 1e3,
            creep10 * 1e3,
            if held { "" } else { " DROPPED" },
            placed[0],
            placed[1],
        );
    }
    Ok(())
}
