//! The scene: materials, lighting, the floor, shadows, and the [`Renderer`] tying them up.

use nalgebra::Vector3;
use panda_rapier_core::task::GoalMarker;
use panda_rapier_core::{
    Error, PandaEnv, Result, Simulation, VisualPrimitive, VisualShape, VisualTag,
};
use serde::{Deserialize, Serialize};

use crate::camera::{Camera, CameraConfig, NEAR};
use crate::look::{episode_key, Look, VisualRandomization};
use crate::mesh::{tessellate_with, Detail, Triangle};
use crate::raster::{Frame, ScreenVertex};

/// Largest width or height accepted (pixels).
pub const MAX_SIZE: u32 = 4096;

/// What to draw and how big: picture size and camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderConfig {
    /// Width in pixels (1 to [`MAX_SIZE`]; default 720).
    pub width: u32,
    /// Height in pixels (1 to [`MAX_SIZE`]; default 480).
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
            width: 720,
            height: 480,
            camera: CameraConfig::default(),
            show_goal: true,
            randomization: None,
        }
    }
}

impl RenderConfig {
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

/// Direction towards the light (normalised in use): high, from the front left.
pub(crate) const LIGHT: [f64; 3] = [0.4, 0.3, 1.0];
pub(crate) const AMBIENT: f64 = 0.42;
pub(crate) const DIFFUSE: f64 = 0.5;
/// Light from the eye, so faces turned away from the sun keep their shape.
const HEADLIGHT: f64 = 0.12;
/// Colour left in shadow, out of 256.
const SHADOW: u16 = 165;

const SKY_TOP: [f64; 3] = [150.0, 180.0, 215.0];
const SKY_HORIZON: [f64; 3] = [222.0, 230.0, 238.0];
pub(crate) const FLOOR: [[u8; 3]; 2] = [[196, 196, 190], [172, 174, 170]];
pub(crate) const PLATFORM: [u8; 3] = [176, 132, 86];
/// Object colours, by the object's index in the task's scene (a second cube is blue).
pub(crate) const OBJECTS: [[u8; 3]; 3] = [[214, 52, 40], [40, 92, 214], [226, 178, 32]];
const GOAL: [u8; 3] = [40, 190, 80];
const LINK: [u8; 3] = [236, 236, 236];
const HAND: [u8; 3] = [70, 70, 76];
const GOAL_RADIUS: f64 = 0.015;

/// Floor tiles: a checkerboard of this many tiles of this size around the robot.
const FLOOR_TILE: f64 = 0.25;
const FLOOR_TILES: i32 = 20;

/// Draws [`PandaEnv`]s (or bare [`Simulation`]s) into a reusable [`Frame`].
#[derive(Debug, Clone)]
pub struct Renderer {
    config: RenderConfig,
    camera: Camera,
    frame: Frame,
    background: Vec<[u8; 3]>,
    primitives: Vec<VisualPrimitive>,
    /// How finely round shapes are split, from the picture's height.
    detail: Detail,
    /// The camera's focal length in pixels.
    focal_px: f64,
    /// Each primitive's shape and its triangles (in the shape's frame), by primitive index:
    /// shapes do not change between frames, so they are tessellated once.
    meshes: Vec<(VisualShape, Vec<Triangle>)>,
    casters: Vec<Triangle>,
    /// The goal markers of the frame being drawn (kept to reuse the buffer).
    markers: Vec<GoalMarker>,
    /// The camera before randomisation.
    base_camera: Camera,
    /// The light and colours of the frame being drawn.
    look: Look,
    /// The episode key the camera and look were drawn for (randomisation only).
    look_key: Option<u64>,
}

impl Renderer {
    /// A renderer for `config`; invalid sizes or cameras are [`Error::InvalidConfig`].
    pub fn new(config: RenderConfig) -> Result<Self> {
        config.validate()?;
        let camera = Camera::new(&config.camera)?;
        let background = (0..config.height)
            .map(|y| {
                let t = f64::from(y) / f64::from(config.height.max(2) - 1);
                std::array::from_fn(|c| (SKY_TOP[c] + (SKY_HORIZON[c] - SKY_TOP[c]) * t) as u8)
            })
            .collect();
        Ok(Self {
            frame: Frame::new(config.width, config.height),
            camera,
            background,
            primitives: Vec::new(),
            detail: Detail::for_height(config.height),
            focal_px: camera.focal_px(config.height),
            meshes: Vec::new(),
            casters: Vec::new(),
            markers: Vec::new(),
            base_camera: camera,
            look: Look::default(),
            look_key: None,
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &RenderConfig {
        &self.config
    }

    /// The resolved camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Draws the environment's current state with its goal, as its task shows it (with the
    /// configuration's randomisation, if any, drawn for this episode and step).
    pub fn render(&mut self, env: &PandaEnv) -> &Frame {
        let noise = match self.config.randomization.clone() {
            Some(randomization) => {
                let key = episode_key(env.goal());
                if self.look_key != Some(key) {
                    let (camera, look) =
                        Look::draw(key, &randomization, &self.base_camera, self.base_distance());
                    self.camera = camera;
                    self.focal_px = camera.focal_px(self.config.height);
                    self.look = look;
                    self.look_key = Some(key);
                }
                Some((key, randomization))
            }
            None => None,
        };
        let mut markers = std::mem::take(&mut self.markers);
        markers.clear();
        env.task().goal_markers(env.goal(), &mut markers);
        self.render_with_markers(env.simulation(), &markers);
        self.markers = markers;
        if let Some((key, randomization)) = noise {
            if randomization.noise > 0 {
                crate::look::add_noise(
                    self.frame.rgb_mut(),
                    key,
                    &randomization,
                    env.elapsed_steps(),
                );
            }
        }
        &self.frame
    }

    /// Eye to target distance of the configured camera (m).
    fn base_distance(&self) -> f64 {
        let target = self
            .config
            .camera
            .target
            .map_or(Vector3::from(crate::camera::DEFAULT_TARGET), Vector3::from);
        (target - self.base_camera.eye).norm()
    }

    /// Draws a simulation, with a goal marker at every position (consecutive triples) in
    /// `goal`; non-finite positions are left out.
    pub fn render_simulation(&mut self, sim: &Simulation, goal: &[f64]) -> &Frame {
        let mut markers = std::mem::take(&mut self.markers);
        markers.clear();
        GoalMarker::points(goal, &mut markers);
        self.render_with_markers(sim, &markers);
        self.markers = markers;
        &self.frame
    }

    /// Draws a simulation with the goal `markers`.
    pub fn render_with_markers(&mut self, sim: &Simulation, markers: &[GoalMarker]) -> &Frame {
        self.frame.clear(&self.background);
        self.primitives.clear();
        sim.visual_primitives(&mut self.primitives);
        let light = self.look.light;
        let links = sim.model().links();
        let mut primitives = std::mem::take(&mut self.primitives);
        let mut shadow_planes = Vec::new();
        self.casters.clear();
        for (index, p) in primitives.iter().enumerate() {
            let color = match p.tag {
                VisualTag::Floor => {
                    shadow_planes.push(p.pose.translation.z);
                    self.draw_floor(p, &light);
                    continue;
                }
                VisualTag::Platform => {
                    if let VisualShape::Box { half_extents } = &p.shape {
                        shadow_planes.push(p.pose.translation.z + half_extents.z);
                    }
                    self.look.platform
                }
                VisualTag::Object { index } => self.look.objects[index % OBJECTS.len()],
                VisualTag::RobotLink { finger: true, .. } => HAND,
                VisualTag::RobotLink { link, .. } => {
                    let name = links.get(link).map_or("", |l| l.name.as_str());
                    if name.contains("hand") {
                        HAND
                    } else {
                        LINK
                    }
                }
            };
            let casts = !matches!(p.tag, VisualTag::Platform);
            self.draw_primitive(index, p, color, &light, casts);
        }
        let markers = if self.config.show_goal { markers } else { &[] };
        for (k, marker) in markers.iter().enumerate() {
            let (shape, pose) = match *marker {
                GoalMarker::Point(at) => (
                    VisualShape::Sphere {
                        radius: GOAL_RADIUS,
                    },
                    nalgebra::Isometry3::translation(at.x, at.y, at.z),
                ),
                GoalMarker::Pose { pose, half_extent } => (
                    VisualShape::Box {
                        half_extents: Vector3::repeat(half_extent),
                    },
                    pose,
                ),
            };
            let marker = VisualPrimitive {
                shape,
                pose,
                // Not drawn by tag: the colour is given below and the marker casts no shadow.
                tag: VisualTag::Floor,
            };
            self.draw_primitive(primitives.len() + k, &marker, GOAL, &light, false);
        }
        self.draw_shadows(&light, &shadow_planes);
        primitives.clear();
        self.primitives = primitives;
        &self.frame
    }

    /// The last frame drawn.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    /// Draws primitive `index` (its triangles cached under that index; the goal markers
    /// follow the scene's primitives).
    fn draw_primitive(
        &mut self,
        index: usize,
        p: &VisualPrimitive,
        color: [u8; 3],
        light: &Vector3<f64>,
        casts: bool,
    ) {
        if self.meshes.len() <= index {
            self.meshes
                .resize_with(index + 1, || (VisualShape::Plane, Vec::new()));
        }
        let (shape, triangles) = &mut self.meshes[index];
        if *shape != p.shape || triangles.is_empty() {
            triangles.clear();
            tessellate_with(&p.shape, self.detail, triangles);
            shape.clone_from(&p.shape);
        }
        let triangles = std::mem::take(triangles);
        for t in &triangles {
            let world = t
                .map(|v| p.pose * nalgebra::Point3::from(v))
                .map(|p| p.coords);
            let normal = (world[1] - world[0]).cross(&(world[2] - world[0]));
            if casts && normal.dot(light) > 0.0 {
                self.casters.push(world);
            }
            self.draw_triangle(&world, &normal, color, light);
        }
        self.meshes[index].1 = triangles;
    }

    fn draw_floor(&mut self, p: &VisualPrimitive, light: &Vector3<f64>) {
        let z = p.pose.translation.z;
        let (cx, cy) = (p.pose.translation.x.round(), p.pose.translation.y.round());
        let half = FLOOR_TILES / 2;
        for i in -half..half {
            for j in -half..half {
                let (x0, y0) = (
                    cx + f64::from(i) * FLOOR_TILE,
                    cy + f64::from(j) * FLOOR_TILE,
                );
                let (x1, y1) = (x0 + FLOOR_TILE, y0 + FLOOR_TILE);
                let color = self.look.floor[((i + j).rem_euclid(2)) as usize];
                let a = Vector3::new(x0, y0, z);
                let b = Vector3::new(x1, y0, z);
                let c = Vector3::new(x1, y1, z);
                let d = Vector3::new(x0, y1, z);
                for t in [[a, b, c], [a, c, d]] {
                    self.draw_triangle(&t, &Vector3::z(), color, light);
                }
            }
        }
    }

    /// Shades and draws one world-space triangle, unless it faces away from the eye.
    fn draw_triangle(
        &mut self,
        world: &Triangle,
        normal: &Vector3<f64>,
        color: [u8; 3],
        light: &Vector3<f64>,
    ) {
        let to_eye = self.camera.eye - world[0];
        if normal.dot(&to_eye) <= 0.0 {
            return;
        }
        let n = normal.normalize();
        let shade = self.look.ambient
            + self.look.diffuse * n.dot(light).max(0.0)
            + HEADLIGHT * n.dot(&to_eye.normalize()).max(0.0);
        let shaded = color.map(|c| (f64::from(c) * shade).round().clamp(0.0, 255.0) as u8);
        let view = world.map(|p| self.camera.to_view(&p));
        for t in clip_near(&view).iter().flatten() {
            let screen = self.to_screen(t);
            self.frame.fill_triangle(&screen, shaded);
        }
    }

    /// Projects every light-facing caster triangle along the light onto each receiving plane
    /// (the floor, the platform's top) and marks where it lands on a visible surface.
    fn draw_shadows(&mut self, light: &Vector3<f64>, planes: &[f64]) {
        let casters = std::mem::take(&mut self.casters);
        for &h in planes {
            for t in &casters {
                if t.iter().all(|p| p.z <= h) {
                    continue;
                }
                let projected = t.map(|p| {
                    let lift = (p.z - h).max(0.0);
                    let mut q = p - light * (lift / light.z);
                    q.z = h;
                    self.camera.to_view(&q)
                });
                for v in clip_near(&projected).iter().flatten() {
                    let screen = self.to_screen(v);
                    self.frame.mark_shadow(&screen);
                }
            }
        }
        self.casters = casters;
        self.frame.apply_shadows(SHADOW);
    }

    fn to_screen(&self, t: &Triangle) -> [ScreenVertex; 3] {
        let f = self.focal_px;
        let (cx, cy) = (
            f64::from(self.config.width) / 2.0,
            f64::from(self.config.height) / 2.0,
        );
        t.map(|v| ScreenVertex {
            x: (cx + f * v.x / v.z) as f32,
            y: (cy - f * v.y / v.z) as f32,
            inv_depth: (1.0 / v.z) as f32,
        })
    }
}

/// Clips a view-space triangle to the part in front of the near plane: none, one or two
/// triangles.
fn clip_near(t: &Triangle) -> [Option<Triangle>; 2] {
    let inside = t.map(|v| v.z >= NEAR);
    match inside.iter().filter(|&&i| i).count() {
        3 => [Some(*t), None],
        0 => [None, None],
        _ => {
            let mut poly: Vec<Vector3<f64>> = Vec::with_capacity(4);
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                if inside[i] {
                    poly.push(a);
                }
                if inside[i] != inside[(i + 1) % 3] {
                    let s = (NEAR - a.z) / (b.z - a.z);
                    let mut p = a + (b - a) * s;
                    p.z = NEAR;
                    poly.push(p);
                }
            }
            match poly.len() {
                3 => [Some([poly[0], poly[1], poly[2]]), None],
                4 => [
                    Some([poly[0], poly[1], poly[2]]),
                    Some([poly[0], poly[2], poly[3]]),
                ],
                _ => [None, None],
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_clipping_keeps_the_front_part() {
        let t = [
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(1.0, 0.0, 1.0),
            Vector3::new(-1.0, 0.0, 1.0),
        ];
        let [a, b] = clip_near(&t);
        let (a, b) = (a.unwrap(), b.unwrap());
        for v in a.iter().chain(&b) {
            assert!(v.z >= NEAR - 1e-12);
        }
        let behind = t.map(|v| Vector3::new(v.x, v.y, -2.0));
        assert_eq!(clip_near(&behind), [None, None]);
    }

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
