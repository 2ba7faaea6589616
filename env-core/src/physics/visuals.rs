//! The world for drawing: every collider as a renderer-neutral [`VisualPrimitive`] (shape, pose
//! and owner), so no renderer needs rapier's types.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rapier3d::geometry::ColliderHandle;

use super::convert::{pose_to_na, vec_to_na};
use super::Simulation;

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

/// One collider as it is now: its shape, world pose and owner.
#[derive(Debug, Clone, PartialEq)]
pub struct VisualPrimitive {
    /// Shape in the primitive's frame.
    pub shape: VisualShape,
    /// World pose of the primitive's frame.
    pub pose: Isometry3<f64>,
    /// What it belongs to.
    pub tag: VisualTag,
}

impl Simulation {
    /// Every collider as a [`VisualPrimitive`] at its current pose, appended to `out`: the
    /// floor, the platform, the objects and the robot's links. Renderers draw these instead of
    /// touching the physics engine.
    pub fn visual_primitives(&self, out: &mut Vec<VisualPrimitive>) {
        let mut push = |handle: ColliderHandle, tag: VisualTag| {
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
        push(self.floor_collider, VisualTag::Floor);
        if let Some(platform) = self.platform_collider {
            push(platform, VisualTag::Platform);
        }
        for (index, object) in self.objects.iter().enumerate() {
            push(object.collider, VisualTag::Object { index });
        }
        for (index, articulation) in self.articulations.iter().enumerate() {
            for &(handle, link) in &articulation.colliders {
                push(handle, VisualTag::Articulation { index, link });
            }
        }
        for &(handle, link) in &self.robot_colliders {
            let finger = self.gripper.as_ref().is_some_and(|g| g.is_finger(link));
            push(handle, VisualTag::RobotLink { link, finger });
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
    });
}
