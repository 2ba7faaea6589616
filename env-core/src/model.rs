//! The robot description: links, joints and limits read from a URDF, independent of the physics
//! engine (articulated objects, such as the shipped cabinet, are read the same way). Kinematics (`crate::kinematics`) and introspection work on this alone.
//!
//! Over 600 lines: reading and validating a URDF (every malformed case with its own message)
//! and the unit tests of both make up most of it; the accessors are thin.

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use rapier3d_urdf::urdf_rs;

use crate::error::{Error, Result};

/// The kind of a joint, as in the URDF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JointType {
    /// Rotation about `axis`, limited to `[lower, upper]` radians.
    Revolute,
    /// Rotation about `axis` without position limits.
    Continuous,
    /// Translation along `axis`, limited to `[lower, upper]` metres.
    Prismatic,
    /// No motion.
    Fixed,
}

impl JointType {
    /// The lower-case URDF name of this type (`"revolute"`, `"prismatic"`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            JointType::Revolute => "revolute",
            JointType::Continuous => "continuous",
            JointType::Prismatic => "prismatic",
            JointType::Fixed => "fixed",
        }
    }

    /// Whether the joint has a degree of freedom.
    pub fn is_movable(self) -> bool {
        self != JointType::Fixed
    }
}

/// A joint that follows another one: `q = multiplier * q_master + offset` (the real gripper's
/// second finger).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mimic {
    /// Index of the joint being followed.
    pub master: usize,
    /// Gain on the master's position.
    pub multiplier: f64,
    /// Constant offset.
    pub offset: f64,
}

/// Everything known about one joint: the PyBullet `getJointInfo` fields, done properly.
#[derive(Debug, Clone, PartialEq)]
pub struct JointInfo {
    /// Position of this joint in the URDF's joint list.
    pub index: usize,
    /// The URDF name.
    pub name: String,
    /// Revolute, continuous, prismatic or fixed.
    pub joint_type: JointType,
    /// Lower position limit (rad or m); `-inf` when unlimited.
    pub lower: f64,
    /// Upper position limit (rad or m); `+inf` when unlimited.
    pub upper: f64,
    /// Effort limit (N m or N) from the URDF.
    pub max_force: f64,
    /// Velocity limit (rad/s or m/s) from the URDF.
    pub max_velocity: f64,
    /// Viscous damping (N m s/rad or N s/m) from the URDF's `<dynamics damping>`; 0 where
    /// absent, as the URDF standard (and MuJoCo) read it.
    pub damping: f64,
    /// Coulomb friction (N m or N) from the URDF's `<dynamics friction>`; 0 where absent.
    pub friction: f64,
    /// Unit axis in the joint frame.
    pub axis: Vector3<f64>,
    /// Name of the parent link.
    pub parent_link: String,
    /// Name of the child link.
    pub child_link: String,
    /// Index of the parent link.
    pub parent_link_index: usize,
    /// Index of the child link.
    pub child_link_index: usize,
    /// Pose of the joint frame in the parent link's frame.
    pub origin: Isometry3<f64>,
    /// Set when this joint copies another joint's motion.
    pub mimic: Option<Mimic>,
    /// Position of this joint in the actuated-joint vector `q`, for movable joints that are not
    /// mimics; `None` otherwise.
    pub dof: Option<usize>,
}

impl JointInfo {
    /// Clamps a position into this joint's limits.
    pub fn clamp(&self, position: f64) -> f64 {
        position.clamp(self.lower, self.upper)
    }
}

/// One link of the robot.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkInfo {
    /// Position in the URDF's link list.
    pub index: usize,
    /// The URDF name.
    pub name: String,
    /// Mass in kg from the URDF `<inertial>` block (0 for frame-only links).
    pub mass: f64,
    /// The joint whose child this link is; `None` for the root.
    pub parent_joint: Option<usize>,
}

/// The tool centre point: a fixed offset from one link (for the Panda, between the fingertips).
#[derive(Debug, Clone, PartialEq)]
pub struct Tcp {
    /// Index of the link the TCP is attached to.
    pub link: usize,
    /// Pose of the TCP in that link's frame.
    pub offset: Isometry3<f64>,
}

