//! The scene: materials, lighting, the floor, shadows, and the [`Renderer`] tying them up.

use nalgebra::Vector3;
use panda_rapier_core::task::GoalMarker;
use panda_rapier_core::{PandaEnv, Result, Simulation, VisualPrimitive, VisualShape, VisualTag};

use crate::camera::{on_screen, Camera, Projection};
pub use crate::config::{RenderConfig, MAX_SIZE};
use crate::look::{episode_key, Look};
use crate::mesh::{map3, tessellate_with, Detail, IndexedMesh, Triangle};
use crate::palette::{
    CARCASS, DRAWER, GOAL, HAND, HEADLIGHT, LINK, OBJECTS, SHADOW, SKY_HORIZON, SKY_TOP,
};
use crate::raster::{Frame, ScreenVertex};
use crate::segmentation;
use crate::shadow::{Edges, Receiver, Shadows};

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
    /// Each primitive's shape, its triangles (in the shape's frame) and their edges, by
    /// primitive index: shapes do not change between frames, so they are tessellated once.
    meshes: Vec<(VisualShape, IndexedMesh, Edges)>,
    /// This frame's shadow casters.
    shadows: Shadows,
    /// A primitive's (or the casters') vertices in the world, seen by the camera and on the
    /// screen: each computed once per vertex (buffers kept between frames).
    world: Vec<Vector3<f64>>,
    view: Vec<Vector3<f64>>,
    screen: Vec<ScreenVertex>,
    /// The goal markers of the frame being drawn (kept to reuse the buffer).
    markers: Vec<GoalMarker>,
    /// The camera before randomisation.
    base_camera: Camera,
    /// The light and colours of the frame being drawn.
    look: Look,
    /// The episode key the camera and look were drawn for (randomisation only).
    look_key: Option<u64>,
    /// The sky and the floor as drawn for the floor pose, camera and look they were drawn
    /// with: the floor never moves, so most frames start from a copy (800 triangles saved).
    floor_cache: Option<(nalgebra::Isometry3<f64>, Camera, Look, Frame)>,
}

