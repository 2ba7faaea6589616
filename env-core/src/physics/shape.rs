//! The shapes an object of a [`super::Scene`] can have ([`ObjectShape`]): boxes, spheres,
//! cylinders and capsules, convex hulls of points, and compounds of these at poses in the
//! object's frame (a box with a hole, a convex decomposition of a mesh). Cylinders and capsules
//! run along the object's z axis. Turned into rapier's shapes here, and nowhere else.

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use rapier3d::geometry::SharedShape;

use super::convert::{pose_from_na, vec_from_array};
use crate::error::{ensure_all_finite, Error, Result};

/// The shape of an object in its own frame (the frame [`super::Simulation::object_state`]
/// reports; its centre of mass follows from the shape and a uniform density).
#[derive(Debug, Clone, PartialEq)]
pub enum ObjectShape {
    /// A box centred on the origin.
    Box {
        /// Half the side lengths along x, y and z (m).
        half_extents: [f64; 3],
    },
    /// A sphere centred on the origin.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A cylinder along z, centred on the origin.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Half its height (m).
        half_height: f64,
    },
    /// A capsule along z, centred on the origin: the segment from `-half_height` to
    /// `+half_height` swept by a sphere of `radius`.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Half the length of its central segment (m).
        half_height: f64,
    },
    /// The convex hull of points (m), at least four of them not in one plane. A flat face of
    /// any number of corners rests on what it touches (our parry patch,
    /// `patches/parry3d/`, lets a face of more than four corners touch at the four that span
    /// the largest area).
    ConvexHull {
        /// The points; those inside the hull are dropped.
        points: Vec<[f64; 3]>,
    },
    /// Several shapes fixed together, each at a pose in the object's frame (parts are not
    /// compounds themselves).
    Compound {
        /// The parts.
        parts: Vec<ShapePart>,
    },
}

/// One part of an [`ObjectShape::Compound`].
#[derive(Debug, Clone, PartialEq)]
pub struct ShapePart {
    /// Where the part's frame is in the object's frame.
    pub pose: Isometry3<f64>,
    /// The part's shape in its frame (not a compound).
    pub shape: ObjectShape,
}

impl ShapePart {
    /// `shape` with its frame at `position` in the object's frame, not turned.
    pub fn at(position: [f64; 3], shape: ObjectShape) -> Self {
        Self {
            pose: Isometry3::translation(position[0], position[1], position[2]),
            shape,
        }
    }
}

impl ObjectShape {
    /// A cube of edge `size` (m).
    pub fn cube(size: f64) -> Self {
        Self::Box {
            half_extents: [size / 2.0; 3],
        }
    }

    /// The edge of a cube (a box with three equal sides), `None` for any other shape.
    pub fn cube_size(&self) -> Option<f64> {
        match self {
            Self::Box {
                half_extents: [x, y, z],
            } if x == y && y == z => Some(2.0 * x),
            _ => None,
        }
    }

