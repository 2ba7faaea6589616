//! A rigid object from a URDF file (PyBullet's object files, a dataset's models): the collision
//! geometry of its links, joined by fixed joints, as one [`ObjectShape`] in the root link's
//! frame, with the mass its `<inertial>` blocks give. Boxes, spheres, cylinders and capsules
//! become those shapes; meshes (OBJ, STL, COLLADA; `package://`, `file://`, relative and
//! absolute paths resolved by [`RobotModel::from_urdf_file`]) become convex parts by a
//! [`MeshCollision`] (a file named `*_vhacd.*`, PyBullet's convention for a file that is already
//! its convex hulls, is taken as it is, [`MeshCollision::Parts`], unless the collision asked
//! for is one hull). Inertia is not read: the physics spreads the mass uniformly over
//! the shape (several of PyBullet's files give placeholder tensors). Its `<visual>` elements
//! say how it looks ([`ObjectVisual`], [`urdf_visual_parts`]).

use std::path::Path;

use std::sync::Arc;

use nalgebra::{Isometry3, Vector3};
use rapier3d_urdf::urdf_rs;

use crate::error::{Error, Result};
use crate::model::{urdf_pose, JointType, RobotModel};
use crate::physics::{
    color_from_fractions, MeshCollision, MeshFile, ObjectShape, ObjectVisual, ShapeCache,
    ShapePart, VisualPart, VisualShape,
};

/// A URDF object: its shape (root link's frame) and the mass of all its links (0 where the
/// file gives none).
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfObject {
    /// The collision shape.
    pub shape: ObjectShape,
    /// The sum of the links' `<inertial>` masses (kg).
    pub mass: f64,
    /// How it looks: its links' `<visual>` elements (empty where it has none).
    pub visual: Arc<ObjectVisual>,
}

impl UrdfObject {
    /// Reads the URDF at `path`, its lengths (and mesh coordinates) times `scale`; errors name
    /// `field` and the file.
    pub fn load(
        path: &Path,
        scale: f64,
        collision: &MeshCollision,
        field: &str,
        cache: &ShapeCache,
    ) -> Result<Self> {
        let model = RobotModel::from_urdf_file(path)?;
        let bad = |reason: String| Error::BadMesh {
            field: field.to_owned(),
            path: path.to_owned(),
            reason,
        };
        if let Some(j) = model
            .joints()
            .iter()
            .find(|j| j.joint_type != JointType::Fixed)
        {
            return Err(bad(format!(
                "joint `{}` is {}: a pickable object's links must be joined by fixed joints \
                 (an object with moving parts is an articulated object)",
                j.name,
                j.joint_type.as_str()
            )));
        }
        // Each link's pose in the root link's frame, parents first.
        let mut poses = vec![Isometry3::identity(); model.links().len()];
        for &j in model.topological_joints() {
            let joint = &model.joints()[j];
            poses[joint.child_link_index] = poses[joint.parent_link_index] * joint.origin;
        }
        let scaled = |pose: Isometry3<f64>| {
            let mut p = pose;
            p.translation.vector *= scale;
            p
        };
        let mut parts = Vec::new();
        for (link, urdf_link) in model.urdf().links.iter().enumerate() {
            for (k, c) in urdf_link.collision.iter().enumerate() {
                let pose = scaled(poses[link] * urdf_pose(&c.origin));
                let what = format!("link `{}`, collision {k}", urdf_link.name);
                let shape = match &c.geometry {
                    urdf_rs::Geometry::Box { size } => ObjectShape::Box {
                        half_extents: [
                            size[0] * scale / 2.0,
                            size[1] * scale / 2.0,
                            size[2] * scale / 2.0,
                        ],
                    },
                    urdf_rs::Geometry::Sphere { radius } => ObjectShape::Sphere {
                        radius: radius * scale,
                    },
                    urdf_rs::Geometry::Cylinder { radius, length } => ObjectShape::Cylinder {
                        radius: radius * scale,
                        half_height: length * scale / 2.0,
                    },
                    urdf_rs::Geometry::Capsule { radius, length } => ObjectShape::Capsule {
                        radius: radius * scale,
                        half_height: length * scale / 2.0,
                    },
                    urdf_rs::Geometry::Mesh {
                        filename,
                        scale: mesh_scale,
                    } => {
                        let s = mesh_scale.as_ref().map_or([1.0; 3], |v| [v[0], v[1], v[2]]);
                        let path = Path::new(filename);
                        // PyBullet's convention: a `_vhacd` file is already its convex hulls.
                        let hulls = path
                            .file_stem()
                            .is_some_and(|s| s.to_string_lossy().ends_with("_vhacd"));
                        let collision = match collision {
                            MeshCollision::Decompose(_) if hulls => MeshCollision::Parts,
                            other => *other,
                        };
                        let mesh = MeshFile {
                            path: path.to_owned(),
                            scale: [s[0] * scale, s[1] * scale, s[2] * scale],
                            collision,
                        };
                        mesh.load(&format!("{field} ({what})"), cache)?
                    }
                };
                match shape {
                    ObjectShape::Compound { parts: inner } => {
                        parts.extend(inner.into_iter().map(|p| ShapePart {
                            pose: pose * p.pose,
                            shape: p.shape,
                        }))
                    }
                    shape => parts.push(ShapePart { pose, shape }),
                }
            }
        }
        if parts.is_empty() {
            return Err(bad(
                "it has no collision geometry (no link has a <collision> element)".into(),
            ));
        }
        let shape = if parts.len() == 1 && parts[0].pose == Isometry3::identity() {
            parts.remove(0).shape
        } else {
            ObjectShape::Compound { parts }
        };
        let mass = model.links().iter().map(|l| l.mass).sum();
        let mut visual = ObjectVisual::default();
        for (link, pose) in poses.iter().enumerate() {
            visual
                .parts
                .extend(urdf_visual_parts(model.urdf(), link, pose, scale, field)?);
        }
        Ok(Self {
            shape,
            mass,
            visual: Arc::new(visual),
        })
    }
}

