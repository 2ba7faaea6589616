//! Shadows: each caster's outline as the light sees it, dropped along the light onto each
//! receiving plane (the floor, the platform's top) and marked where it lands on a surface the
//! camera sees.
//!
//! The shadow of a convex shape on a plane is the projection of its outline: the loop of
//! edges between its faces turned towards the light and those turned away. Filling that one
//! polygon marks the pixels that filling every light-facing triangle would, with a fraction of
//! the work (at 84 pixels a capsule's 32 light-facing triangles cover about five pixels
//! each). Shapes whose outline is not one loop, that cross the plane, or that reach behind the
//! camera's near plane are marked triangle by triangle.

use std::collections::HashMap;
use std::ops::Range;

use nalgebra::Vector3;

use crate::camera::{on_screen, Camera, Projection, NEAR};
use crate::mesh::{map3, IndexedMesh};
use crate::raster::{Frame, Span};

/// How far beyond a bounded receiver's edges its shadows are still drawn (m): a shadow is
/// marked on whatever is drawn within the rasteriser's depth tolerance of the plane, which
/// reaches a few millimetres past the edge onto the box's side.
const RECEIVER_MARGIN: f64 = 0.03;

/// A horizontal surface that shadows fall on: the floor (unbounded) or the top of a box.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Receiver {
    /// Its height (m).
    height: f64,
    /// Where it ends, if it does (widened by [`RECEIVER_MARGIN`]).
    bounds: Option<Rect>,
}

/// An axis-aligned rectangle in the xy plane (m).
#[derive(Debug, Clone, Copy)]
struct Rect {
    min: [f64; 2],
    max: [f64; 2],
}

impl Rect {
    /// Whether the bounding box of `points` (on the plane) meets the rectangle.
    fn overlaps<'a>(&self, points: impl IntoIterator<Item = &'a Vector3<f64>>) -> bool {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (0..2).all(|k| hi[k] >= self.min[k] && lo[k] <= self.max[k])
    }
}

impl Receiver {
    /// A plane at `height` without edges (the floor).
    pub(crate) fn unbounded(height: f64) -> Self {
        Self {
            height,
            bounds: None,
        }
    }

    /// The top of an upright box at `pose` (its rotation about z allowed for in the bounds).
    pub(crate) fn box_top(pose: &nalgebra::Isometry3<f64>, half_extents: &Vector3<f64>) -> Self {
        let (mut min, mut max) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let corner = pose
                * nalgebra::Point3::new(sx * half_extents.x, sy * half_extents.y, half_extents.z);
            for k in 0..2 {
                min[k] = min[k].min(corner[k] - RECEIVER_MARGIN);
                max[k] = max[k].max(corner[k] + RECEIVER_MARGIN);
            }
        }
        Self {
            height: pose.translation.z + half_extents.z,
            bounds: Some(Rect { min, max }),
        }
    }
}

/// The edges of a closed mesh, each with the triangles on its two sides, to find outlines.
/// Vertices closer than a nanometre are welded first (a tessellated seam or pole repeats a
/// point up to rounding).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Edges {
    /// `[from, to, left, right]`: welded vertex ids, the triangle in whose winding the edge
    /// runs from `from` to `to`, and the triangle on its other side.
    edges: Vec<[u32; 4]>,
    /// A mesh vertex for each welded id.
    representative: Vec<u32>,
    /// Whether every edge has exactly one triangle on each side, wound consistently.
    closed: bool,
    /// The mesh's number of triangles.
    triangles: usize,
}

