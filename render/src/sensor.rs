//! [`Cameras`]: camera images as observations, the [`Sensor`] a [`PandaVecEnv`] runs on every
//! environment's thread after each step and reset.
//!
//! [`PandaVecEnv`]: panda_rapier_core::PandaVecEnv

use panda_rapier_core::{Error, PandaEnv, Result, Sensor};
use serde::{Deserialize, Serialize};

use crate::scene::{RenderConfig, Renderer};

/// One camera of an observation: the key it appears under and what it sees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationCamera {
    /// The observation key of its image.
    pub key: String,
    /// Size, camera and goal markers.
    pub render: RenderConfig,
}

/// One or more cameras whose HxWx3 RGB images, one after the other in the given order, make an
/// environment's image observation. Each image depends on the environment's state only.
#[derive(Debug, Clone)]
pub struct Cameras {
    keys: Vec<String>,
    renderers: Vec<Renderer>,
    len: usize,
}

impl Cameras {
    /// Cameras from their configurations; at least one, with distinct non-empty keys.
    pub fn new(cameras: Vec<ObservationCamera>) -> Result<Self> {
        if cameras.is_empty() {
            return Err(invalid("must name at least one camera"));
        }
        let mut keys: Vec<String> = Vec::with_capacity(cameras.len());
        let mut renderers = Vec::with_capacity(cameras.len());
        for camera in cameras {
            if camera.key.is_empty() || keys.contains(&camera.key) {
                return Err(invalid(format!(
                    "keys must be distinct and non-empty, got {:?} twice or empty",
                    camera.key
                )));
            }
            keys.push(camera.key);
            renderers.push(Renderer::new(camera.render)?);
        }
        let len = renderers.iter().map(image_len).sum();
        Ok(Self {
            keys,
            renderers,
            len,
        })
    }

    /// Cameras from a JSON list of `{"key": ..., "render": {width, height, camera, show_goal}}`.
    pub fn from_json(text: &str) -> Result<Self> {
        let cameras: Vec<ObservationCamera> =
            serde_json::from_str(text).map_err(|e| invalid(e.to_string()))?;
        Self::new(cameras)
    }

    /// The observation keys, in order.
    pub fn keys(&self) -> &[String] {
        &self.keys
    }

    /// Each camera's image shape `(height, width, 3)`, in order.
    pub fn shapes(&self) -> Vec<(usize, usize, usize)> {
        self.renderers
            .iter()
            .map(|r| (r.config().height as usize, r.config().width as usize, 3))
            .collect()
    }
}

fn image_len(renderer: &Renderer) -> usize {
    renderer.config().width as usize * renderer.config().height as usize * 3
}

fn invalid(reason: impl Into<String>) -> Error {
    Error::InvalidConfig {
        field: "cameras".into(),
        reason: reason.into(),
    }
}

impl Sensor for Cameras {
    fn len(&self) -> usize {
        self.len
    }

    fn observe(&mut self, env: &PandaEnv, out: &mut [u8]) {
        let mut start = 0;
        for renderer in &mut self.renderers {
            let len = image_len(renderer);
            out[start..start + len].copy_from_slice(renderer.render(env).rgb());
            start += len;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use panda_rapier_core::{AutoresetMode, EnvConfig, PandaVecEnv, ResetOptions};

    fn cameras(size: u32) -> Cameras {
        let render = |azimuth: f64| RenderConfig {
            width: size,
            height: size,
            camera: crate::CameraConfig {
                azimuth: Some(azimuth),
                ..Default::default()
            },
            show_goal: false,
            randomization: None,
        };
        Cameras::new(vec![
            ObservationCamera {
                key: "front".into(),
                render: render(0.0),
            },
            ObservationCamera {
                key: "side".into(),
                render: render(90.0),
            },
        ])
        .unwrap()
    }

    #[test]
    fn images_follow_the_state_whatever_the_batch_and_threads() {
        let mut single = PandaEnv::with_index(EnvConfig::default(), 2).unwrap();
        single.reset(Some(7), &ResetOptions::default()).unwrap();
        let mut expected = vec![0; cameras(16).len()];
        cameras(16).observe(&single, &mut expected);

        for (num_envs, threads) in [(3, 1), (5, 2)] {
            let mut vec = PandaVecEnv::new(
                EnvConfig::default(),
                num_envs,
                Some(threads),
                AutoresetMode::SameStep,
            )
            .unwrap();
            vec.reset(Some(7)).unwrap();
            vec.set_sensors((0..num_envs).map(|_| Box::new(cameras(16)) as _).collect())
                .unwrap();
            let mut data = vec![0; num_envs * vec.sensor_len()];
            vec.sensor_data(&mut data).unwrap();
            let row = &data[2 * vec.sensor_len()..3 * vec.sensor_len()];
            assert_eq!(row, expected.as_slice(), "num_envs {num_envs}");
        }
    }

    #[test]
    fn bad_camera_lists_are_config_errors() {
        assert!(matches!(
            Cameras::from_json("[]"),
            Err(Error::InvalidConfig { .. })
        ));
        assert!(matches!(
            Cameras::from_json(r#"[{"key": "a", "render": {"width": 0}}]"#),
            Err(Error::InvalidConfig { .. })
        ));
        let twice = r#"[{"key": "a", "render": {}}, {"key": "a", "render": {}}]"#;
        assert!(matches!(
            Cameras::from_json(twice),
            Err(Error::InvalidConfig { .. })
        ));
        assert!(matches!(
            Cameras::from_json("{"),
            Err(Error::InvalidConfig { .. })
        ));
    }
}
