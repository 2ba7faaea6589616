//! [`Cameras`]: camera images as observations, the [`Sensor`] a [`PandaVecEnv`] runs on every
//! environment's thread after each step and reset. Each camera gives one or more
//! [`Modality`]s: colour, depth, segmentation ids and a point cloud, each one observation
//! entry ([`Entry`]).
//!
//! Over 600 lines with its tests, which are half of it: they drive every modality through the
//! vector env and check the points against the scene, and belong beside the layout they pin.
//!
//! [`PandaVecEnv`]: panda_rapier_core::PandaVecEnv

use nalgebra::Vector3;
use panda_rapier_core::{Error, PandaEnv, Result, Sensor};
use serde::{Deserialize, Serialize};

use crate::scene::{RenderConfig, Renderer};

/// The depth of pixels where nothing is drawn (the sky) or the surface is farther (m): depth
/// images lie in `[0, DEPTH_FAR]`, and a point cloud keeps the pixels nearer than this.
pub const DEPTH_FAR: f32 = 10.0;

/// The largest point count of a point cloud.
pub const MAX_POINTS: usize = 1 << 20;

/// What a camera observes, each an entry of the observation (in this order for each camera).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Modality {
    /// Colour: `(height, width, 3)` uint8, under the camera's key.
    Rgb,
    /// Depth: `(height, width, 1)` float32 metres along the optical axis, [`DEPTH_FAR`] where
    /// nothing nearer is drawn; under `<key>_depth`.
    Depth,
    /// Segmentation: `(height, width, 1)` uint8 ids ([`crate::segmentation`]); under
    /// `<key>_segmentation`.
    Segmentation,
    /// A point cloud: `points` pixels back-projected (`(points, 3)` float32 metres) under
    /// `<key>_points`, with `<key>_points_mask` (`(points,)` uint8, 1 for a point, 0 for
    /// padding), and the points' colours (`<key>_points_rgb`) and ids
    /// (`<key>_points_segmentation`) when the camera gives those too.
    Points,
}

/// The frame point clouds are given in.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PointFrame {
    /// The world frame (m).
    #[default]
    World,
    /// The camera's frame: x to the picture's right, y to its top, z along the optical axis
    /// away from the eye (m).
    Camera,
}

fn rgb_only() -> Vec<Modality> {
    vec![Modality::Rgb]
}

fn default_points() -> usize {
    1024
}

/// One camera of an observation: the key it appears under and what it sees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationCamera {
    /// The observation key of its image.
    pub key: String,
    /// Size, camera and goal markers.
    pub render: RenderConfig,
    /// What it gives (default colour alone); each at most once, given in any order, laid out
    /// in [`Modality`]'s order.
    #[serde(default = "rgb_only")]
    pub modalities: Vec<Modality>,
    /// The number of points of its point cloud (1 to [`MAX_POINTS`]; default 1024).
    #[serde(default = "default_points")]
    pub points: usize,
    /// The frame of its point cloud (default the world's).
    #[serde(default)]
    pub points_frame: PointFrame,
}

/// One entry of the observation: its key, its shape and element type, and its bytes' length.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The observation key.
    pub key: String,
    /// The array's shape.
    pub shape: Vec<usize>,
    /// `"uint8"` or `"float32"` (little-endian).
    pub dtype: &'static str,
    /// The least and greatest value an element takes (a point's coordinates: any finite
    /// `f32`, so Gymnasium's checker sees finite bounds).
    pub bounds: (f64, f64),
}

impl Entry {
    /// Its length in bytes.
    pub fn len(&self) -> usize {
        self.shape.iter().product::<usize>() * if self.dtype == "float32" { 4 } else { 1 }
    }