impl Edges {
    /// The edges of `mesh`.
    pub(crate) fn of(mesh: &IndexedMesh) -> Self {
        let mut weld: HashMap<[i64; 3], u32> = HashMap::new();
        let mut representative = Vec::new();
        let ids: Vec<u32> = mesh
            .vertices
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let key = [v.x, v.y, v.z].map(|c| (c * 1e9).round() as i64);
                *weld.entry(key).or_insert_with(|| {
                    representative.push(i as u32);
                    (representative.len() - 1) as u32
                })
            })
            .collect();
        let mut by_pair: HashMap<(u32, u32), usize> = HashMap::new();
        let mut edges: Vec<[u32; 4]> = Vec::new();
        let mut closed = !mesh.triangles.is_empty();
        for (t, corners) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = map3(*corners, |k| ids[k as usize]);
            if a == b || b == c || c == a {
                // Collapsed by the weld: no area, nothing on either side.
                continue;
            }
            for (from, to) in [(a, b), (b, c), (c, a)] {
                let key = (from.min(to), from.max(to));
                match by_pair.get(&key) {
                    None => {
                        by_pair.insert(key, edges.len());
                        edges.push([from, to, t as u32, u32::MAX]);
                    }
                    Some(&e) => {
                        let edge = &mut edges[e];
                        if edge[3] == u32::MAX && edge[0] == to && edge[1] == from {
                            edge[3] = t as u32;
                        } else {
                            closed = false;
                        }
                    }
                }
            }
        }
        closed &= edges.iter().all(|e| e[3] != u32::MAX);
        Self {
            edges,
            representative,
            closed,
            triangles: mesh.triangles.len(),
        }
    }

    /// Appends to `out` the outline between the triangles `lit` marks and the others, as
    /// mesh vertex indices in order around it; false (and `out` as it was) when the mesh is
    /// not closed or the outline is not one loop. `next` is a scratch buffer.
    fn outline(&self, lit: &[bool], next: &mut Vec<u32>, out: &mut Vec<u32>) -> bool {
        if !self.closed {
            return false;
        }
        next.clear();
        next.resize(self.representative.len(), u32::MAX);
        let (mut count, mut start) = (0usize, u32::MAX);
        for &[from, to, left, right] in &self.edges {
            let (l, r) = (lit[left as usize], lit[right as usize]);
            if l == r {
                continue;
            }
            // Along the lit side's winding.
            let (a, b) = if l { (from, to) } else { (to, from) };
            if next[a as usize] != u32::MAX {
                return false;
            }
            next[a as usize] = b;
            count += 1;
            start = a;
        }
        if count < 3 {
            return false;
        }
        let first = out.len();
        let mut v = start;
        for i in 0..count {
            out.push(self.representative[v as usize]);
            v = next[v as usize];
            if v == u32::MAX || (v == start && i + 1 < count) {
                out.truncate(first);
                return false;
            }
        }
        if v != start {
            out.truncate(first);
            return false;
        }
        true
    }
}

/// One shadow caster of a frame: ranges into [`Shadows`]' buffers.
#[derive(Debug, Clone)]
struct Caster {
    /// Its triangles in `Shadows::casters.triangles` (and `Shadows::lit`).
    triangles: Range<usize>,
    /// Its outline in `Shadows::outlines` (indices into `Shadows::casters.vertices`); empty
    /// when it has none.
    outline: Range<usize>,
    /// The lowest and highest of its vertices (m).
    min_z: f64,
    max_z: f64,
}

/// The shadow casters of the frame being drawn, and the buffers their shadows are drawn with.
#[derive(Debug, Clone, Default)]
pub(crate) struct Shadows {
    /// Every caster's vertices in the world and its triangles, and whether each faces the
    /// light.
    casters: IndexedMesh,
    lit: Vec<bool>,
    parts: Vec<Caster>,
    outlines: Vec<u32>,
    /// Scratch: the outline walk, an outline on the plane and on the screen, and a polygon's
    /// spans.
    next: Vec<u32>,
    /// Where the caster being added starts in `casters`.
    offset: u32,
    first_triangle: usize,
    on_plane: Vec<Vector3<f64>>,
    polygon: Vec<[f32; 2]>,
    spans: Vec<Span>,
}

impl Shadows {
    /// Forgets the last frame's casters.
    pub(crate) fn clear(&mut self) {
        self.casters.vertices.clear();
        self.casters.triangles.clear();
        self.lit.clear();
        self.parts.clear();
        self.outlines.clear();
    }

    /// Starts a caster with its vertices in the world; its triangles follow in the order of
    /// its mesh ([`Shadows::triangle`]), then [`Shadows::end`].
    pub(crate) fn begin(&mut self, world: &[Vector3<f64>]) {
        self.offset = self.casters.vertices.len() as u32;
        self.casters.vertices.extend_from_slice(world);
        self.first_triangle = self.casters.triangles.len();
    }

    /// The caster's next triangle (its corners in its mesh) and whether it faces the light.
    pub(crate) fn triangle(&mut self, corners: [u32; 3], lit: bool) {
        let offset = self.offset;
        self.casters.triangles.push(map3(corners, |k| k + offset));
        self.lit.push(lit);
    }

