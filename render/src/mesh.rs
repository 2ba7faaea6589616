//! Triangles for each [`VisualShape`], in the shape's frame, wound counter-clockwise seen from
//! outside (so back faces can be culled).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::Vector3;
use panda_rapier_core::VisualShape;

/// A triangle (m).
pub type Triangle = [Vector3<f64>; 3];

/// How finely round shapes are split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Detail {
    /// Segments around the circumference of round shapes.
    pub slices: usize,
    /// Latitude bands of a sphere (a capsule's two caps share as many); even.
    pub stacks: usize,
}

impl Detail {
    /// 16 segments around, 8 bands: smooth outlines in pictures a few hundred pixels high.
    pub const FULL: Detail = Detail {
        slices: 16,
        stacks: 8,
    };
    /// 8 segments around, 4 bands: for pictures under 200 pixels high (observation images),
    /// where a link about 7 pixels in radius is drawn at most half a pixel inside its outline.
    pub const COARSE: Detail = Detail {
        slices: 8,
        stacks: 4,
    };

    /// The detail for pictures `height` pixels high.
    pub fn for_height(height: u32) -> Detail {
        if height < 200 {
            Detail::COARSE
        } else {
            Detail::FULL
        }
    }
}

/// Appends the triangles of `shape` to `out` at full detail. Planes are not tessellated (they
/// are unbounded); the scene draws its own floor.
pub fn tessellate(shape: &VisualShape, out: &mut Vec<Triangle>) {
    tessellate_with(shape, Detail::FULL, out);
}

/// Appends the triangles of `shape` to `out`, round shapes split as `detail` says.
pub fn tessellate_with(shape: &VisualShape, detail: Detail, out: &mut Vec<Triangle>) {
    let Detail { slices, .. } = detail;
    let start = out.len();
    match shape {
        VisualShape::Box { half_extents: h } => {
            let corner = |i: usize| {
                Vector3::new(
                    if i & 1 == 0 { -h.x } else { h.x },
                    if i & 2 == 0 { -h.y } else { h.y },
                    if i & 4 == 0 { -h.z } else { h.z },
                )
            };
            for quad in [
                [0, 1, 3, 2],
                [4, 5, 7, 6],
                [0, 1, 5, 4],
                [2, 3, 7, 6],
                [0, 2, 6, 4],
                [1, 3, 7, 5],
            ] {
                let [a, b, c, d] = quad.map(corner);
                out.push([a, b, c]);
                out.push([a, c, d]);
            }
        }
        VisualShape::Sphere { radius } => round(*radius, 0.0, detail, out),
        VisualShape::Capsule {
            half_height,
            radius,
        } => round(*radius, *half_height, detail, out),
        VisualShape::Cylinder {
            half_height,
            radius,
        } => {
            let ring = |k: usize, z: f64| {
                let a = TAU * (k % slices) as f64 / slices as f64;
                Vector3::new(radius * a.cos(), radius * a.sin(), z)
            };
            let (top, bottom) = (Vector3::z() * *half_height, -Vector3::z() * *half_height);
            for k in 0..slices {
                let (t0, t1) = (ring(k, *half_height), ring(k + 1, *half_height));
                let (b0, b1) = (ring(k, -*half_height), ring(k + 1, -*half_height));
                out.extend([[b0, b1, t1], [b0, t1, t0], [top, t0, t1], [bottom, b1, b0]]);
            }
        }
        VisualShape::ConvexMesh {
            vertices,
            triangles,
        } => {
            for t in triangles {
                if let (Some(a), Some(b), Some(c)) = (
                    vertices.get(t[0] as usize),
                    vertices.get(t[1] as usize),
                    vertices.get(t[2] as usize),
                ) {
                    out.push([*a, *b, *c]);
                }
            }
        }
        VisualShape::Plane => {}
        VisualShape::Mesh { mesh } => {
            // As the file winds them: it need not be convex, and renderers draw both sides.
            let v = mesh.vertices();
            out.extend(mesh.triangles().iter().map(|t| t.map(|k| v[k as usize])));
            return;
        }
    }
    // Every other shape here is convex around its centre: a face points outwards when its normal
    // points away from the centre. This fixes the winding whatever the source gave.
    let centre = match shape {
        VisualShape::ConvexMesh { vertices, .. } if !vertices.is_empty() => {
            vertices.iter().sum::<Vector3<f64>>() / vertices.len() as f64
        }
        _ => Vector3::zeros(),
    };
    for t in &mut out[start..] {
        let normal = (t[1] - t[0]).cross(&(t[2] - t[0]));
        if normal.dot(&((t[0] + t[1] + t[2]) / 3.0 - centre)) < 0.0 {
            t.swap(1, 2);
        }
    }
}

/// A sphere of `radius`, split at the equator and its halves moved `half_height` up and down
/// along z: a capsule, or a sphere when `half_height` is 0.
fn round(radius: f64, half_height: f64, detail: Detail, out: &mut Vec<Triangle>) {
    let Detail { slices, stacks } = detail;
    let point = |stack: usize, slice: usize| {
        // Latitude from -pi/2 (bottom) to pi/2; the equator is duplicated, once per cap.
        let (lat, shift) = if stack <= stacks / 2 {
            (-FRAC_PI_2 + PI * stack as f64 / stacks as f64, -half_height)
        } else {
            (
                -FRAC_PI_2 + PI * (stack - 1) as f64 / stacks as f64,
                half_height,
            )
        };
        // The seam (slice `slices`) is slice 0 and the poles are one point each, bit for bit,
        // so that the mesh's shared corners are stored (and transformed) once.
        if stack == 0 || stack == stacks + 1 {
            return Vector3::new(0.0, 0.0, radius * lat.sin() + shift);
        }
        let lon = TAU * (slice % slices) as f64 / slices as f64;
        Vector3::new(
            radius * lat.cos() * lon.cos(),
            radius * lat.cos() * lon.sin(),
            radius * lat.sin() + shift,
        )
    };
    for stack in 0..=stacks {
        for slice in 0..slices {
            let (a, b) = (point(stack, slice), point(stack, slice + 1));
            let (c, d) = (point(stack + 1, slice + 1), point(stack + 1, slice));
            // Bands touching a pole collapse to one triangle.
            if stack > 0 {
                out.push([a, b, c]);
            }
            if stack < stacks {
                out.push([a, c, d]);
            }
        }
    }
}