impl Renderer {
    /// A renderer for `config`; invalid sizes or cameras are
    /// [`panda_rapier_core::Error::InvalidConfig`].
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
            shadows: Shadows::default(),
            world: Vec::new(),
            view: Vec::new(),
            screen: Vec::new(),
            markers: Vec::new(),
            base_camera: camera,
            look: Look::default(),
            look_key: None,
            floor_cache: None,
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
        self.primitives.clear();
        sim.visual_primitives(&mut self.primitives);
        let light = self.look.light;
        let links = sim.model().links();
        let mut primitives = std::mem::take(&mut self.primitives);
        let mut shadow_planes = Vec::new();
        self.shadows.clear();
        // The floor comes first: the frame starts as the sky with the floor on it.
        let first = match primitives.first() {
            Some(floor) if floor.tag == VisualTag::Floor => {
                shadow_planes.push(Receiver::unbounded(floor.pose.translation.z));
                self.frame.set_segment(segmentation::FLOOR);
                self.clear_with_floor(floor, &light);
                1
            }
            _ => {
                self.frame.clear(&self.background);
                0
            }
        };
        for (index, p) in primitives.iter().enumerate().skip(first) {
            self.frame.set_segment(segmentation::id_of(&p.tag));
            let color = match p.tag {
                VisualTag::Floor => {
                    shadow_planes.push(Receiver::unbounded(p.pose.translation.z));
                    self.draw_floor(p, &light);
                    continue;
                }
                VisualTag::Platform => {
                    if let VisualShape::Box { half_extents } = &p.shape {
                        shadow_planes.push(Receiver::box_top(&p.pose, half_extents));
                    }
                    self.look.platform
                }
                VisualTag::Object { index } => {
                    let k = index % OBJECTS.len();
                    match p.color {
                        // The file's own colour, randomised as its slot's palette colour is.
                        Some(own) => tinted(own, OBJECTS[k], self.look.objects[k]),
                        None => self.look.objects[k],
                    }
                }
                VisualTag::Articulation { link: 0, .. } => CARCASS,
                VisualTag::Articulation { .. } => DRAWER,
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
        self.frame.set_segment(segmentation::GOAL);
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
                color: None,
            };
            self.draw_primitive(primitives.len() + k, &marker, GOAL, &light, false);
        }
        let projection = self.projection();
        self.shadows.draw(
            &mut self.frame,
            &self.camera,
            &projection,
            &light,
            &shadow_planes,
            SHADOW,
        );
        primitives.clear();
        self.primitives = primitives;
        &self.frame
    }

    /// The last frame drawn.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    /// Whether frames keep a segmentation id per pixel ([`Frame::segments`], ids from
    /// [`crate::segmentation`]); off by default. Colours and depths are the same bits either
    /// way.
    pub fn set_segmentation(&mut self, on: bool) {
        let has = !self.frame.segments().is_empty();
        if on != has {
            self.frame = Frame::new(self.config.width, self.config.height).with_segmentation(on);
            self.floor_cache = None;
        }
    }

    /// Draws primitive `index` (its mesh cached under that index; the goal markers follow
    /// the scene's primitives). Each vertex is moved, seen and projected once; each triangle
    /// is then drawn from its corners, the same bits as transforming it on its own.
    fn draw_primitive(
        &mut self,
        index: usize,
        p: &VisualPrimitive,
        color: [u8; 3],
        light: &Vector3<f64>,
        casts: bool,
    ) {
        if self.meshes.len() <= index {
            self.meshes.resize_with(index + 1, || {
                (VisualShape::Plane, IndexedMesh::default(), Edges::default())
            });
        }
        let (shape, mesh, edges) = &mut self.meshes[index];
        if *shape != p.shape || mesh.triangles.is_empty() {
            let mut triangles = Vec::new();
            tessellate_with(&p.shape, self.detail, &mut triangles);
            *mesh = IndexedMesh::from_triangles(&triangles);
            *edges = Edges::of(mesh);
            shape.clone_from(&p.shape);
        }
        let mesh = std::mem::take(&mut self.meshes[index].1);
        let mut world = std::mem::take(&mut self.world);
        world.clear();
        // The pose's rotation as a matrix, once per primitive (the same up to the last bits
        // as turning each vertex by the quaternion, and cheaper).
        let (rotation, translation) = (
            p.pose.rotation.to_rotation_matrix().into_inner(),
            p.pose.translation.vector,
        );
        world.extend(mesh.vertices.iter().map(|v| rotation * v + translation));
        self.project(&world);
        let (view, screen) = (
            std::mem::take(&mut self.view),
            std::mem::take(&mut self.screen),
        );
        if casts {
            self.shadows.begin(&world);
        }
        // A file's mesh need not be closed or wound outwards: both sides of its triangles
        // are drawn, and all of them cast shadows.
        let two_sided = matches!(p.shape, VisualShape::Mesh { .. });
        for (i, corners) in mesh.triangles.iter().enumerate() {
            let w = mesh.corners(i, &world);
            let mut normal = (w[1] - w[0]).cross(&(w[2] - w[0]));
            if casts {
                self.shadows
                    .triangle(*corners, two_sided || normal.dot(light) > 0.0);
            }
            // Faces turned away from the eye are left before their corners are fetched.
            let to_eye = self.camera.eye - w[0];
            let facing = normal.dot(&to_eye);
            if facing <= 0.0 {
                if !two_sided || facing == 0.0 {
                    continue;
                }
                normal = -normal;
            }
            let (v, sv) = (mesh.corners(i, &view), mesh.corners(i, &screen));
            self.shade_and_fill(&normal, &to_eye, color, light, &v, &sv);
        }
        if casts {
            self.shadows.end(&self.meshes[index].2);
        }
        (self.world, self.view, self.screen) = (world, view, screen);
        self.meshes[index].1 = mesh;
    }

    /// Fills `self.view` and `self.screen` with `points` seen by the camera and projected.
    fn project(&mut self, points: &[Vector3<f64>]) {
        let (camera, projection) = (self.camera, self.projection());
        self.view.clear();
        self.view.extend(points.iter().map(|p| camera.to_view(p)));
        self.screen.clear();
        self.screen
            .extend(self.view.iter().map(|v| projection.screen(v)));
    }

    /// Clears the frame to the sky and draws the floor `p` on it: a copy of the frame the
    /// last call drew when the floor's pose, the camera and the look are the same (the same
    /// bits: the floor is the first thing drawn).
    fn clear_with_floor(&mut self, p: &VisualPrimitive, light: &Vector3<f64>) {
        if let Some((pose, camera, look, frame)) = &self.floor_cache {
            if *pose == p.pose && *camera == self.camera && *look == self.look {
                self.frame.copy_from(frame);
                return;
            }
        }
        self.frame.clear(&self.background);
        self.draw_floor(p, light);
        self.floor_cache = Some((p.pose, self.camera, self.look, self.frame.clone()));
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
        let view = map3(*world, |p| self.camera.to_view(&p));
        let screen = map3(view, |v| self.to_screen_vertex(&v));
        self.draw_seen(world, normal, color, light, &view, &screen);
    }

    /// Shades and draws one triangle given in the world, seen by the camera (`view`) and on
    /// the screen (`screen`, used where all of it lies beyond the near plane), unless it faces
    /// away from the eye.
    fn draw_seen(
        &mut self,
        world: &Triangle,
        normal: &Vector3<f64>,
        color: [u8; 3],
        light: &Vector3<f64>,
        view: &Triangle,
        screen: &[ScreenVertex; 3],
    ) {
        let to_eye = self.camera.eye - world[0];
        if normal.dot(&to_eye) <= 0.0 {
            return;
        }
        self.shade_and_fill(normal, &to_eye, color, light, view, screen);
    }

    /// Shades and draws a triangle facing the eye (`to_eye`: from its first corner to the eye).
    fn shade_and_fill(
        &mut self,
        normal: &Vector3<f64>,
        to_eye: &Vector3<f64>,
        color: [u8; 3],
        light: &Vector3<f64>,
        view: &Triangle,
        screen: &[ScreenVertex; 3],
    ) {
        // The cosines to the light and to the eye, without normalising either vector (the
        // same up to the last bits, which the colour's rounding to a byte does not see).
        let length = normal.norm();
        let shade = self.look.ambient
            + self.look.diffuse * (normal.dot(light) / length).max(0.0)
            + HEADLIGHT * (normal.dot(to_eye) / (length * to_eye.norm())).max(0.0);
        let shaded = map3(color, |c| round_to_u8(f64::from(c) * shade));
        for t in self.on_screen(view, screen).iter().flatten() {
            self.frame.fill_triangle(t, shaded);
        }
    }

    /// A view-space triangle on the screen (see [`on_screen`]).
    fn on_screen(
        &self,
        view: &Triangle,
        screen: &[ScreenVertex; 3],
    ) -> [Option<[ScreenVertex; 3]>; 2] {
        on_screen(&self.projection(), view, screen)
    }

    fn to_screen_vertex(&self, v: &Vector3<f64>) -> ScreenVertex {
        self.projection().screen(v)
    }

    fn projection(&self) -> Projection {
        Projection {
            focal_px: self.focal_px,
            cx: f64::from(self.config.width) / 2.0,
            cy: f64::from(self.config.height) / 2.0,
        }
    }
}