    /// Whether it holds no bytes (never: shapes are at least 1 in every axis).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A camera's renderer and what it gives.
#[derive(Debug, Clone)]
struct Camera {
    renderer: Renderer,
    modalities: Vec<Modality>,
    points: usize,
    points_frame: PointFrame,
}

impl Camera {
    fn has(&self, modality: Modality) -> bool {
        self.modalities.contains(&modality)
    }
}

/// One or more cameras whose entries ([`Cameras::entries`]: colour images, depth images,
/// segmentation images, point clouds), one after the other in the given order, make an
/// environment's image observation. Each entry depends on the environment's state only.
#[derive(Debug, Clone)]
pub struct Cameras {
    cameras: Vec<Camera>,
    entries: Vec<Entry>,
    len: usize,
    /// The valid pixels of a point cloud (a scratch buffer).
    valid: Vec<u32>,
}

impl Cameras {
    /// Cameras from their configurations; at least one, with distinct non-empty keys, each
    /// with at least one modality.
    pub fn new(cameras: Vec<ObservationCamera>) -> Result<Self> {
        if cameras.is_empty() {
            return Err(invalid("must name at least one camera"));
        }
        let mut keys: Vec<String> = Vec::with_capacity(cameras.len());
        let mut built = Vec::with_capacity(cameras.len());
        let mut entries = Vec::new();
        for camera in cameras {
            if camera.key.is_empty() || keys.contains(&camera.key) {
                return Err(invalid(format!(
                    "keys must be distinct and non-empty, got {:?} twice or empty",
                    camera.key
                )));
            }
            let mut modalities = camera.modalities.clone();
            modalities.sort();
            modalities.dedup();
            if modalities.is_empty() || modalities.len() != camera.modalities.len() {
                return Err(invalid(format!(
                    "camera {:?}: modalities must be distinct and at least one, got {:?}",
                    camera.key, camera.modalities
                )));
            }
            if !(1..=MAX_POINTS).contains(&camera.points) {
                return Err(Error::InvalidConfig {
                    field: "points".into(),
                    reason: format!(
                        "camera {:?}: must be in [1, {MAX_POINTS}], got {}",
                        camera.key, camera.points
                    ),
                });
            }
            let mut renderer = Renderer::new(camera.render)?;
            let (h, w) = (
                renderer.config().height as usize,
                renderer.config().width as usize,
            );
            let n = camera.points;
            let key = &camera.key;
            let bytes = (0.0, 255.0);
            let entry = |suffix: &str, shape: Vec<usize>, dtype, bounds| Entry {
                key: format!("{key}{suffix}"),
                shape,
                dtype,
                bounds,
            };
            for modality in &modalities {
                match modality {
                    Modality::Rgb => entries.push(entry("", vec![h, w, 3], "uint8", bytes)),
                    Modality::Depth => entries.push(entry(
                        "_depth",
                        vec![h, w, 1],
                        "float32",
                        (0.0, f64::from(DEPTH_FAR)),
                    )),
                    Modality::Segmentation => {
                        entries.push(entry("_segmentation", vec![h, w, 1], "uint8", bytes))
                    }
                    Modality::Points => {
                        let space = (f64::from(f32::MIN), f64::from(f32::MAX));
                        entries.push(entry("_points", vec![n, 3], "float32", space));
                        entries.push(entry("_points_mask", vec![n], "uint8", (0.0, 1.0)));
                        if modalities.contains(&Modality::Rgb) {
                            entries.push(entry("_points_rgb", vec![n, 3], "uint8", bytes));
                        }
                        if modalities.contains(&Modality::Segmentation) {
                            entries.push(entry("_points_segmentation", vec![n], "uint8", bytes));
                        }
                    }
                }
            }
            renderer.set_segmentation(modalities.contains(&Modality::Segmentation));
            keys.push(camera.key);
            built.push(Camera {
                renderer,
                modalities,
                points: n,
                points_frame: camera.points_frame,
            });
        }
        for (i, entry) in entries.iter().enumerate() {
            if entries[..i].iter().any(|e| e.key == entry.key) {
                return Err(invalid(format!(
                    "two entries are named {:?} (a camera's key and another's entry)",
                    entry.key
                )));
            }
        }
        let len = entries.iter().map(Entry::len).sum();
        Ok(Self {
            cameras: built,
            entries,
            len,
            valid: Vec::new(),
        })
    }

