//! CPU rendering of panda_rapier scenes: no GPU, no display, no OpenGL or Vulkan.
//!
//! [`Renderer`] draws what [`Simulation::visual_primitives`] describes (the floor, the
//! platform, the cube and the robot's collision shapes) plus the goal, with a small z-buffer
//! rasteriser: flat shading from a directional light and ambient light, and shadows projected
//! onto the floor and the platform. The same state always gives the same bytes.
//!
//! ```
//! use panda_rapier_core::{EnvConfig, PandaEnv, ResetOptions};
//! use panda_rapier_render::{RenderConfig, Renderer};
//!
//! let mut env = PandaEnv::new(EnvConfig::default())?;
//! env.reset(Some(0), &ResetOptions::default())?;
//! let mut renderer = Renderer::new(RenderConfig::from_json(r#"{"width": 320, "height": 240}"#)?)?;
//! let frame = renderer.render(&env);
//! assert_eq!(frame.rgb().len(), 320 * 240 * 3);
//! # Ok::<(), panda_rapier_core::Error>(())
//! ```
//!
//! [`Simulation::visual_primitives`]: panda_rapier_core::Simulation::visual_primitives

pub mod camera;
mod config;
mod look;
pub mod mesh;
mod palette;
pub mod raster;
mod scene;
pub mod segmentation;
mod sensor;
mod shadow;

pub use camera::{Camera, CameraConfig};
pub use look::VisualRandomization;
pub use raster::Frame;
pub use scene::{RenderConfig, Renderer, MAX_SIZE};
pub use sensor::{Cameras, Entry, Modality, ObservationCamera, PointFrame, DEPTH_FAR, MAX_POINTS};