/// The `<visual>` elements of link `link` of `urdf` as [`VisualPart`]s in a frame where the
/// link's frame is at `link_pose` (lengths of the file times `scale`; the pose's translation
/// is scaled here). Boxes, spheres, cylinders and capsules become those shapes; a mesh file
/// (its path resolved, as [`RobotModel::from_urdf_file`] resolves them) becomes its triangles.
/// A part's colour: a mesh's own materials' where it gives them (an OBJ's `Kd`), else the
/// element's `<material>` colour (given inline or by the name of a material the file
/// defines at its top), else none. Errors name `field`, the link and the element.
///
/// # Errors
/// [`Error::BadMesh`] for a mesh file that is missing, unreadable or malformed.
pub fn urdf_visual_parts(
    urdf: &urdf_rs::Robot,
    link: usize,
    link_pose: &Isometry3<f64>,
    scale: f64,
    field: &str,
) -> Result<Vec<VisualPart>> {
    let Some(urdf_link) = urdf.links.get(link) else {
        return Ok(Vec::new());
    };
    let mut parts = Vec::new();
    for (k, v) in urdf_link.visual.iter().enumerate() {
        let mut pose = link_pose * urdf_pose(&v.origin);
        pose.translation.vector *= scale;
        let color = v.material.as_ref().and_then(|m| {
            let named = || urdf.materials.iter().find(|n| n.name == m.name);
            let given = m.color.as_ref().or_else(|| named()?.color.as_ref())?;
            color_from_fractions([given.rgba[0], given.rgba[1], given.rgba[2]])
        });
        let shape = match &v.geometry {
            urdf_rs::Geometry::Box { size } => VisualShape::Box {
                half_extents: Vector3::new(size[0], size[1], size[2]) * (scale / 2.0),
            },
            urdf_rs::Geometry::Sphere { radius } => VisualShape::Sphere {
                radius: radius * scale,
            },
            urdf_rs::Geometry::Cylinder { radius, length } => VisualShape::Cylinder {
                half_height: length * scale / 2.0,
                radius: radius * scale,
            },
            urdf_rs::Geometry::Capsule { radius, length } => VisualShape::Capsule {
                half_height: length * scale / 2.0,
                radius: radius * scale,
            },
            urdf_rs::Geometry::Mesh {
                filename,
                scale: mesh_scale,
            } => {
                let s = mesh_scale.as_ref().map_or([1.0; 3], |v| [v[0], v[1], v[2]]);
                let mesh = MeshFile {
                    path: Path::new(filename).to_owned(),
                    scale: [s[0] * scale, s[1] * scale, s[2] * scale],
                    collision: MeshCollision::Hull,
                };
                let what = format!("{field} (link `{}`, visual {k})", urdf_link.name);
                for part in mesh.visual(&mesh.read(&what)?, &what)?.parts {
                    parts.push(VisualPart {
                        pose: pose * part.pose,
                        color: part.color.or(color),
                        shape: part.shape,
                    });
                }
                continue;
            }
        };
        parts.push(VisualPart { shape, pose, color });
    }
    Ok(parts)
}

/// Whether `path` names a URDF file (by its extension, any case).
pub fn is_urdf(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("urdf"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn primitives_and_fixed_links_make_one_compound() {
        let dir =
            std::env::temp_dir().join(format!("panda_rapier_urdf_object_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("dumbbell.urdf");
        std::fs::write(
            &path,
            r#"<robot name="dumbbell">
              <link name="bar"><inertial><mass value="0.2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
                <collision><geometry><cylinder radius="0.01" length="0.1"/></geometry></collision></link>
              <link name="end"><inertial><mass value="0.1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
                <collision><origin xyz="0 0 0.01"/><geometry><sphere radius="0.02"/></geometry></collision></link>
              <joint name="weld" type="fixed"><parent link="bar"/><child link="end"/><origin xyz="0 0 0.05"/></joint>
            </robot>"#,
        )
        .unwrap();
        let cache = ShapeCache::at(dir.join("cache"));
        let object = UrdfObject::load(&path, 2.0, &MeshCollision::Hull, "object", &cache).unwrap();
        assert!((object.mass - 0.3).abs() < 1e-12);
        let ObjectShape::Compound { parts } = &object.shape else {
            panic!("{:?}", object.shape)
        };
        assert_eq!(parts.len(), 2);
        assert_eq!(
            parts[0].shape,
            ObjectShape::Cylinder {
                radius: 0.02,
                half_height: 0.1
            }
        );
        // The sphere's centre: (0.05 + 0.01) m up, scaled twice.
        let centre = parts[1].pose.translation.vector;
        assert!(
            (centre - Vector3::new(0.0, 0.0, 0.12)).norm() < 1e-12,
            "{centre}"
        );
        assert_eq!(parts[1].shape, ObjectShape::Sphere { radius: 0.04 });

        let hinge = dir.join("hinge.urdf");
        std::fs::write(
            &hinge,
            std::fs::read_to_string(&path)
                .unwrap()
                .replace(r#"type="fixed"><parent link="bar"/>"#, r#"type="revolute"><parent link="bar"/><axis xyz="0 0 1"/><limit lower="0" upper="1" effort="1" velocity="1"/>"#),
        )
        .unwrap();
        let err =
            UrdfObject::load(&hinge, 1.0, &MeshCollision::Hull, "object", &cache).unwrap_err();
        assert!(
            err.to_string().contains("weld") && err.to_string().contains("revolute"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