    /// Cameras from a JSON list of `{"key": ..., "render": {width, height, camera, show_goal},
    /// "modalities": [...], "points": ..., "points_frame": ...}` (the last three optional).
    pub fn from_json(text: &str) -> Result<Self> {
        let cameras: Vec<ObservationCamera> =
            serde_json::from_str(text).map_err(|e| invalid(e.to_string()))?;
        Self::new(cameras)
    }

    /// The observation entries, in order (their bytes follow one another in this order).
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// The observation keys, in order.
    pub fn keys(&self) -> Vec<String> {
        self.entries.iter().map(|e| e.key.clone()).collect()
    }

    /// Each entry's shape, in order (`(height, width, 3)` for colour images).
    pub fn shapes(&self) -> Vec<Vec<usize>> {
        self.entries.iter().map(|e| e.shape.clone()).collect()
    }
}

fn invalid(reason: impl Into<String>) -> Error {
    Error::InvalidConfig {
        field: "cameras".into(),
        reason: reason.into(),
    }
}

/// Writes `values` as little-endian bytes into `out` (of four times their length).
fn put_f32(out: &mut [u8], values: impl Iterator<Item = f32>) {
    for (chunk, v) in out.chunks_exact_mut(4).zip(values) {
        chunk.copy_from_slice(&v.to_le_bytes());
    }
}

/// A pixel's depth (m) from its inverse depth: [`DEPTH_FAR`] where nothing nearer was drawn.
fn depth_of(inv_depth: f32) -> f32 {
    let d = 1.0 / inv_depth;
    if d < DEPTH_FAR {
        d
    } else {
        DEPTH_FAR
    }
}

impl Sensor for Cameras {
    fn len(&self) -> usize {
        self.len
    }

