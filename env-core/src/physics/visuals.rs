//! The world for drawing: every collider as a renderer-neutral [`VisualPrimitive`] (shape, pose
//! and owner), so no renderer needs rapier's types; objects whose files say how they look
//! ([`ObjectVisual`]: coloured visual meshes and shapes) are drawn as their files say instead
//! of as their collision parts.

use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rapier3d::geometry::ColliderHandle;

use super::convert::{pose_to_na, vec_to_na};
use super::{ObjectId, Simulation};

/// A collider's shape in its own frame, for drawing: renderer-neutral, so no renderer needs
/// rapier's types.
#[derive(Debug, Clone, PartialEq)]
pub enum VisualShape {
    /// A box centred on the origin.
    Box {
        /// Half the side lengths along x, y and z (m).
        half_extents: Vector3<f64>,
    },
    /// A sphere centred on the origin.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A capsule along z, centred on the origin: the segment from `-half_height` to
    /// `+half_height`, swept by a sphere.
    Capsule {
        /// Half the length of the central segment (m).
        half_height: f64,
        /// Radius (m).
        radius: f64,
    },
    /// A cylinder along z, centred on the origin.
    Cylinder {
        /// Half the height (m).
        half_height: f64,
        /// Radius (m).
        radius: f64,
    },
    /// A convex mesh (a convex hull of a mesh collider).
    ConvexMesh {
        /// Vertices (m).
        vertices: Vec<Vector3<f64>>,
        /// Triangles as indices into `vertices`.
        triangles: Vec<[u32; 3]>,
    },
    /// The unbounded plane z = 0, facing +z (the floor).
    Plane,
    /// A triangle mesh as a file gives it (a visual mesh: neither convex nor closed, nor
    /// wound consistently, need it be; renderers draw both sides of its triangles).
    Mesh {
        /// The mesh, shared by every world and frame that draws it.
        mesh: SharedMesh,
    },
}

/// Triangles as indices into a list of vertices (m), every index in range and every
/// coordinate finite ([`TriangleMesh::new`] checks).
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    vertices: Vec<Vector3<f64>>,
    triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// The mesh of `triangles` over `vertices`; `None` when an index is out of range, a
    /// coordinate is not finite, or there is no triangle.
    pub fn new(vertices: Vec<Vector3<f64>>, triangles: Vec<[u32; 3]>) -> Option<Self> {
        let count = vertices.len();
        let valid = !triangles.is_empty()
            && triangles.iter().flatten().all(|&i| (i as usize) < count)
            && vertices.iter().all(|v| v.iter().all(|c| c.is_finite()));
        valid.then_some(Self {
            vertices,
            triangles,
        })
    }

    /// The vertices (m).
    pub fn vertices(&self) -> &[Vector3<f64>] {
        &self.vertices
    }

    /// The triangles, as indices into [`TriangleMesh::vertices`].
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }
}

/// A [`TriangleMesh`] shared between worlds and frames: cloning it copies a pointer, and two
/// compare equal at once when they are the same mesh (else by their contents).
#[derive(Debug, Clone)]
pub struct SharedMesh(pub Arc<TriangleMesh>);

impl PartialEq for SharedMesh {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.0 == other.0
    }
}

impl std::ops::Deref for SharedMesh {
    type Target = TriangleMesh;

    fn deref(&self) -> &TriangleMesh {
        &self.0
    }
}

/// One coloured part of how an object looks, in the object's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct VisualPart {
    /// Its shape, in its frame.
    pub shape: VisualShape,
    /// Where its frame is in the object's frame.
    pub pose: Isometry3<f64>,
    /// Its colour as its file gives it (an OBJ material's `Kd`, a URDF `<material>`'s
    /// `rgba`), as 8-bit sRGB; `None` where the file gives none (renderers pick one).
    pub color: Option<[u8; 3]>,
}

/// How an object looks, where its file says (a mesh file's triangles with their materials'
/// colours, a URDF's `<visual>` elements): drawn in place of its collision parts. An empty
/// one (no parts) draws the collision parts.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObjectVisual {
    /// The parts.
    pub parts: Vec<VisualPart>,
}

/// A colour given as fractions (`[0, 1]`, an OBJ material's `Kd`, a URDF `rgba`) as 8-bit
/// sRGB: each channel clamped and rounded; `None` for a non-finite channel.
pub fn color_from_fractions(rgb: [f64; 3]) -> Option<[u8; 3]> {
    rgb.iter()
        .all(|c| c.is_finite())
        .then(|| rgb.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8))
}

/// What a [`VisualPrimitive`] belongs to, so a renderer can pick its material.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VisualTag {
    /// The floor.
    Floor,
    /// The platform.
    Platform,
    /// A movable object (index into [`crate::physics::Scene::objects`]).
    Object {
        /// The object's index.
        index: usize,
    },
    /// A link of an articulated object.
    Articulation {
        /// The object's index in [`crate::physics::Scene::articulations`].
        index: usize,
        /// The link's index in its model's links.
        link: usize,
    },
    /// A robot link (index into [`crate::RobotModel::links`]).
    RobotLink {
        /// Link index.
        link: usize,
        /// Whether the link is a finger of the gripper.
        finger: bool,
    },
}