/// Triangles as indices into a list of distinct vertices, so that a vertex several
/// triangles share is transformed once per frame. Each triangle's corners are bit for bit
/// the ones it was built from (vertices are merged only when their coordinates are equal).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IndexedMesh {
    /// The distinct vertices (m).
    pub vertices: Vec<Vector3<f64>>,
    /// Each triangle's corners, by index into `vertices`, in the order they were given.
    pub triangles: Vec<[u32; 3]>,
}

impl IndexedMesh {
    /// The mesh of `triangles`.
    pub fn from_triangles(triangles: &[Triangle]) -> Self {
        let mut index: std::collections::HashMap<[u64; 3], u32> = Default::default();
        let mut mesh = Self::default();
        for t in triangles {
            let corners = t.map(|v| {
                *index.entry(v.map(f64::to_bits).into()).or_insert_with(|| {
                    mesh.vertices.push(v);
                    (mesh.vertices.len() - 1) as u32
                })
            });
            mesh.triangles.push(corners);
        }
        mesh
    }

    /// Triangle `i`'s corners from `vertices` (this mesh's, or their images under a map).
    pub fn corners<T: Copy>(&self, i: usize, vertices: &[T]) -> [T; 3] {
        map3(self.triangles[i], |k| vertices[k as usize])
    }
}

/// `a.map(f)` for three elements, spelt out: `[T; 3]::map` goes through `try_map`, which
/// is not always inlined, and the renderer calls this for every corner of every triangle.
#[inline(always)]
pub(crate) fn map3<T, U>(a: [T; 3], mut f: impl FnMut(T) -> U) -> [U; 3] {
    let [x, y, z] = a;
    [f(x), f(y), f(z)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_closed_outward(shape: &VisualShape, inside: f64, outside: f64) {
        for detail in [Detail::FULL, Detail::COARSE] {
            check_closed_outward_at(shape, detail, inside, outside);
        }
    }

    fn check_closed_outward_at(shape: &VisualShape, detail: Detail, inside: f64, outside: f64) {
        let mut tris = Vec::new();
        tessellate_with(shape, detail, &mut tris);
        assert!(!tris.is_empty());
        let mut signed_volume = 0.0;
        for t in &tris {
            for p in t {
                let r = p.norm();
                assert!(r <= outside + 1e-9 && r.is_finite(), "vertex {p:?} outside");
            }
            signed_volume += t[0].dot(&t[1].cross(&t[2])) / 6.0;
        }
        // Outward winding gives a positive volume, about that of the shape (the coarse detail's
        // octagons keep 90 % of a circle's area).
        let inside = if detail == Detail::COARSE {
            0.85 * inside
        } else {
            inside
        };
        assert!(
            signed_volume > inside,
            "volume {signed_volume} at {detail:?}"
        );
    }

    #[test]
    fn an_indexed_mesh_gives_back_every_corner_bit_for_bit() {
        for shape in [
            VisualShape::Box {
                half_extents: Vector3::new(0.1, 0.2, 0.3),
            },
            VisualShape::Sphere { radius: 0.7 },
            VisualShape::Capsule {
                half_height: 0.3,
                radius: 0.05,
            },
        ] {
            for detail in [Detail::FULL, Detail::COARSE] {
                let mut triangles = Vec::new();
                tessellate_with(&shape, detail, &mut triangles);
                let mesh = IndexedMesh::from_triangles(&triangles);
                assert_eq!(mesh.triangles.len(), triangles.len());
                for (i, t) in triangles.iter().enumerate() {
                    let corners = mesh.corners(i, &mesh.vertices);
                    for (a, b) in corners.iter().zip(t) {
                        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
                    }
                }
                // Shared corners are stored once.
                assert!(2 * mesh.vertices.len() < triangles.len() * 3, "{shape:?}");
            }
        }
    }

    #[test]
    fn shapes_are_closed_and_wound_outwards() {
        let h = Vector3::new(0.1, 0.2, 0.3);
        let mut tris = Vec::new();
        tessellate(&VisualShape::Box { half_extents: h }, &mut tris);
        let volume: f64 = tris
            .iter()
            .map(|t| t[0].dot(&t[1].cross(&t[2])) / 6.0)
            .sum();
        assert!((volume - 8.0 * 0.1 * 0.2 * 0.3).abs() < 1e-12);
        let sphere_volume = 4.0 / 3.0 * PI;
        check_closed_outward(
            &VisualShape::Sphere { radius: 1.0 },
            0.8 * sphere_volume,
            1.0,
        );
        check_closed_outward(
            &VisualShape::Capsule {
                half_height: 1.0,
                radius: 1.0,
            },
            0.8 * (sphere_volume + 2.0 * PI),
            2.0,
        );
        check_closed_outward(
            &VisualShape::Cylinder {
                half_height: 1.0,
                radius: 1.0,
            },
            0.9 * 2.0 * PI,
            2f64.sqrt(),
        );
    }
}
