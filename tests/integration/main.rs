//! The engine's integration tests, one module per subject, linked into one test binary.
//!
//! Each test binary links the whole engine, and cargo runs test binaries one after another:
//! as 26 binaries they linked the engine 26 times, and the two slow subjects (`tasks`,
//! `scripted_policy`) ran alone in turn. One binary links it once and runs every subject's
//! tests side by side. Run a subject's tests with a filter, for example
//! `cargo test --release --test integration grasp_sequence -- --nocapture`.
//! `tests/allocations.rs` stays a binary of its own: its counting global allocator would count
//! every test in its binary.

mod common {
    pub mod obj_files;
    pub mod objects;
}

mod articulation;
mod autoreset;
mod determinism;
mod env_contract;
mod env_determinism;
mod errors;
mod grasp_planning;
mod grasp_sequence;
mod inverse_kinematics;
mod kinematic_arm;
mod mesh_objects;
mod multibody_update;
mod object_shapes;
mod osc_control;
mod pose_control;
mod properties;
mod random_actions;
mod reference_urdf;
mod render;
mod robot_api;
mod scripted_policy;
mod snapshot_roundtrip;
mod task_episode;
mod tasks;
mod touch;
mod visual_meshes;
