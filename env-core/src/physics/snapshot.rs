//! Saving and restoring the whole dynamic state of a world, bit for bit.

use rapier3d::dynamics::{
    ImpulseJointHandle, ImpulseJointSet, IslandManager, MultibodyJointSet, RigidBodySet,
};
use rapier3d::geometry::{BroadPhaseBvh, ColliderSet, NarrowPhase};

use super::touch::TouchWindow;
use super::{Arm, JointControl, ObjectId, Scene, Simulation};
use crate::config::SimConfig;
use crate::error::{Error, Result};

/// Everything that decides how a [`Simulation`] continues: bodies, colliders, joints, contact
/// and broad-phase caches, motor commands and the clock. Restoring it with
/// [`Simulation::restore`] continues bit-identically to the moment it was taken.
#[derive(Clone)]
pub struct SimSnapshot {
    config: SimConfig,
    scene: Scene,
    islands: IslandManager,
    broad_phase: BroadPhaseBvh,
    narrow_phase: NarrowPhase,
    bodies: RigidBodySet,
    colliders: ColliderSet,
    impulse_joints: ImpulseJointSet,
    multibody_joints: MultibodyJointSet,
    arm: Arm,
    controls: Vec<JointControl>,
    torques_applied: bool,
    attachments: Vec<(ObjectId, ImpulseJointHandle)>,
    touch_window: TouchWindow,
    time: f64,
    steps: u64,
}

impl std::fmt::Debug for SimSnapshot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimSnapshot")
            .field("time", &self.time)
            .field("steps", &self.steps)
            .finish_non_exhaustive()
    }
}

impl Simulation {
    /// Copies the whole dynamic state (see [`SimSnapshot`]).
    pub fn snapshot(&self) -> SimSnapshot {
        SimSnapshot {
            config: self.config.clone(),
            scene: self.scene.clone(),
            islands: self.world.islands.clone(),
            broad_phase: self.world.broad_phase.clone(),
            narrow_phase: self.world.narrow_phase.clone(),
            bodies: self.world.bodies.clone(),
            colliders: self.world.colliders.clone(),
            impulse_joints: self.world.impulse_joints.clone(),
            multibody_joints: self.world.multibody_joints.clone(),
            arm: self.arm.clone(),
            controls: self.controls.clone(),
            torques_applied: self.torques_applied,
            attachments: self.attachments.clone(),
            touch_window: self.touch_window.clone(),
            time: self.time,
            steps: self.steps,
        }
    }

    /// Puts the world back into the state `snapshot` recorded. The snapshot must come from a
    /// simulation built from an equal configuration.
    pub fn restore(&mut self, snapshot: &SimSnapshot) -> Result<()> {
        if snapshot.config != self.config || snapshot.scene != self.scene {
            return Err(Error::SnapshotMismatch {
                reason: "it was taken from a simulation with a different configuration or scene"
                    .into(),
            });
        }
        self.world.islands.clone_from(&snapshot.islands);
        self.world.broad_phase.clone_from(&snapshot.broad_phase);
        self.world.narrow_phase.clone_from(&snapshot.narrow_phase);
        self.world.bodies.clone_from(&snapshot.bodies);
        self.world.colliders.clone_from(&snapshot.colliders);
        self.world
            .impulse_joints
            .clone_from(&snapshot.impulse_joints);
        self.world
            .multibody_joints
            .clone_from(&snapshot.multibody_joints);
        self.arm.clone_from(&snapshot.arm);
        self.controls.clone_from(&snapshot.controls);
        self.torques_applied = snapshot.torques_applied;
        self.attachments.clone_from(&snapshot.attachments);
        // Keeps this buffer's capacity: stepping after a restore does not allocate.
        self.touch_window.copy_from(&snapshot.touch_window);
        self.time = snapshot.time;
        self.steps = snapshot.steps;
        Ok(())
    }
}
