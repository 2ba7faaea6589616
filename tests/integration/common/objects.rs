//! Helpers shared by the object tests (`object_shapes.rs`, `mesh_objects.rs`): a moving
//! object of 0.1 kg, a world of a scene with the default robot, and stepping by time.

use panda_rapier::{ObjectShape, ObjectSpec, RobotModel, Scene, SimConfig, Simulation};

/// A moving object of `shape` (0.1 kg, friction 0.8) at `position`.
pub fn object(name: &str, shape: ObjectShape, position: [f64; 3]) -> ObjectSpec {
    ObjectSpec {
        name: name.into(),
        shape,
        mass: 0.1,
        friction: 0.8,
        position,
        fixed: false,
        visuals: Vec::new(),
    }
}

/// The default robot in `scene`.
pub fn world(scene: Scene) -> Simulation {
    let config = SimConfig::default();
    let model = RobotModel::from_config(&config).unwrap();
    Simulation::with_scene(config, model, scene).unwrap()
}

/// Steps the physics for `seconds` of simulated time.
pub fn run(sim: &mut Simulation, seconds: f64) {
    let end = sim.time() + seconds;
    while sim.time() < end - 1e-9 {
        sim.step();
    }
}
