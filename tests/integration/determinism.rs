//! Contract: the same configuration and the same commands give bit-identical states, whichever
//! thread or process runs the simulation and whatever else runs beside it.

use panda_rapier::demo::{self, TutorialSequence};
use panda_rapier::{JointControl, SimConfig, Simulation};

/// Every number of the state, as raw bits.
fn fingerprint(sim: &Simulation) -> Vec<u64> {
    let mut bits: Vec<u64> = sim
        .joint_positions()
        .into_iter()
        .chain(sim.joint_velocities())
        .map(f64::to_bits)
        .collect();
    let cube = sim.object_state(sim.object("cube").unwrap());
    for v in cube
        .position
        .iter()
        .chain(cube.orientation.coords.iter())
        .chain(cube.linear_velocity.iter())
        .chain(cube.angular_velocity.iter())
    {
        bits.push(v.to_bits());
    }
    for link in sim.link_states() {
        for v in link
            .state
            .position
            .iter()
            .chain(link.state.orientation.coords.iter())
        {
            bits.push(v.to_bits());
        }
    }
    bits
}

/// A run mixing all control modes and the grasp sequence; returns a fingerprint per phase.
fn scripted_run() -> Vec<Vec<u64>> {
    let mut sim = Simulation::new(SimConfig::default()).unwrap();
    let mut prints = Vec::new();
    let plan = TutorialSequence::for_scene(&sim);
    demo::run(&mut sim, &plan).unwrap();
    prints.push(fingerprint(&sim));
    let j2 = sim.model().joint_index("panda_joint2").unwrap();
    let j6 = sim.model().joint_index("panda_joint6").unwrap();
    sim.set_joint_control(j2, JointControl::Torque(-5.0))
        .unwrap();
    sim.set_joint_control(j6, JointControl::velocity(0.5))
        .unwrap();
    for _ in 0..25 {
        sim.step_control();
    }
    prints.push(fingerprint(&sim));
    prints
}

#[test]
fn same_commands_give_bit_identical_states() {
    let a = scripted_run();
    let b = scripted_run();
    assert_eq!(a, b);
}

#[test]
fn thread_placement_does_not_change_results() {
    let reference = scripted_run();
    let parallel: Vec<_> = (0..2)
        .map(|_| std::thread::spawn(scripted_run))
        .collect::<Vec<_>>()
        .into_iter()
        .map(|h| h.join().unwrap())
        .collect();
    for run in parallel {
        assert_eq!(run, reference);
    }
}

/// Set in the child process of `another_process_gives_the_same_bits`.
const CHILD: &str = "PANDA_RAPIER_DETERMINISM_CHILD";

#[test]
fn another_process_gives_the_same_bits() {
    let print = |runs: &[Vec<u64>]| {
        runs.iter()
            .map(|r| r.iter().map(|b| format!("{b:016x}")).collect::<String>())
            .collect::<Vec<_>>()
            .join("\n")
    };
    if std::env::var_os(CHILD).is_some() {
        println!("BITS\n{}\nEND", print(&scripted_run()));
        return;
    }
    // This test's name as the harness lists it: its module path without the crate's name.
    let name = match module_path!().split_once("::") {
        Some((_, module)) => format!("{module}::another_process_gives_the_same_bits"),
        None => "another_process_gives_the_same_bits".to_string(),
    };
    let output = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", &name, "--nocapture", "--test-threads=1"])
        .env(CHILD, "1")
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let stdout = String::from_utf8_lossy(&output.stdout);
    let child = stdout
        .split("BITS\n")
        .nth(1)
        .and_then(|rest| rest.split("\nEND").next())
        .expect("the child printed its fingerprint");
    assert_eq!(child, print(&scripted_run()));
}