    fn observe(&mut self, env: &PandaEnv, out: &mut [u8]) {
        let mut start = 0;
        let mut take = |len: usize| {
            let range = start..start + len;
            start += len;
            range
        };
        for camera in &mut self.cameras {
            camera.renderer.render(env);
            let frame = camera.renderer.frame();
            let pixels = frame.width() as usize * frame.height() as usize;
            if camera.has(Modality::Rgb) {
                out[take(pixels * 3)].copy_from_slice(frame.rgb());
            }
            if camera.has(Modality::Depth) {
                let inv = frame.inv_depths().iter();
                put_f32(&mut out[take(pixels * 4)], inv.map(|&z| depth_of(z)));
            }
            if camera.has(Modality::Segmentation) {
                out[take(pixels)].copy_from_slice(frame.segments());
            }
            if camera.has(Modality::Points) {
                let n = camera.points;
                let points = take(n * 12);
                let mask = take(n);
                let colors = camera.has(Modality::Rgb).then(|| take(n * 3));
                let ids = camera.has(Modality::Segmentation).then(|| take(n));
                // The pixels nearer than the far depth, row by row; `n` of them evenly spaced
                // (the k-th point is valid pixel floor(k * valid / n)), or all of them followed
                // by padding.
                self.valid.clear();
                self.valid.extend(
                    (0u32..)
                        .zip(frame.inv_depths())
                        .filter(|&(_, &z)| depth_of(z) < DEPTH_FAR)
                        .map(|(i, _)| i),
                );
                let valid = self.valid.len();
                let chosen = |k: usize| -> Option<usize> {
                    if valid >= n {
                        Some(self.valid[k * valid / n] as usize)
                    } else {
                        self.valid.get(k).map(|&i| i as usize)
                    }
                };
                let view = back_projection(&camera.renderer, camera.points_frame);
                let width = frame.width() as usize;
                let points_out = &mut out[points];
                for k in 0..n {
                    let p = chosen(k).map_or([0.0; 3], |i| {
                        let (x, y) = (i % width, i / width);
                        view(x, y, depth_of(frame.inv_depths()[i]))
                    });
                    put_f32(&mut points_out[k * 12..k * 12 + 12], p.into_iter());
                }
                for k in 0..n {
                    out[mask.start + k] = u8::from(chosen(k).is_some());
                }
                if let Some(colors) = colors {
                    for k in 0..n {
                        let c = chosen(k).map_or([0; 3], |i| {
                            let rgb = frame.rgb();
                            [rgb[i * 3], rgb[i * 3 + 1], rgb[i * 3 + 2]]
                        });
                        out[colors.start + k * 3..colors.start + k * 3 + 3].copy_from_slice(&c);
                    }
                }
                if let Some(ids) = ids {
                    for k in 0..n {
                        out[ids.start + k] = chosen(k).map_or(0, |i| frame.segments()[i]);
                    }
                }
            }
        }
    }
}

/// Pixel (`x`, `y`) at `depth` (m) as a point of `frame`, for the camera the renderer last
/// drew with: through the pixel's centre, `depth` along the optical axis.
fn back_projection(
    renderer: &Renderer,
    frame: PointFrame,
) -> impl Fn(usize, usize, f32) -> [f32; 3] {
    let camera = *renderer.camera();
    let config = renderer.config();
    let focal = camera.focal_px(config.height);
    let (cx, cy) = (
        f64::from(config.width) / 2.0,
        f64::from(config.height) / 2.0,
    );
    move |x, y, depth| {
        let z = f64::from(depth);
        let view = Vector3::new(
            (x as f64 + 0.5 - cx) * z / focal,
            (cy - (y as f64 + 0.5)) * z / focal,
            z,
        );
        let p = match frame {
            PointFrame::Camera => view,
            PointFrame::World => {
                camera.eye + camera.right * view.x + camera.up * view.y + camera.forward * view.z
            }
        };
        [p.x as f32, p.y as f32, p.z as f32]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use panda_rapier_core::{AutoresetMode, EnvConfig, PandaVecEnv, ResetOptions};

    fn cameras(size: u32) -> Cameras {
        cameras_with(size, &[Modality::Rgb])
    }

    const ALL: [Modality; 4] = [
        Modality::Points,
        Modality::Rgb,
        Modality::Segmentation,
        Modality::Depth,
    ];

    fn cameras_with(size: u32, modalities: &[Modality]) -> Cameras {
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
                modalities: modalities.to_vec(),
                points: 300,
                points_frame: PointFrame::World,
            },
            ObservationCamera {
                key: "side".into(),
                render: render(90.0),
                modalities: modalities.to_vec(),
                points: 300,
                points_frame: PointFrame::World,
            },
        ])
        .unwrap()
    }

    #[test]
    fn images_follow_the_state_whatever_the_batch_and_threads() {
        for modalities in [&[Modality::Rgb][..], &ALL[..]] {
            follow_the_state(modalities);
        }
    }

    fn follow_the_state(modalities: &[Modality]) {
        let cameras = |size| cameras_with(size, modalities);
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

    fn observe(cameras: &mut Cameras, env: &PandaEnv) -> Vec<(Entry, Vec<u8>)> {
        let mut out = vec![0; cameras.len()];
        cameras.observe(env, &mut out);
        let mut start = 0;
        cameras
            .entries()
            .iter()
            .map(|e| {
                start += e.len();
                (e.clone(), out[start - e.len()..start].to_vec())
            })
            .collect()
    }

    fn floats(bytes: &[u8]) -> Vec<f32> {
        bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[test]
    fn every_modality_leaves_the_colours_alone() {
        let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
        env.reset(Some(4242), &ResetOptions::default()).unwrap();
        let plain = observe(&mut cameras(32), &env);
        let all = observe(&mut cameras_with(32, &ALL), &env);
        let keys: Vec<&str> = all.iter().map(|(e, _)| e.key.as_str()).collect();
        assert_eq!(
            keys,
            [
                "front",
                "front_depth",
                "front_segmentation",
                "front_points",
                "front_points_mask",
                "front_points_rgb",
                "front_points_segmentation",
                "side",
                "side_depth",
                "side_segmentation",
                "side_points",
                "side_points_mask",
                "side_points_rgb",
                "side_points_segmentation"
            ]
        );
        assert_eq!(plain[0].1, all[0].1);
        assert_eq!(plain[1].1, all[7].1);
        // Depths are in (0, far]; the sky is far; the segmentation ids are the table's.
        let depth = floats(&all[1].1);
        assert!(depth.iter().all(|&d| d > 0.0 && d <= DEPTH_FAR));
        let table = crate::segmentation::table(env.simulation());
        for id in &all[2].1 {
            assert!(table.iter().any(|(known, _)| known == id), "{id}");
        }
        let cube = crate::segmentation::FIRST_OBJECT;
        assert!(all[2].1.contains(&cube) && all[2].1.contains(&crate::segmentation::FLOOR));
        // Points: as many as asked, all valid (the floor fills the lower picture).
        assert_eq!(floats(&all[3].1).len(), 300 * 3);
        assert!(all[4].1.iter().all(|&m| m == 1));
    }

    #[test]
    fn points_lie_on_the_surfaces_they_show() {
        let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
        env.reset(Some(4243), &ResetOptions::default()).unwrap();
        let mut cameras = cameras_with(64, &[Modality::Points, Modality::Segmentation]);
        let got = observe(&mut cameras, &env);
        let (points, ids) = (floats(&got[1].1), &got[3].1);
        // A pixel of 64 at 45 degrees, 2 m away, spans about 2.6 cm.
        let footprint = 0.03;
        let mut on_floor = 0;
        for (p, id) in points.chunks_exact(3).zip(ids.iter()) {
            if *id == crate::segmentation::FLOOR {
                assert!(p[2].abs() < footprint, "{p:?}");
                on_floor += 1;
            }
        }
        assert!(on_floor > 50, "{on_floor}");
        // A camera frame point is the world point seen by the camera.
        let mut local = cameras_with(64, &[Modality::Points]);
        for camera in &mut local.cameras {
            camera.points_frame = PointFrame::Camera;
        }
        let seen = observe(&mut local, &env);
        let camera = *cameras.cameras[0].renderer.camera();
        for (w, c) in floats(&got[1].1)
            .chunks_exact(3)
            .zip(floats(&seen[0].1).chunks_exact(3))
        {
            let v = camera.to_view(&Vector3::new(w[0], w[1], w[2]).cast::<f64>());
            assert!((v - Vector3::new(c[0], c[1], c[2]).cast::<f64>()).norm() < 1e-4);
        }
    }

    #[test]
    fn bad_modalities_and_point_counts_are_config_errors() {
        for (json, field) in [
            (
                r#"[{"key": "a", "render": {}, "modalities": ["heat"]}]"#,
                "cameras",
            ),
            (
                r#"[{"key": "a", "render": {}, "modalities": []}]"#,
                "cameras",
            ),
            (
                r#"[{"key": "a", "render": {}, "modalities": ["rgb", "rgb"]}]"#,
                "cameras",
            ),
            (
                r#"[{"key": "a", "render": {}, "modalities": ["points"], "points": 0}]"#,
                "points",
            ),
            (
                r#"[{"key": "a", "render": {}, "points_frame": "moon"}]"#,
                "cameras",
            ),
        ] {
            match Cameras::from_json(json) {
                Err(Error::InvalidConfig { field: f, .. }) => assert_eq!(f, field, "{json}"),
                other => panic!("{json}: {other:?}"),
            }
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