    /// Checks sizes (finite, > 0), points (finite, at least four) and parts (at least one,
    /// none a compound); `field` names the shape in the error.
    pub fn validate(&self, field: &str) -> Result<()> {
        let positive = |what: &str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(Error::InvalidConfig {
                    field: format!("{field}.{what}"),
                    reason: format!("must be finite and > 0, got {value}"),
                })
            }
        };
        match self {
            Self::Box { half_extents } => {
                for (axis, &h) in ["x", "y", "z"].iter().zip(half_extents) {
                    positive(&format!("half_extents.{axis}"), h)?;
                }
            }
            Self::Sphere { radius } => positive("radius", *radius)?,
            Self::Cylinder {
                radius,
                half_height,
            }
            | Self::Capsule {
                radius,
                half_height,
            } => {
                positive("radius", *radius)?;
                positive("half_height", *half_height)?;
            }
            Self::ConvexHull { points } => {
                for (i, p) in points.iter().enumerate() {
                    ensure_all_finite(&format!("{field}.points[{i}]"), p)?;
                }
                if points.len() < 4 {
                    return Err(Error::InvalidConfig {
                        field: format!("{field}.points"),
                        reason: format!(
                            "a convex hull needs at least 4 points not in one plane, got {}",
                            points.len()
                        ),
                    });
                }
            }
            Self::Compound { parts } => {
                if parts.is_empty() {
                    return Err(Error::InvalidConfig {
                        field: format!("{field}.parts"),
                        reason: "a compound needs at least one part".into(),
                    });
                }
                for (i, part) in parts.iter().enumerate() {
                    let part_field = format!("{field}.parts[{i}]");
                    if matches!(part.shape, Self::Compound { .. }) {
                        return Err(Error::InvalidConfig {
                            field: part_field,
                            reason: "a part of a compound cannot be a compound".into(),
                        });
                    }
                    let pose = &part.pose;
                    ensure_all_finite(
                        &format!("{part_field}.pose.translation"),
                        pose.translation.vector.as_slice(),
                    )?;
                    ensure_all_finite(
                        &format!("{part_field}.pose.rotation"),
                        pose.rotation.coords.as_slice(),
                    )?;
                    part.shape.validate(&format!("{part_field}.shape"))?;
                }
            }
        }
        Ok(())
    }

    /// The half extents of the box, centred on the object's origin and aligned with its axes,
    /// that holds the shape (m).
    pub fn half_extents(&self) -> Vector3<f64> {
        let mut high = Vector3::zeros();
        self.for_each_extreme(&Isometry3::identity(), &mut |p| {
            high = high.sup(&p.coords.abs());
        });
        high
    }

    /// The corners (lowest, highest) of the smallest box aligned with the object's frame that
    /// holds the shape (m, object frame).
    pub fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        let mut low = Vector3::repeat(f64::INFINITY);
        let mut high = Vector3::repeat(f64::NEG_INFINITY);
        self.for_each_extreme(&Isometry3::identity(), &mut |p| {
            low = low.inf(&p.coords);
            high = high.sup(&p.coords);
        });
        (low, high)
    }

    /// Calls `visit` with points whose bounding box is the shape's, in the frame `pose` puts
    /// the shape in: box and cylinder corners, sphere and capsule extremes, hull points.
    fn for_each_extreme(&self, pose: &Isometry3<f64>, visit: &mut impl FnMut(Point3<f64>)) {
        let mut corners = |h: Vector3<f64>, pose: &Isometry3<f64>| {
            for i in 0..8 {
                let sign = |bit: usize| if i >> bit & 1 == 0 { -1.0 } else { 1.0 };
                visit(pose * Point3::new(sign(0) * h.x, sign(1) * h.y, sign(2) * h.z));
            }
        };
        match self {
            Self::Box { half_extents } => corners(Vector3::from(*half_extents), pose),
            Self::Sphere { radius } => corners(Vector3::repeat(*radius), pose),
            Self::Cylinder {
                radius,
                half_height,
            } => corners(Vector3::new(*radius, *radius, *half_height), pose),
            Self::Capsule {
                radius,
                half_height,
            } => corners(Vector3::new(*radius, *radius, half_height + radius), pose),
            Self::ConvexHull { points } => {
                for p in points {
                    visit(pose * Point3::from(*p));
                }
            }
            Self::Compound { parts } => {
                for part in parts {
                    part.shape.for_each_extreme(&(pose * part.pose), visit);
                }
            }
        }
    }

    /// rapier's shape, and where it sits in the object's frame (cylinders and capsules are
    /// built along rapier's y axis and turned onto z). Call [`ObjectShape::validate`] first;
    /// `field` names the shape in the error of a hull that cannot be built.
    pub(super) fn build(&self, field: &str) -> Result<(SharedShape, Isometry3<f64>)> {
        // Maps rapier's y axis onto the object's z axis.
        let y_to_z = Isometry3::from_parts(
            Default::default(),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2),
        );
        Ok(match self {
            Self::Box { half_extents: h } => (
                SharedShape::cuboid(h[0] as f32, h[1] as f32, h[2] as f32),
                Isometry3::identity(),
            ),
            Self::Sphere { radius } => (SharedShape::ball(*radius as f32), Isometry3::identity()),
            Self::Cylinder {
                radius,
                half_height,
            } => (
                SharedShape::cylinder(*half_height as f32, *radius as f32),
                y_to_z,
            ),
            Self::Capsule {
                radius,
                half_height,
            } => (
                SharedShape::capsule_z(*half_height as f32, *radius as f32),
                Isometry3::identity(),
            ),
            Self::ConvexHull { points } => {
                let points: Vec<_> = points.iter().map(|&p| vec_from_array(p)).collect();
                // parry builds a flat hull of points in one plane; it has no volume (no mass).
                let hull = SharedShape::convex_hull(&points)
                    .filter(|hull| hull.mass_properties(1.0).mass() > 0.0)
                    .ok_or_else(|| Error::InvalidConfig {
                        field: format!("{field}.points"),
                        reason: "their convex hull has no volume (all points in one plane)".into(),
                    })?;
                (hull, Isometry3::identity())
            }
            Self::Compound { parts } => {
                let mut built = Vec::with_capacity(parts.len());
                for (i, part) in parts.iter().enumerate() {
                    let (shape, local) = part.shape.build(&format!("{field}.parts[{i}].shape"))?;
                    built.push((pose_from_na(&(part.pose * local)), shape));
                }
                (SharedShape::compound(built), Isometry3::identity())
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_extents_cover_turned_parts() {
        let shape = ObjectShape::Compound {
            parts: vec![
                ShapePart::at(
                    [0.1, 0.0, 0.0],
                    ObjectShape::Box {
                        half_extents: [0.01, 0.02, 0.03],
                    },
                ),
                ShapePart {
                    pose: Isometry3::from_parts(
                        Default::default(),
                        UnitQuaternion::from_axis_angle(
                            &Vector3::y_axis(),
                            std::f64::consts::FRAC_PI_2,
                        ),
                    ),
                    shape: ObjectShape::Cylinder {
                        radius: 0.02,
                        half_height: 0.05,
                    },
                },
            ],
        };
        let h = shape.half_extents();
        assert!((h - Vector3::new(0.11, 0.02, 0.03)).norm() < 1e-12, "{h}");
    }

    #[test]
    fn bad_shapes_name_the_field() {
        let flat = ObjectShape::ConvexHull {
            points: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
            ],
        };
        flat.validate("o").unwrap();
        let err = flat.build("o").unwrap_err().to_string();
        assert!(err.contains("o.points"), "{err}");
        let nested = ObjectShape::Compound {
            parts: vec![ShapePart::at(
                [0.0; 3],
                ObjectShape::Compound {
                    parts: vec![ShapePart::at([0.0; 3], ObjectShape::cube(0.1))],
                },
            )],
        };
        let err = nested.validate("o").unwrap_err().to_string();
        assert!(err.contains("o.parts[0]"), "{err}");
        let nan = ObjectShape::Sphere { radius: f64::NAN };
        assert!(nan
            .validate("o")
            .unwrap_err()
            .to_string()
            .contains("o.radius"));
        let few = ObjectShape::ConvexHull {
            points: vec![[0.0; 3]; 3],
        };
        assert!(few.validate("o").is_err());
        assert!(ObjectShape::Compound { parts: vec![] }
            .validate("o")
            .is_err());
    }
}
