//! panda_rapier: Franka Panda pick-and-place on rapier3d.
//!
//! This facade re-exports [`panda_rapier_core`] and, as [`policies`], the scripted policies of
//! [`panda_rapier_policies`], and, as [`render`], the CPU renderer of [`panda_rapier_render`]; the top-level `tests/`, `benches/` and `examples/` use the API
//! through it exactly as users do.

pub use panda_rapier_core::*;

/// The core's [`task`](panda_rapier_core::task) module, with the environment's configuration
/// beside it as before 0.2 named it (`panda_rapier::task::EnvConfig`): tasks, their registry
/// and schema, plus [`EnvConfig`], [`ControlMode`] and
/// [`make_task`](panda_rapier_core::env::make_task) from [`env`](mod@panda_rapier_core::env).
pub mod task {
    pub use panda_rapier_core::env::LEGACY_KEYS_REMOVED_IN;
    pub use panda_rapier_core::env::{make_task, ControlMode, Deprecation, EnvConfig};
    pub use panda_rapier_core::task::*;
}
pub use panda_rapier_policies as policies;
pub use panda_rapier_render as render;

/// The classic tutorial's pick-and-place sequence (see [`panda_rapier_policies::tutorial`]).
pub use panda_rapier_policies::tutorial as demo;

/// The README's Rust examples, compiled and run as doc tests.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// The Rust guide's examples (docs/guide/rust.md), compiled and run as doc tests.
#[doc = include_str!("../docs/guide/rust.md")]
#[cfg(doctest)]
pub struct RustGuideDoctests;
