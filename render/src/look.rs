//! Seeded visual randomisation (domain randomisation): [`VisualRandomization`], the ranges,
//! and what an episode looks like under them (camera pose, light, colours, pixel noise).

use nalgebra::Vector3;
use panda_rapier_core::{Error, Result};
use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::camera::Camera;
use crate::palette::{AMBIENT, DIFFUSE, FLOOR, LIGHT, OBJECTS, PLATFORM};

/// Seeded visual randomisation (domain randomisation) of the pictures [`crate::Renderer::render`]
/// draws of an environment. Each episode's look (camera pose, light, colours) is drawn from a
/// stream keyed by the episode's goal and `seed`, and each frame's noise from that key and the
/// step, so the same episode looks the same whatever the batch, the threads or the order of
/// the episodes, and another `seed` gives other looks. All ranges are half-widths of uniform
/// draws around the unrandomised scene; zero leaves that aspect alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VisualRandomization {
    /// The eye and the point looked at each move by up to this along every axis (m; at most
    /// 0.2).
    pub camera_position: f64,
    /// The vertical field of view changes by up to this (degrees; at most 20).
    pub camera_fov: f64,
    /// Each component of the direction towards the light, `(0.4, 0.3, 1.0)` before it is
    /// normalised, moves by up to this (at most 0.9, so the light stays above the floor).
    pub light_direction: f64,
    /// The ambient and the sun's light are scaled by a factor within `1 +- light_intensity`
    /// (below 1).
    pub light_intensity: f64,
    /// Every colour channel of each object, of the floor's two tiles and of the platform is
    /// scaled by its own factor within `1 +- colors` (below 1).
    pub colors: f64,
    /// Every channel of every pixel moves by a uniform integer in `[-noise, noise]` each frame
    /// (0-255 units; at most 64).
    pub noise: u8,
    /// The seed of the draws.
    pub seed: u64,
}

impl Default for VisualRandomization {
    /// The documented "on" ranges (what `visual_randomization=True` gives in Python).
    fn default() -> Self {
        Self {
            camera_position: 0.02,
            camera_fov: 2.0,
            light_direction: 0.3,
            light_intensity: 0.2,
            colors: 0.15,
            noise: 6,
            seed: 0,
        }
    }
}

impl VisualRandomization {
    /// Checks every range.
    pub fn validate(&self) -> Result<()> {
        for (field, value, max, inclusive) in [
            ("camera_position", self.camera_position, 0.2, true),
            ("camera_fov", self.camera_fov, 20.0, true),
            ("light_direction", self.light_direction, 0.9, true),
            ("light_intensity", self.light_intensity, 1.0, false),
            ("colors", self.colors, 1.0, false),
        ] {
            let fits = value >= 0.0 && if inclusive { value <= max } else { value < max };
            if !fits {
                return Err(Error::InvalidConfig {
                    field: format!("randomization.{field}"),
                    reason: format!(
                        "must be in [0, {max}{} got {value}",
                        if inclusive { "]," } else { ")," }
                    ),
                });
            }
        }
        if self.noise > 64 {
            return Err(Error::InvalidConfig {
                field: "randomization.noise".into(),
                reason: format!("must be in [0, 64], got {}", self.noise),
            });
        }
        Ok(())
    }
}

/// What an episode looks like: the light and the colours (the unrandomised scene by default).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Look {
    /// Unit vector towards the light.
    pub(crate) light: Vector3<f64>,
    pub(crate) ambient: f64,
    pub(crate) diffuse: f64,
    pub(crate) floor: [[u8; 3]; 2],
    pub(crate) platform: [u8; 3],
    pub(crate) objects: [[u8; 3]; 3],
}

impl Default for Look {
    fn default() -> Self {
        Self {
            light: Vector3::from(LIGHT).normalize(),
            ambient: AMBIENT,
            diffuse: DIFFUSE,
            floor: FLOOR,
            platform: PLATFORM,
            objects: OBJECTS,
        }
    }
}

/// A key for an episode's draws: its goal's bits (drawn at random per episode, fixed within
/// it) mixed by SplitMix64's finaliser.
pub(crate) fn episode_key(goal: &[f64]) -> u64 {
    let mut h: u64 = 0x9e37_79b9_7f4a_7c15;
    for v in goal {
        h ^= v.to_bits();
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 31;
    }
    h
}

/// A factor within `1 +- range`.
fn factor(rng: &mut ChaCha8Rng, range: f64) -> f64 {
    1.0 + range * (2.0 * rng.random::<f64>() - 1.0)
}

fn scale_color(rng: &mut ChaCha8Rng, color: [u8; 3], range: f64) -> [u8; 3] {
    color.map(|c| {
        (f64::from(c) * factor(rng, range))
            .round()
            .clamp(0.0, 255.0) as u8
    })
}

