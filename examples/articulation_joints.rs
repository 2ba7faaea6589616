//! The two joint models of an articulated object side by side (issue 57): the shipped
//! cabinet, tilted 30 degrees so gravity pulls its 1.5 kg drawer open, stepped 3 s with the
//! robot idle beside it, with the drawer's joint in a multibody and as an impulse joint. Prints
//! how far the drawer ran past its 25 cm limit, how far it left its axis (sideways and up, in
//! the cabinet's frame), where it ended and the physics steps per second of the whole world.
//!
//! `cargo run --release --example articulation_joints`

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use panda_rapier::{
    ArticulationJoints, ArticulationSpec, RobotModel, Scene, SimConfig, Simulation,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let cabinet = Arc::new(RobotModel::cabinet()?);
    let pose = Isometry3::from_parts(
        Translation3::new(1.2, 0.0, 0.4),
        UnitQuaternion::from_euler_angles(0.0, 30f64.to_radians(), 0.0),
    );
    let drawer = cabinet.link_index("drawer")?;
    for joints in [ArticulationJoints::Multibody, ArticulationJoints::Impulse] {
        let scene = Scene {
            articulations: vec![ArticulationSpec {
                name: "cabinet".into(),
                model: Arc::clone(&cabinet),
                pose,
                friction: 1.0,
                joints,
            }],
            ..Scene::default()
        };
        let config = SimConfig::default();
        let robot = RobotModel::from_config(&config)?;
        let mut sim = Simulation::with_scene(config, robot, scene)?;
        let id = sim.articulation("cabinet")?;
        let start = sim.articulation_link_state(id, drawer)?.position;
        let (mut past_limit, mut off_axis) = (0.0f64, 0.0f64);
        let steps = (3.0 / sim.config().physics.solver.dt).round() as usize;
        let clock = Instant::now();
        for _ in 0..steps {
            sim.step();
            let q = sim.articulation_joint_state(id, 0)?.position;
            past_limit = past_limit.max(q - 0.25);
            // The drawer's displacement in the cabinet's frame: all of it should be along x.
            let moved = pose.rotation.inverse()
                * (sim.articulation_link_state(id, drawer)?.position - start);
            off_axis = off_axis.max(moved.y.hypot(moved.z));
        }
        let seconds = clock.elapsed().as_secs_f64();
        let end = sim.articulation_joint_state(id, 0)?;
        println!(
            "{joints:?}: ended at {:.4} m ({:.2e} m/s), at most {:.2} mm past the limit, \
             {:.3} mm off its axis; {:.0} physics steps/s",
            end.position,
            end.velocity,
            1e3 * past_limit,
            1e3 * off_axis,
            steps as f64 / seconds
        );
    }
    Ok(())
}
