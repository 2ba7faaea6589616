//! The tutorial's manual pick-and-place on the default scene, printed phase by phase.
//!
//! `cargo run --release --example pick_and_place [config.json] [--attach]`
//!
//! `--attach` holds the cube by the classic tutorial's fixed constraint once the fingers have
//! closed on it (a shortcut: see `GraspMode::Attach`), instead of by friction alone.

use panda_rapier::demo::{self, GraspMode, TutorialSequence};
use panda_rapier::{SimConfig, Simulation};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Optional: a JSON file with any SimConfig fields to override (unknown keys are errors).
    let args: Vec<String> = std::env::args().skip(1).collect();
    let attach = args.iter().any(|a| a == "--attach");
    let config = match args.iter().find(|a| !a.starts_with("--")) {
        Some(path) => SimConfig::from_json(&std::fs::read_to_string(path)?)?,
        None => SimConfig::default(),
    };
    let mut sim = Simulation::new(config)?;
    let mut plan = TutorialSequence::for_scene(&sim);
    if attach {
        plan.grasp = GraspMode::Attach;
    }
    let start = sim.object_state(sim.object("cube").unwrap()).position;
    println!(
        "panda_rapier: Franka Panda, cube {:.0} mm / {} kg at ({:.3}, {:.3}, {:.3}), physics dt {} s x {} substeps, {} solver iterations",
        sim.scene().objects[0].shape.cube_size().unwrap_or(f64::NAN) * 1000.0,
        sim.scene().objects[0].mass,
        start.x, start.y, start.z,
        sim.config().physics.solver.dt,
        sim.config().substeps,
        sim.config().physics.solver.solver_iterations,
    );
    let wall = std::time::Instant::now();
    let report = demo::run(&mut sim, &plan)?;
    let elapsed = wall.elapsed().as_secs_f64();
    let mut previous = 0.0;
    for (name, end) in &report.phases {
        println!("  {name:<10} {previous:6.2} s -> {end:6.2} s");
        previous = *end;
    }
    let p = report.final_position;
    println!("lifted            {:.3} m", report.lift);
    println!(
        "carried           {:.3} m (peak TCP speed {:.2} m/s)",
        report.carry_distance, report.peak_carry_speed
    );
    println!(
        "grip width        {:.4} m (cube {:.3} m)",
        report.grip_width,
        sim.scene().objects[0].shape.cube_size().unwrap_or(f64::NAN)
    );
    println!("slip in the hand  {:.2} mm, {:.2} deg from lift to placing; {:.2} mm, {:.2} deg during the carry",
        report.max_slip * 1e3, report.max_slip_angle.to_degrees(), report.carry_slip * 1e3, report.carry_slip_angle.to_degrees());
    println!("final cube centre ({:.4}, {:.4}, {:.4}), {:.1} mm from the target, speed {:.4} m/s, on the platform: {}",
        p.x, p.y, p.z, report.placement_error * 1e3, report.final_speed, report.on_platform);
    println!(
        "constraints between hand and cube: {} ({} grasp); non-finite state seen: {}",
        report.max_constraints_on_cube,
        if attach { "attach" } else { "friction" },
        report.non_finite_seen
    );
    println!(
        "largest IK residual {:.1e} m, largest TCP tracking gap {:.1} mm",
        report.max_ik_error,
        report.max_tracking_error * 1e3
    );
    println!(
        "simulated {:.2} s in {:.3} s wall clock ({:.0}x real time, {} physics steps)",
        sim.time(),
        elapsed,
        sim.time() / elapsed,
        sim.physics_steps()
    );
    Ok(())
}