/// A robot read from a URDF: the kinematic tree, limits, masses and the tool centre point.
#[derive(Debug, Clone)]
pub struct RobotModel {
    name: String,
    source: String,
    links: Vec<LinkInfo>,
    joints: Vec<JointInfo>,
    root_link: usize,
    /// Movable, non-mimic joints in URDF order: the entries of the configuration vector `q`.
    actuated: Vec<usize>,
    /// Joint indices ordered so that every parent link is placed before its children.
    topological: Vec<usize>,
    tcp: Tcp,
    /// The parsed URDF with every mesh path resolved to an existing file.
    urdf: urdf_rs::Robot,
}

impl RobotModel {
    /// Reads a URDF file. Mesh references (`package://pkg/...`, `file://...`, relative or
    /// absolute paths) are resolved against the URDF's folder, its ancestors and
    /// `ROS_PACKAGE_PATH`; a collision mesh that cannot be found is an error, never silently
    /// dropped.
    pub fn from_urdf_file(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| Error::AssetNotFound {
            path: path.to_owned(),
            reason: e.to_string(),
        })?;
        let base = path
            .parent()
            .map(Path::to_owned)
            .unwrap_or_else(|| PathBuf::from("."));
        Self::parse(&text, &base, &path.display().to_string())
    }

    /// Reads a URDF document from a string; relative mesh paths resolve against `base_dir`.
    pub fn from_urdf_str(text: &str, base_dir: impl AsRef<Path>) -> Result<Self> {
        Self::parse(text, base_dir.as_ref(), "<string>")
    }

    /// The robot `config` names: its `robot.urdf`, else the bundled Panda.
    pub fn from_config(config: &crate::config::SimConfig) -> Result<Self> {
        match &config.robot.urdf {
            Some(path) => Self::from_urdf_file(path),
            None => Self::panda(),
        }
    }

    /// The bundled Franka Panda description (`assets/panda/panda.urdf`).
    pub fn panda() -> Result<Self> {
        Self::parse(
            crate::assets::PANDA_URDF,
            Path::new("."),
            crate::assets::PANDA_URDF_SOURCE,
        )
    }

    /// The shipped cabinet with one drawer (`assets/cabinet/cabinet.urdf`): not a robot but an
    /// articulated object ([`crate::ArticulationSpec`]), read the same way.
    pub fn cabinet() -> Result<Self> {
        Self::parse(
            crate::assets::CABINET_URDF,
            Path::new("."),
            crate::assets::CABINET_URDF_SOURCE,
        )
    }

    fn parse(text: &str, base_dir: &Path, source_name: &str) -> Result<Self> {
        let malformed = |reason: String| Error::MalformedUrdf {
            source_name: source_name.to_owned(),
            reason,
        };
        let mut urdf = urdf_rs::read_from_string(text).map_err(|e| malformed(e.to_string()))?;
        resolve_meshes(&mut urdf, base_dir, source_name)?;

        if urdf.links.is_empty() {
            return Err(malformed("the robot has no links".into()));
        }
        let link_index = |name: &str| urdf.links.iter().position(|l| l.name == name);
        let mut links: Vec<LinkInfo> = urdf
            .links
            .iter()
            .enumerate()
            .map(|(index, l)| LinkInfo {
                index,
                name: l.name.clone(),
                mass: l.inertial.mass.value,
                parent_joint: None,
            })
            .collect();
        for (i, l) in links.iter().enumerate() {
            if links[..i].iter().any(|o| o.name == l.name) {
                return Err(malformed(format!("duplicate link name `{}`", l.name)));
            }
            if !l.mass.is_finite() || l.mass < 0.0 {
                return Err(malformed(format!("link `{}` has mass {}", l.name, l.mass)));
            }
        }

        let mut joints = Vec::with_capacity(urdf.joints.len());
        for (index, j) in urdf.joints.iter().enumerate() {
            let joint_type = match &j.joint_type {
                urdf_rs::JointType::Revolute => JointType::Revolute,
                urdf_rs::JointType::Continuous => JointType::Continuous,
                urdf_rs::JointType::Prismatic => JointType::Prismatic,
                urdf_rs::JointType::Fixed => JointType::Fixed,
                other => {
                    return Err(malformed(format!(
                        "joint `{}` has type {other:?}; only revolute, continuous, prismatic and fixed joints are supported",
                        j.name
                    )))
                }
            };
            let parent = link_index(&j.parent.link).ok_or_else(|| {
                malformed(format!(
                    "joint `{}` names unknown parent link `{}`",
                    j.name, j.parent.link
                ))
            })?;
            let child = link_index(&j.child.link).ok_or_else(|| {
                malformed(format!(
                    "joint `{}` names unknown child link `{}`",
                    j.name, j.child.link
                ))
            })?;
            if links[child].parent_joint.is_some() {
                return Err(malformed(format!(
                    "link `{}` is the child of more than one joint",
                    j.child.link
                )));
            }
            links[child].parent_joint = Some(index);

            let axis = Vector3::new(j.axis.xyz[0], j.axis.xyz[1], j.axis.xyz[2]);
            let axis_norm = axis.norm();
            if joint_type.is_movable() && !(axis_norm.is_finite() && axis_norm > 1e-9) {
                return Err(malformed(format!("joint `{}` has a zero axis", j.name)));
            }
            let axis = if axis_norm > 1e-9 {
                axis / axis_norm
            } else {
                Vector3::x()
            };
            let (lower, upper) = match joint_type {
                JointType::Revolute | JointType::Prismatic => (j.limit.lower, j.limit.upper),
                JointType::Continuous => (f64::NEG_INFINITY, f64::INFINITY),
                JointType::Fixed => (0.0, 0.0),
            };
            if lower.is_nan() || upper.is_nan() || lower > upper {
                return Err(malformed(format!(
                    "joint `{}` has limits [{lower}, {upper}]",
                    j.name
                )));
            }
            let origin = urdf_pose(&j.origin);
            if !origin.translation.vector.iter().all(|v| v.is_finite())
                || !origin.rotation.coords.iter().all(|v| v.is_finite())
            {
                return Err(malformed(format!(
                    "joint `{}` has a non-finite origin",
                    j.name
                )));
            }
            let (damping, friction) = j
                .dynamics
                .as_ref()
                .map_or((0.0, 0.0), |d| (d.damping, d.friction));
            if !(damping.is_finite() && damping >= 0.0 && friction.is_finite() && friction >= 0.0) {
                return Err(malformed(format!(
                    "joint `{}` has dynamics damping {damping}, friction {friction} (need finite \
                     values >= 0)",
                    j.name
                )));
            }
            joints.push(JointInfo {
                index,
                name: j.name.clone(),
                joint_type,
                lower,
                upper,
                max_force: j.limit.effort,
                max_velocity: j.limit.velocity,
                damping,
                friction,
                axis,
                parent_link: j.parent.link.clone(),
                child_link: j.child.link.clone(),
                parent_link_index: parent,
                child_link_index: child,
                origin,
                mimic: None,
                dof: None,
            });
        }
        for (i, j) in urdf.joints.iter().enumerate() {
            if let Some(m) = &j.mimic {
                let master = joints
                    .iter()
                    .position(|o| o.name == m.joint)
                    .ok_or_else(|| {
                        malformed(format!(
                            "joint `{}` mimics unknown joint `{}`",
                            j.name, m.joint
                        ))
                    })?;
                if !joints[master].joint_type.is_movable() || urdf.joints[master].mimic.is_some() {
                    return Err(malformed(format!(
                        "joint `{}` mimics `{}`, which is fixed or itself a mimic",
                        j.name, m.joint
                    )));
                }
                joints[i].mimic = Some(Mimic {
                    master,
                    multiplier: m.multiplier.unwrap_or(1.0),
                    offset: m.offset.unwrap_or(0.0),
                });
            }
        }
        let roots: Vec<usize> = links
            .iter()
            .filter(|l| l.parent_joint.is_none())
            .map(|l| l.index)
            .collect();
        if roots.len() != 1 {
            return Err(malformed(format!(
                "expected one root link, found {}: {}",
                roots.len(),
                roots
                    .iter()
                    .map(|&i| links[i].name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        let root_link = roots[0];

        // Breadth-first from the root: parents before children, and a cycle leaves joints out.
        let mut topological = Vec::with_capacity(joints.len());
        let mut frontier = vec![root_link];
        while let Some(link) = frontier.pop() {
            for j in joints.iter().filter(|j| j.parent_link_index == link) {
                topological.push(j.index);
                frontier.push(j.child_link_index);
            }
        }
        if topological.len() != joints.len() {
            return Err(malformed("the joints do not form a tree".into()));
        }

        let mut actuated = Vec::new();
        for j in joints.iter_mut() {
            if j.joint_type.is_movable() && j.mimic.is_none() {
                j.dof = Some(actuated.len());
                actuated.push(j.index);
            }
        }

        // A known convention's TCP (the Panda's sits between the fingertips); any other
        // robot's at its last link.
        let known = crate::assets::KNOWN_TCPS
            .iter()
            .find_map(|&(name, offset)| {
                links
                    .iter()
                    .position(|l| l.name == name)
                    .map(|link| (link, offset))
            });
        let tcp = match known {
            Some((link, offset)) => Tcp {
                link,
                offset: Isometry3::translation(0.0, 0.0, offset),
            },
            None => Tcp {
                link: *topological
                    .last()
                    .map(|&j| &joints[j].child_link_index)
                    .unwrap_or(&root_link),
                offset: Isometry3::identity(),
            },
        };

        Ok(Self {
            name: urdf.name.clone(),
            source: source_name.to_owned(),
            links,
            joints,
            root_link,
            actuated,
            topological,
            tcp,
            urdf,
        })
    }

    /// The robot's name from the URDF.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Where the description came from (a path, or `<string>`).
    pub fn source(&self) -> &str {
        &self.source
    }

    /// All links, in URDF order.
    pub fn links(&self) -> &[LinkInfo] {
        &self.links
    }

    /// All joints (fixed ones included), in URDF order; `JointInfo::index` is the position here.
    pub fn joints(&self) -> &[JointInfo] {
        &self.joints
    }

    /// The root link's index.
    pub fn root_link(&self) -> usize {
        self.root_link
    }

    /// Indices of the movable, non-mimic joints: the order of configuration vectors `q`.
    pub fn actuated_joints(&self) -> &[usize] {
        &self.actuated
    }

    /// Length of a configuration vector `q`.
    pub fn num_dofs(&self) -> usize {
        self.actuated.len()
    }

    /// Joint indices with every parent before its children.
    pub fn topological_joints(&self) -> &[usize] {
        &self.topological
    }

    /// The tool centre point.
    pub fn tcp(&self) -> &Tcp {
        &self.tcp
    }

    /// Moves the tool centre point to `offset` in the frame of link `link_name`.
    pub fn set_tcp(&mut self, link_name: &str, offset: Isometry3<f64>) -> Result<()> {
        let link = self.link_index(link_name)?;
        self.tcp = Tcp { link, offset };
        Ok(())
    }

    /// The parsed URDF, with mesh paths resolved to existing files.
    pub fn urdf(&self) -> &urdf_rs::Robot {
        &self.urdf
    }

    /// Index of the joint named `name`.
    pub fn joint_index(&self, name: &str) -> Result<usize> {
        self.joints
            .iter()
            .position(|j| j.name == name)
            .ok_or_else(|| Error::UnknownJoint {
                name: name.to_owned(),
                known: join_names(self.joints.iter().map(|j| j.name.as_str())),
            })
    }

    /// Index of the link named `name`.
    pub fn link_index(&self, name: &str) -> Result<usize> {
        self.links
            .iter()
            .position(|l| l.name == name)
            .ok_or_else(|| Error::UnknownLink {
                name: name.to_owned(),
                known: join_names(self.links.iter().map(|l| l.name.as_str())),
            })
    }

    /// The joint at `index`, or [`Error::JointIndexOutOfRange`].
    pub fn joint(&self, index: usize) -> Result<&JointInfo> {
        self.joints.get(index).ok_or(Error::JointIndexOutOfRange {
            index,
            count: self.joints.len(),
        })
    }

    /// Position of every joint (fixed ones read 0, mimics follow their master) for the
    /// configuration `q`; no validation, `q` must have `num_dofs()` entries.
    pub(crate) fn expand_positions(&self, q: &[f64], out: &mut [f64]) {
        for j in &self.joints {
            out[j.index] = self.joint_position(j.index, q);
        }
    }

    /// The entry of `q` that moves joint `joint` and the gain it moves it with: its own dof
    /// (gain 1), its master's for a mimic joint (the mimic multiplier), `None` for fixed joints.
    pub(crate) fn joint_driver(&self, joint: usize) -> Option<(usize, f64)> {
        let j = &self.joints[joint];
        match (j.dof, j.mimic) {
            (Some(d), _) => Some((d, 1.0)),
            (None, Some(m)) => self.joints[m.master].dof.map(|d| (d, m.multiplier)),
            (None, None) => None,
        }
    }

    /// Position of joint `joint` in configuration `q` (fixed joints read 0).
    pub(crate) fn joint_position(&self, joint: usize, q: &[f64]) -> f64 {
        let offset = self.joints[joint].mimic.map_or(0.0, |m| m.offset);
        self.joint_driver(joint)
            .map_or(0.0, |(dof, gain)| gain * q[dof] + offset)
    }

    /// Checks that `q` has one finite entry per actuated joint.
    pub fn validate_configuration(&self, q: &[f64]) -> Result<()> {
        crate::error::ensure_len("joint configuration q", self.num_dofs(), q.len())?;
        crate::error::ensure_all_finite("joint configuration q", q)
    }

    /// The configuration `q` clamped into the joint limits.
    pub fn clamp_configuration(&self, q: &mut [f64]) {
        for (value, &j) in q.iter_mut().zip(&self.actuated) {
            *value = self.joints[j].clamp(*value);
        }
    }

    /// The pose of the child link of joint `joint` relative to its parent link at joint
    /// position `position`.
    pub(crate) fn joint_transform(&self, joint: usize, position: f64) -> Isometry3<f64> {
        self.joints[joint].origin * self.joint_motion(joint, position)
    }

    /// The motion of joint `joint` at `position`, in its own frame (after its origin).
    pub(crate) fn joint_motion(&self, joint: usize, position: f64) -> Isometry3<f64> {
        let j = &self.joints[joint];
        match j.joint_type {
            JointType::Revolute | JointType::Continuous => Isometry3::from_parts(
                Translation3::identity(),
                UnitQuaternion::from_axis_angle(&Unit::new_unchecked(j.axis), position),
            ),
            JointType::Prismatic => Isometry3::translation(
                j.axis.x * position,
                j.axis.y * position,
                j.axis.z * position,
            ),
            JointType::Fixed => Isometry3::identity(),
        }
    }
}

fn join_names<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names.collect::<Vec<_>>().join(", ")
}

pub(crate) fn urdf_pose(pose: &urdf_rs::Pose) -> Isometry3<f64> {
    let [x, y, z] = pose.xyz.0;
    let [roll, pitch, yaw] = pose.rpy.0;
    // URDF rpy: fixed-axis roll about x, then pitch about y, then yaw about z.
    Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_euler_angles(roll, pitch, yaw),
    )
}

/// Rewrites every mesh filename of the URDF to an existing absolute path. Collision meshes must
/// resolve; visual meshes that do not are left alone (they are not simulated).
fn resolve_meshes(urdf: &mut urdf_rs::Robot, base_dir: &Path, source_name: &str) -> Result<()> {
    for link in &mut urdf.links {
        for collision in &mut link.collision {
            if let urdf_rs::Geometry::Mesh { filename, .. } = &mut collision.geometry {
                let candidates = mesh_candidates(filename, base_dir);
                match candidates.iter().find(|c| c.is_file()) {
                    Some(found) => *filename = found.display().to_string(),
                    None => {
                        return Err(Error::MissingMesh {
                            filename: filename.clone(),
                            urdf: source_name.to_owned(),
                            tried: candidates
                                .iter()
                                .map(|c| c.display().to_string())
                                .collect::<Vec<_>>()
                                .join(", "),
                        })
                    }
                }
            }
        }
        for visual in &mut link.visual {
            if let urdf_rs::Geometry::Mesh { filename, .. } = &mut visual.geometry {
                if let Some(found) = mesh_candidates(filename, base_dir)
                    .into_iter()
                    .find(|c| c.is_file())
                {
                    *filename = found.display().to_string();
                }
            }
        }
    }
    Ok(())
}

/// Where a mesh reference may live, in the order tried.
fn mesh_candidates(filename: &str, base_dir: &Path) -> Vec<PathBuf> {
    if let Some(rest) = filename.strip_prefix("package://") {
        let (package, inner) = rest.split_once('/').unwrap_or((rest, ""));
        let mut candidates = Vec::new();
        let ros_paths = std::env::var_os("ROS_PACKAGE_PATH")
            .map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
            .unwrap_or_default();
        // pybullet_data style: `package://meshes/...` relative to the URDF's folder; ROS style:
        // `package://<package>/...` where some ancestor folder is, or contains, the package.
        for dir in base_dir
            .ancestors()
            .chain(ros_paths.iter().map(PathBuf::as_path))
        {
            candidates.push(dir.join(package).join(inner));
            if dir.file_name().is_some_and(|n| n == package) {
                candidates.push(dir.join(inner));
            }
        }
        candidates
    } else {
        let path = Path::new(filename.strip_prefix("file://").unwrap_or(filename));
        vec![if path.is_absolute() {
            path.to_owned()
        } else {
            base_dir.join(path)
        }]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bundled_panda_has_the_franka_names_and_limits() {
        let model = RobotModel::panda().unwrap();
        let names: Vec<&str> = model.joints().iter().map(|j| j.name.as_str()).collect();
        for i in 1..=7 {
            assert!(names.contains(&format!("panda_joint{i}").as_str()));
        }
        assert_eq!(model.num_dofs(), 8, "7 arm joints + one gripper dof");
        let j4 = &model.joints()[model.joint_index("panda_joint4").unwrap()];
        assert_eq!((j4.lower, j4.upper), (-3.0718, -0.0698));
        assert_eq!(j4.max_force, 87.0);
        let f2 = &model.joints()[model.joint_index("panda_finger_joint2").unwrap()];
        assert_eq!(f2.joint_type, JointType::Prismatic);
        assert_eq!((f2.lower, f2.upper), (0.0, 0.04));
        assert_eq!(
            f2.mimic.map(|m| m.master),
            Some(model.joint_index("panda_finger_joint1").unwrap())
        );
    }

    #[test]
    fn unknown_names_are_typed_errors() {
        let model = RobotModel::panda().unwrap();
        assert!(matches!(
            model.joint_index("elbow"),
            Err(Error::UnknownJoint { .. })
        ));
        assert!(matches!(
            model.link_index("gripper"),
            Err(Error::UnknownLink { .. })
        ));
        assert!(matches!(
            model.joint(99),
            Err(Error::JointIndexOutOfRange {
                index: 99,
                count: 11
            })
        ));
    }

    #[test]
    fn broken_urdfs_are_rejected_with_a_reason() {
        let err = RobotModel::from_urdf_str("<robot name='x'><link name=", ".").unwrap_err();
        assert!(matches!(err, Error::MalformedUrdf { .. }), "{err}");
        let missing = RobotModel::from_urdf_file("/nonexistent/robot.urdf").unwrap_err();
        assert!(matches!(missing, Error::AssetNotFound { .. }), "{missing}");
        let two_roots = r#"<robot name="x"><link name="a"/><link name="b"/></robot>"#;
        let err = RobotModel::from_urdf_str(two_roots, ".").unwrap_err();
        assert!(err.to_string().contains("one root link"), "{err}");
        let mesh = r#"<robot name="x"><link name="a"><collision><geometry>
            <mesh filename="package://meshes/none.obj"/></geometry></collision></link></robot>"#;
        let err = RobotModel::from_urdf_str(mesh, "/tmp").unwrap_err();
        assert!(matches!(err, Error::MissingMesh { .. }), "{err}");
        let inverted = r#"<robot name="x"><link name="a"/><link name="b"/>
            <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
            <axis xyz="0 0 1"/><limit lower="1" upper="-1" effort="1" velocity="1"/></joint></robot>"#;
        let err = RobotModel::from_urdf_str(inverted, ".").unwrap_err();
        assert!(err.to_string().contains("limits"), "{err}");
    }

    #[test]
    fn package_paths_resolve_next_to_the_urdf() {
        let dir = std::env::temp_dir().join(format!("panda_rapier_mesh_{}", std::process::id()));
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        std::fs::write(dir.join("meshes/box.obj"), "v 0 0 0\n").unwrap();
        let found = mesh_candidates("package://meshes/box.obj", &dir)
            .into_iter()
            .find(|c| c.is_file());
        assert_eq!(found, Some(dir.join("meshes/box.obj")));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