/// One collider (or one part of an object's [`ObjectVisual`]) as it is now: its shape, world
/// pose, owner and, where its file gives one, colour.
#[derive(Debug, Clone, PartialEq)]
pub struct VisualPrimitive {
    /// Shape in the primitive's frame.
    pub shape: VisualShape,
    /// World pose of the primitive's frame.
    pub pose: Isometry3<f64>,
    /// What it belongs to.
    pub tag: VisualTag,
    /// The colour its file gives ([`VisualPart::color`]); `None`: renderers pick one by tag.
    pub color: Option<[u8; 3]>,
}

impl Simulation {
    /// Every collider as a [`VisualPrimitive`] at its current pose, appended to `out`: the
    /// floor, the platform, the objects and the robot's links. Renderers draw these instead of
    /// touching the physics engine. An object whose [`super::ObjectSpec::visuals`] has an
    /// entry for its variant ([`Simulation::object_variant`]) is that entry's parts instead of
    /// its colliders.
    pub fn visual_primitives(&self, out: &mut Vec<VisualPrimitive>) {
        let push = |handle: ColliderHandle, tag: VisualTag, out: &mut Vec<VisualPrimitive>| {
            let Some(collider) = self.world.colliders.get(handle) else {
                return;
            };
            // A collider's own pose is synchronised with its body only when the world steps;
            // after a teleport (a reset) the body already is where it should be drawn.
            let parent = collider
                .parent()
                .and_then(|b| self.world.bodies.get(b))
                .zip(collider.position_wrt_parent());
            let pose = match parent {
                Some((body, local)) => pose_to_na(body.position()) * pose_to_na(local),
                None => pose_to_na(collider.position()),
            };
            push_visual(collider.shape(), &pose, tag, out);
        };
        push(self.floor_collider, VisualTag::Floor, out);
        if let Some(platform) = self.platform_collider {
            push(platform, VisualTag::Platform, out);
        }
        for (index, object) in self.objects.iter().enumerate() {
            let tag = VisualTag::Object { index };
            let visual = self.scene.objects.get(index).and_then(|spec| {
                let variant = self.object_variant(ObjectId(index)) as usize;
                spec.visuals.get(variant).filter(|v| !v.parts.is_empty())
            });
            let body = self.world.bodies.get(object.body);
            match (visual, body) {
                (Some(visual), Some(body)) => {
                    let pose = pose_to_na(body.position());
                    out.extend(visual.parts.iter().map(|part| VisualPrimitive {
                        shape: part.shape.clone(),
                        pose: pose * part.pose,
                        tag,
                        color: part.color,
                    }));
                }
                _ => push(object.collider, tag, out),
            }
        }
        for (index, articulation) in self.articulations.iter().enumerate() {
            for &(handle, link) in &articulation.colliders {
                push(handle, VisualTag::Articulation { index, link }, out);
            }
        }
        for &(handle, link) in &self.robot_colliders {
            let finger = self.gripper.as_ref().is_some_and(|g| g.is_finger(link));
            push(handle, VisualTag::RobotLink { link, finger }, out);
        }
    }
}

/// Appends `shape` (at world `pose`) as visual primitives; compounds are flattened and shapes
/// a renderer has no use for (none in the scenes built here) are skipped.
fn push_visual(
    shape: &dyn rapier3d::geometry::Shape,
    pose: &Isometry3<f64>,
    tag: VisualTag,
    out: &mut Vec<VisualPrimitive>,
) {
    // parry's cylinders and capsules run along y (capsules between two points); visuals run
    // along z, so the frame is turned: this rotation maps z onto y.
    let z_to_y = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -std::f64::consts::FRAC_PI_2);
    let (shape, local) = if let Some(b) = shape.as_cuboid() {
        let half_extents = vec_to_na(b.half_extents);
        (VisualShape::Box { half_extents }, Isometry3::identity())
    } else if let Some(b) = shape.as_ball() {
        let radius = b.radius as f64;
        (VisualShape::Sphere { radius }, Isometry3::identity())
    } else if let Some(c) = shape.as_capsule() {
        let (a, b) = (vec_to_na(c.segment.a), vec_to_na(c.segment.b));
        let axis = b - a;
        let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &axis)
            // Antiparallel (or a zero-length segment): a half turn about x does.
            .unwrap_or_else(|| {
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
            });
        let shape = VisualShape::Capsule {
            half_height: axis.norm() / 2.0,
            radius: c.radius as f64,
        };
        (
            shape,
            Isometry3::from_parts(Translation3::from((a + b) / 2.0), rotation),
        )
    } else if let Some(c) = shape.as_cylinder() {
        let shape = VisualShape::Cylinder {
            half_height: c.half_height as f64,
            radius: c.radius as f64,
        };
        (
            shape,
            Isometry3::from_parts(Translation3::identity(), z_to_y),
        )
    } else if let Some(c) = shape.as_convex_polyhedron() {
        let (points, triangles) = c.to_trimesh();
        let vertices = points.into_iter().map(vec_to_na).collect();
        (
            VisualShape::ConvexMesh {
                vertices,
                triangles,
            },
            Isometry3::identity(),
        )
    } else if shape.as_halfspace().is_some() {
        // Every halfspace built here is the floor, z up.
        (VisualShape::Plane, Isometry3::identity())
    } else if let Some(compound) = shape.as_compound() {
        for (part_pose, part) in compound.shapes() {
            push_visual(part.as_ref(), &(pose * pose_to_na(part_pose)), tag, out);
        }
        return;
    } else {
        return;
    };
    out.push(VisualPrimitive {
        shape,
        pose: pose * local,
        tag,
        color: None,
    });
}
