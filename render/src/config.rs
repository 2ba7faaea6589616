//! What a [`crate::Renderer`] draws and how big: [`RenderConfig`].

use panda_rapier_core::{Error, Result};
use serde::{Deserialize, Serialize};

use crate::camera::{Camera, CameraConfig};
use crate::look::VisualRandomization;

/// Largest width or height accepted (pixels).
pub const MAX_SIZE: u32 = 4096;

/// What to draw and how big: picture size and camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderConfig {
    /// Width in pixels (1 to [`MAX_SIZE`]; default [`RenderConfig::DEFAULT_WIDTH`]).
    pub width: u32,
    /// Height in pixels (1 to [`MAX_SIZE`]; default [`RenderConfig::DEFAULT_HEIGHT`]).
    pub height: u32,
    /// The camera.
    pub camera: CameraConfig,
    /// Whether the goal markers are drawn (default true; observation cameras leave them out,
    /// so that a relabelled goal never contradicts the picture).
    pub show_goal: bool,
    /// Seeded visual randomisation of the pictures of an environment (default none).
    pub randomization: Option<VisualRandomization>,
}

impl Default for RenderConfig {
    fn default() -> Self {
        Self {
            width: Self::DEFAULT_WIDTH,
            height: Self::DEFAULT_HEIGHT,
            camera: CameraConfig::default(),
            show_goal: true,
            randomization: None,
        }
    }
}

impl RenderConfig {
    /// The default picture width (pixels); Python's `render()` frames default to it too.
    pub const DEFAULT_WIDTH: u32 = 720;
    /// The default picture height (pixels).
    pub const DEFAULT_HEIGHT: u32 = 480;

    /// Reads and validates a JSON configuration; unknown keys are rejected.
    pub fn from_json(text: &str) -> Result<Self> {
        let config: Self = serde_json::from_str(text).map_err(|e| Error::InvalidConfig {
            field: "render".into(),
            reason: e.to_string(),
        })?;
        config.validate()?;
        Ok(config)
    }

    /// Checks the size and the camera.
    pub fn validate(&self) -> Result<()> {
        for (field, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_SIZE).contains(&v) {
                return Err(Error::InvalidConfig {
                    field: field.into(),
                    reason: format!("must be in [1, {MAX_SIZE}] pixels, got {v}"),
                });
            }
        }
        let camera = Camera::new(&self.camera)?;
        if let Some(randomization) = &self.randomization {
            randomization.validate()?;
            let fov = camera.fov_y.to_degrees();
            if !(fov - randomization.camera_fov >= 1.0 && fov + randomization.camera_fov <= 170.0) {
                return Err(Error::InvalidConfig {
                    field: "randomization.camera_fov".into(),
                    reason: format!(
                        "the field of view {fov} degrees +- {} leaves [1, 170]",
                        randomization.camera_fov
                    ),
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_validated() {
        for json in [
            r#"{"width": 0}"#,
            r#"{"height": 100000}"#,
            r#"{"width": -3}"#,
            r#"{"colour": 1}"#,
            r#"{"camera": {"fov": 0}}"#,
        ] {
            assert!(
                matches!(
                    RenderConfig::from_json(json),
                    Err(Error::InvalidConfig { .. })
                ),
                "{json}"
            );
        }
        assert_eq!(
            RenderConfig::from_json("{}").unwrap(),
            RenderConfig::default()
        );
    }
}