    /// Ends the caster begun last, whose mesh has `edges`.
    pub(crate) fn end(&mut self, edges: &Edges) {
        let first = self.outlines.len();
        let lit = &self.lit[self.first_triangle..];
        if lit.len() == edges.triangles && edges.outline(lit, &mut self.next, &mut self.outlines) {
            let offset = self.offset;
            for k in &mut self.outlines[first..] {
                *k += offset;
            }
        }
        let world = &self.casters.vertices[self.offset as usize..];
        let (min_z, max_z) = world
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |m, p| {
                (m.0.min(p.z), m.1.max(p.z))
            });
        self.parts.push(Caster {
            triangles: self.first_triangle..self.casters.triangles.len(),
            outline: first..self.outlines.len(),
            min_z,
            max_z,
        });
    }

    /// Marks in `frame` where each caster's shadow along `light` lands on each receiver,
    /// then darkens those pixels to `factor` of their colour (out of 256).
    pub(crate) fn draw(
        &mut self,
        frame: &mut Frame,
        camera: &Camera,
        projection: &Projection,
        light: &Vector3<f64>,
        receivers: &[Receiver],
        factor: u16,
    ) {
        for receiver in receivers {
            let h = receiver.height;
            let depth = depth_plane(camera, projection, h);
            let pass = Pass {
                camera,
                projection,
                light,
                receiver,
            };
            for part in 0..self.parts.len() {
                let caster = &self.parts[part];
                if caster.max_z <= h {
                    // Wholly under the plane: nothing of it is above to cast.
                    continue;
                }
                let drawn = match depth {
                    Some(depth) if caster.min_z >= h && !caster.outline.is_empty() => {
                        self.draw_outline(frame, &pass, part, depth)
                    }
                    _ => false,
                };
                if !drawn {
                    self.draw_triangles(frame, &pass, part);
                }
            }
        }
        frame.apply_shadows(factor);
    }

    /// Drops the caster's outline onto the receiver and marks it as one polygon; false when
    /// it reaches behind the near plane (the caller marks it triangle by triangle).
    fn draw_outline(
        &mut self,
        frame: &mut Frame,
        pass: &Pass,
        part: usize,
        depth: [f32; 3],
    ) -> bool {
        let Pass {
            camera,
            projection,
            light,
            receiver,
        } = *pass;
        let h = receiver.height;
        let outline = self.parts[part].outline.clone();
        self.on_plane.clear();
        for &k in &self.outlines[outline] {
            self.on_plane
                .push(drop_onto(&self.casters.vertices[k as usize], light, h));
        }
        if let Some(bounds) = receiver.bounds {
            if !bounds.overlaps(&self.on_plane) {
                return true;
            }
        }
        self.polygon.clear();
        for p in &self.on_plane {
            let v = camera.to_view(p);
            if v.z < NEAR {
                return false;
            }
            let s = projection.screen(&v);
            self.polygon.push([s.x, s.y]);
        }
        frame.mark_shadow_polygon(&self.polygon, depth, &mut self.spans);
        true
    }

    /// Drops each of the caster's light-facing triangles onto the receiver and marks it.
    fn draw_triangles(&mut self, frame: &mut Frame, pass: &Pass, part: usize) {
        let Pass {
            camera,
            projection,
            light,
            receiver,
        } = *pass;
        let h = receiver.height;
        for i in self.parts[part].triangles.clone() {
            if !self.lit[i] {
                continue;
            }
            let corners = self.casters.corners(i, &self.casters.vertices);
            if corners.iter().all(|p| p.z <= h) {
                continue;
            }
            let on = map3(corners, |p| drop_onto(&p, light, h));
            if let Some(bounds) = receiver.bounds {
                if !bounds.overlaps(&on) {
                    continue;
                }
            }
            let view = map3(on, |p| camera.to_view(&p));
            let screen = map3(view, |v| projection.screen(&v));
            for t in on_screen(projection, &view, &screen).iter().flatten() {
                frame.mark_shadow(t);
            }
        }
    }
}

/// What one receiver's shadows are drawn with: the camera that sees them, the light that
/// casts them and the receiver they fall on.
#[derive(Clone, Copy)]
struct Pass<'a> {
    camera: &'a Camera,
    projection: &'a Projection,
    light: &'a Vector3<f64>,
    receiver: &'a Receiver,
}

/// `p` moved along `light` down onto the plane at height `h` (points below it stay put).
fn drop_onto(p: &Vector3<f64>, light: &Vector3<f64>, h: f64) -> Vector3<f64> {
    let lift = (p.z - h).max(0.0);
    let mut q = p - light * (lift / light.z);
    q.z = h;
    q
}