impl Look {
    /// The camera and the look of the episode `key` under `r`: the base camera's eye and the
    /// point it looks at (`distance` ahead) jittered, its field of view, the light and the
    /// colours.
    pub(crate) fn draw(
        key: u64,
        r: &VisualRandomization,
        base: &Camera,
        distance: f64,
    ) -> (Camera, Look) {
        fn jitter(rng: &mut ChaCha8Rng, range: f64) -> Vector3<f64> {
            Vector3::from_fn(|_, _| range * (2.0 * rng.random::<f64>() - 1.0))
        }
        let mut rng = ChaCha8Rng::seed_from_u64(key);
        rng.set_stream(r.seed.wrapping_mul(2));
        let eye = base.eye + jitter(&mut rng, r.camera_position);
        let target = base.eye + base.forward * distance + jitter(&mut rng, r.camera_position);
        let fov = base.fov_y + r.camera_fov.to_radians() * (2.0 * rng.random::<f64>() - 1.0);
        // Validated ranges keep the eye away from the target and the field of view in range.
        let camera = Camera::look_at(eye, target, fov).unwrap_or(*base);
        let light = Vector3::from(LIGHT) + jitter(&mut rng, r.light_direction);
        let intensity = factor(&mut rng, r.light_intensity);
        let look = Look {
            light: light.normalize(),
            ambient: AMBIENT * intensity,
            diffuse: DIFFUSE * intensity,
            floor: FLOOR.map(|c| scale_color(&mut rng, c, r.colors)),
            platform: scale_color(&mut rng, PLATFORM, r.colors),
            objects: OBJECTS.map(|c| scale_color(&mut rng, c, r.colors)),
        };
        (camera, look)
    }
}

/// Moves every channel of `rgb` by a uniform integer in `[-noise, noise]`, drawn from the
/// episode key and the step.
pub(crate) fn add_noise(rgb: &mut [u8], key: u64, r: &VisualRandomization, step: u32) {
    let mut rng = ChaCha8Rng::seed_from_u64(key ^ u64::from(step).wrapping_mul(0x9e37_79b9));
    rng.set_stream(r.seed.wrapping_mul(2).wrapping_add(1));
    let n = i16::from(r.noise);
    let span = (2 * n + 1) as u32;
    for c in rgb {
        // Lemire's multiply-shift: a uniform value in [0, span) from 32 random bits (the
        // bias is below span / 2^32).
        let offset = ((u64::from(rng.next_u32()) * u64::from(span)) >> 32) as i16 - n;
        *c = (i16::from(*c) + offset).clamp(0, 255) as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{RenderConfig, Renderer};
    use panda_rapier_core::PandaEnv;

    #[test]
    fn bad_randomization_ranges_are_config_errors() {
        for json in [
            r#"{"randomization": {"colors": 1.0}}"#,
            r#"{"randomization": {"colors": -0.1}}"#,
            r#"{"randomization": {"light_intensity": 1.5}}"#,
            r#"{"randomization": {"camera_position": 0.5}}"#,
            r#"{"randomization": {"light_direction": 1.0}}"#,
            r#"{"randomization": {"noise": 65}}"#,
            r#"{"randomization": {"camera_fov": 30}}"#,
            r#"{"randomization": {"hue": 0.1}}"#,
            r#"{"camera": {"fov": 2}, "randomization": {"camera_fov": 2}}"#,
        ] {
            assert!(
                matches!(
                    RenderConfig::from_json(json),
                    Err(Error::InvalidConfig { .. })
                ),
                "{json}"
            );
        }
        let on = RenderConfig::from_json(r#"{"randomization": {}}"#).unwrap();
        assert_eq!(on.randomization, Some(VisualRandomization::default()));
    }

    fn episode(seed: u64) -> PandaEnv {
        let mut env = PandaEnv::new(panda_rapier_core::EnvConfig::default()).unwrap();
        env.reset(Some(seed), &panda_rapier_core::ResetOptions::default())
            .unwrap();
        env
    }

    fn picture(randomization: Option<VisualRandomization>, env: &PandaEnv) -> Vec<u8> {
        let config = RenderConfig {
            width: 48,
            height: 48,
            show_goal: false,
            randomization,
            ..Default::default()
        };
        Renderer::new(config).unwrap().render(env).rgb().to_vec()
    }

    #[test]
    fn randomized_pictures_are_drawn_from_the_episode_and_the_seed() {
        let env = episode(3);
        let plain = picture(None, &env);
        let on = Some(VisualRandomization::default());
        let first = picture(on.clone(), &env);
        // The same episode and seed: the same bits, from a fresh renderer or a reused one.
        assert_eq!(first, picture(on.clone(), &env));
        let mut renderer = Renderer::new(RenderConfig {
            width: 48,
            height: 48,
            show_goal: false,
            randomization: on.clone(),
            ..Default::default()
        })
        .unwrap();
        renderer.render(&episode(4));
        assert_eq!(renderer.render(&env).rgb(), first.as_slice());
        assert_ne!(first, plain);
        // Another seed, or another episode, looks different.
        let other_seed = Some(VisualRandomization {
            seed: 1,
            ..VisualRandomization::default()
        });
        assert_ne!(first, picture(other_seed, &env));
        // Nothing randomised: the plain picture, bit for bit.
        let zero = VisualRandomization {
            camera_position: 0.0,
            camera_fov: 0.0,
            light_direction: 0.0,
            light_intensity: 0.0,
            colors: 0.0,
            noise: 0,
            seed: 9,
        };
        assert_eq!(picture(Some(zero.clone()), &env), plain);
        // Noise alone moves every channel by at most its range.
        let noisy = picture(Some(VisualRandomization { noise: 5, ..zero }), &env);
        assert_ne!(noisy, plain);
        assert!(noisy
            .iter()
            .zip(&plain)
            .all(|(a, b)| (i16::from(*a) - i16::from(*b)).abs() <= 5));
    }
}