/// `own` scaled channel by channel as the palette colour `base` was to `drawn` (by the visual
/// randomisation): `own` itself when `drawn` is `base`.
fn tinted(own: [u8; 3], base: [u8; 3], drawn: [u8; 3]) -> [u8; 3] {
    std::array::from_fn(|c| {
        if drawn[c] == base[c] || base[c] == 0 {
            return own[c];
        }
        round_to_u8(f64::from(own[c]) * f64::from(drawn[c]) / f64::from(base[c]))
    })
}

/// `v.round().clamp(0.0, 255.0) as u8` without the call to `round` (targets without SSE4.1
/// have no instruction for it): the same value for every `v`, NaN included (0).
fn round_to_u8(v: f64) -> u8 {
    // NaN too.
    if v.is_nan() || v <= 0.0 {
        return 0;
    }
    if v >= 255.0 {
        return 255;
    }
    // 0 < v < 255: `t` is `v`'s integer part and `v - t` its exact fraction; halves round
    // away from zero, as `round` does.
    let t = v as u32;
    let up = v - f64::from(t) >= 0.5;
    (t + u32::from(up)) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_to_u8_is_round_then_clamp() {
        let mut cases = vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -1e300,
            -0.5,
            -0.0,
            0.0,
            0.49999999999999994,
            0.5,
            1.5,
            2.5,
            254.49999999999997,
            254.5,
            254.99999999999997,
            255.0,
            255.5,
            1e300,
        ];
        cases.extend((0..20_000).map(|i| f64::from(i) * 0.013_7 - 3.0));
        for v in cases {
            assert_eq!(round_to_u8(v), v.round().clamp(0.0, 255.0) as u8, "{v}");
        }
    }
}