/// The inverse depth of the horizontal plane at height `h` as an affine function of the
/// pixel coordinates, `[a, b, c]` for `a x + b y + c`; `None` when the eye is in the plane.
fn depth_plane(camera: &Camera, projection: &Projection, h: f64) -> Option<[f32; 3]> {
    // A point eye + v.x right + v.y up + v.z forward is on the plane when n . v = d, with n
    // the world's z in view coordinates; 1 / v.z is then (n.x x' + n.y y' + n.z) / d, where
    // x' = v.x / v.z = (x - cx) / f and y' = v.y / v.z = -(y - cy) / f.
    let (n, d) = (
        Vector3::new(camera.right.z, camera.up.z, camera.forward.z),
        h - camera.eye.z,
    );
    if d == 0.0 || !d.is_finite() {
        return None;
    }
    let f = projection.focal_px;
    let (a, b) = (n.x / (f * d), -n.y / (f * d));
    let c = n.z / d - a * projection.cx - b * projection.cy;
    Some([a as f32, b as f32, c as f32])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{tessellate_with, Detail};
    use panda_rapier_core::VisualShape;

    fn mesh(shape: &VisualShape) -> IndexedMesh {
        let mut triangles = Vec::new();
        tessellate_with(shape, Detail::COARSE, &mut triangles);
        IndexedMesh::from_triangles(&triangles)
    }

    #[test]
    fn tessellated_shapes_are_closed_and_their_outline_is_one_loop() {
        let light = Vector3::new(0.4, 0.3, 1.0).normalize();
        for shape in [
            VisualShape::Box {
                half_extents: Vector3::new(0.1, 0.2, 0.3),
            },
            VisualShape::Capsule {
                half_height: 0.05,
                radius: 0.06,
            },
            VisualShape::Cylinder {
                half_height: 0.07,
                radius: 0.09,
            },
            VisualShape::Sphere { radius: 0.1 },
        ] {
            let mesh = mesh(&shape);
            let edges = Edges::of(&mesh);
            assert!(edges.closed, "{shape:?}");
            let lit: Vec<bool> = (0..mesh.triangles.len())
                .map(|i| {
                    let w = mesh.corners(i, &mesh.vertices);
                    (w[1] - w[0]).cross(&(w[2] - w[0])).dot(&light) > 0.0
                })
                .collect();
            let (mut next, mut out) = (Vec::new(), Vec::new());
            assert!(edges.outline(&lit, &mut next, &mut out), "{shape:?}");
            // Seen along the light, the outline is a convex polygon around every vertex.
            let (u, v) = (
                light.cross(&Vector3::z()).normalize(),
                light.cross(&light.cross(&Vector3::z())).normalize(),
            );
            let flat = |p: &Vector3<f64>| [p.dot(&u), p.dot(&v)];
            let poly: Vec<[f64; 2]> = out
                .iter()
                .map(|&k| flat(&mesh.vertices[k as usize]))
                .collect();
            let n = poly.len();
            let cross = |i: usize, p: [f64; 2]| {
                let (a, b) = (poly[i], poly[(i + 1) % n]);
                (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
            };
            let sign = (0..n)
                .map(|i| cross(i, poly[(i + 2) % n]))
                .sum::<f64>()
                .signum();
            for p in &mesh.vertices {
                for i in 0..n {
                    assert!(
                        sign * cross(i, flat(p)) >= -1e-12,
                        "{shape:?}: vertex outside the outline"
                    );
                }
            }
        }
    }

    #[test]
    fn a_box_top_receives_only_what_lands_on_it() {
        // A 0.3 m platform turned 90 degrees about z, its top at 0.1 m.
        let pose = nalgebra::Isometry3::new(
            Vector3::new(0.5, 0.1, 0.05),
            Vector3::z() * std::f64::consts::FRAC_PI_2,
        );
        let top = Receiver::box_top(&pose, &Vector3::new(0.15, 0.1, 0.05));
        assert!((top.height - 0.1).abs() < 1e-12);
        let bounds = top.bounds.expect("a box top is bounded");
        // Turned, its 0.3 m side runs along y; the margin widens both.
        let near = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(
            near(bounds.min[0], 0.4 - RECEIVER_MARGIN)
                && near(bounds.max[0], 0.6 + RECEIVER_MARGIN)
        );
        assert!(
            near(bounds.min[1], -0.05 - RECEIVER_MARGIN)
                && near(bounds.max[1], 0.25 + RECEIVER_MARGIN)
        );
        let at = |x: f64, y: f64| Vector3::new(x, y, 0.1);
        assert!(bounds.overlaps(&[at(0.5, 0.1), at(0.9, 0.9), at(0.9, 0.8)]));
        // A triangle whose corners all miss the top but which crosses it.
        assert!(bounds.overlaps(&[at(0.3, 0.1), at(0.7, 0.1), at(0.7, 0.12)]));
        assert!(!bounds.overlaps(&[at(0.7, 0.1), at(0.9, 0.1), at(0.8, 0.2)]));
        assert!(Receiver::unbounded(0.0).bounds.is_none());
    }

    #[test]
    fn an_open_mesh_has_no_outline() {
        let mut mesh = mesh(&VisualShape::Box {
            half_extents: Vector3::new(0.1, 0.1, 0.1),
        });
        mesh.triangles.pop();
        let edges = Edges::of(&mesh);
        assert!(!edges.closed);
        let lit = vec![true; mesh.triangles.len()];
        let mut out = vec![7];
        assert!(!edges.outline(&lit, &mut Vec::new(), &mut out));
        assert_eq!(out, [7]);
    }
}
