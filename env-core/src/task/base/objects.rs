//! Objects a task draws from a set per episode ([`ObjectEntry`] in its configuration, loaded
//! into [`PickableObject`]s): a shipped object of `assets/objects` by name, or a user's mesh
//! file (OBJ, STL or COLLADA) or URDF file ([`UrdfObject`]) with its mass, friction and scale. Each is loaded once per
//! process (a vector env of many copies, and every environment after the first, shares it):
//! its collision shape (convex parts, decompositions cached on disk by [`ShapeCache`]), its
//! bounding box and the top-down grasp the planner finds for it
//! ([`ObjectShape::top_grasp`]).

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock};

use nalgebra::Vector3;
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use sha2::{Digest, Sha256};

use crate::assets::{shipped_object, ShippedObject, OBJECT_MATERIALS, OBJECT_SET};
use crate::config::{invalid, non_negative, positive};
use crate::error::Result;
use crate::physics::{
    GripperGeometry, MeshCollision, MeshFile, ObjectShape, ObjectVisual, ShapeCache, TopGrasp,
};
use crate::urdf_object::{is_urdf, UrdfObject};

/// Mass (kg) and friction of the shipped objects, in [`OBJECT_SET`]'s order: everyday masses
/// (an empty plastic bottle and bowl) within what the Panda's friction grasp holds (the
/// fingers squeeze with 20 N).
const SHIPPED_PROPERTIES: [(&str, f64, f64); 10] = [
    ("can", 0.12, 1.0),
    ("bottle", 0.04, 1.0),
    ("bowl", 0.05, 1.0),
    ("mug", 0.1, 1.0),
    ("banana", 0.1, 1.0),
    ("tennis_ball", 0.058, 1.0),
    ("block", 0.1, 1.0),
    ("hammer", 0.15, 1.0),
    ("screwdriver", 0.08, 1.0),
    ("pear", 0.12, 1.0),
];

/// A mesh file's defaults where an entry gives only its path.
const FILE_MASS: f64 = 0.1;
const FILE_FRICTION: f64 = 1.0;
/// Every object's angular damping (1/s) unless its entry says otherwise: the rolling
/// resistance rapier lacks (without it a ball or a pear set down on the platform rolls on for
/// ever and never comes to rest).
pub const ROLLING_DAMPING: f64 = 5.0;

/// One object of a task's set, as its configuration names it. In JSON, a shipped object's
/// name (`"mug"`), a mesh or URDF file's path (`"/data/cup.obj"`: its mass 0.1 kg (a URDF's
/// own where it gives one), friction 1, scale 1, decomposed), or a map `{"path": ..., "mass": ..., "friction": ..., "rolling_damping":
/// ..., "scale": ..., "collision": "decompose" | "parts" | "hull"}` (fields left out take
/// those defaults).
#[derive(Debug, Clone, PartialEq)]
pub enum ObjectEntry {
    /// A shipped object (`assets/objects`), by name.
    Shipped(String),
    /// A mesh file.
    File(ObjectFile),
}

/// A mesh file as an object of a set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObjectFile {
    /// The file: a mesh (`.obj`, `.stl` or `.dae`) or a URDF (`.urdf`: its links' collision
    /// geometry, joined by fixed joints, [`UrdfObject`]), coordinates in metres times
    /// `scale`, its base resting on what the object stands on with its frame's z axis up.
    pub path: PathBuf,
    /// Mass (kg), spread uniformly; `None`: a URDF's own (its links' `<inertial>` masses)
    /// where it gives one, else 0.1 kg.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    /// Friction coefficient.
    pub friction: f64,
    /// Angular damping of the body (1/s): rolling resistance, which rapier lacks.
    pub rolling_damping: f64,
    /// Scale applied to the file's coordinates.
    pub scale: f64,
    /// How its triangles become convex parts: `"decompose"` (V-HACD, the default),
    /// `"parts"` (each `o`/`g` block one hull, as PyBullet's `_vhacd` files) or `"hull"` (one
    /// hull of everything).
    pub collision: String,
}

impl Default for ObjectFile {
    fn default() -> Self {
        Self {
            path: PathBuf::new(),
            mass: None,
            friction: FILE_FRICTION,
            rolling_damping: ROLLING_DAMPING,
            scale: 1.0,
            collision: "decompose".into(),
        }
    }
}

impl ObjectEntry {
    /// The whole shipped set, in its order.
    pub fn shipped_set() -> Vec<ObjectEntry> {
        OBJECT_SET
            .iter()
            .map(|o| ObjectEntry::Shipped(o.name.into()))
            .collect()
    }

    /// A short name for tables and info: the shipped object's name or the file's stem.
    pub fn label(&self) -> String {
        match self {
            ObjectEntry::Shipped(name) => name.clone(),
            ObjectEntry::File(file) => file.path.file_stem().map_or_else(
                || file.path.display().to_string(),
                |s| s.to_string_lossy().into(),
            ),
        }
    }

    /// Mass (kg; `None` where the file decides), friction and rolling damping (1/s).
    fn material(&self) -> (Option<f64>, f64, f64) {
        match self {
            ObjectEntry::Shipped(name) => SHIPPED_PROPERTIES
                .iter()
                .find(|(n, _, _)| n == name)
                .map_or((None, FILE_FRICTION, ROLLING_DAMPING), |&(_, m, f)| {
                    (Some(m), f, ROLLING_DAMPING)
                }),
            ObjectEntry::File(file) => (file.mass, file.friction, file.rolling_damping),
        }
    }

    /// Loads the object (once per process; later calls share it); `field` names the entry in
    /// errors (`task.objects[3]`).
    pub(crate) fn load(&self, field: &str) -> Result<Arc<PickableObject>> {
        let (mass, friction, rolling_damping) = self.material();
        if let Some(mass) = mass {
            positive(&format!("{field}.mass"), mass)?;
        }
        non_negative(&format!("{field}.friction"), friction)?;
        non_negative(&format!("{field}.rolling_damping"), rolling_damping)?;
        let (key, mesh, bytes, shipped) = match self {
            ObjectEntry::Shipped(name) => {
                let shipped = shipped_object(name).ok_or_else(|| {
                    invalid(
                        field,
                        format!(
                            "`{name}` is no shipped object ({}) and not a mesh or URDF \
                             file's path (.obj, .stl, .dae or .urdf)",
                            OBJECT_SET
                                .iter()
                                .map(|o| o.name)
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    )
                })?;
                // Its convex parts where shipped, else its mesh (decomposed).
                let bytes = Cow::Borrowed(shipped.collision.unwrap_or(shipped.mesh));
                (
                    format!("shipped:{name}"),
                    shipped_mesh(shipped),
                    bytes,
                    Some(shipped),
                )
            }
            ObjectEntry::File(file) => {
                let collision = match file.collision.as_str() {
                    "decompose" => MeshCollision::Decompose(Default::default()),
                    "parts" => MeshCollision::Parts,
                    "hull" => MeshCollision::Hull,
                    other => {
                        return Err(invalid(
                            &format!("{field}.collision"),
                            format!("must be \"decompose\", \"parts\" or \"hull\", got {other:?}"),
                        ))
                    }
                };
                if !(file.scale.is_finite() && file.scale > 0.0) {
                    return Err(invalid(
                        &format!("{field}.scale"),
                        format!("must be finite and > 0, got {}", file.scale),
                    ));
                }
                let mesh = MeshFile {
                    path: file.path.clone(),
                    scale: [file.scale; 3],
                    collision,
                };
                let bytes = mesh.read(field)?;
                let digest: String = Sha256::digest(&bytes)
                    .iter()
                    .map(|b| format!("{b:02x}"))
                    .collect();
                let key = format!(
                    "file:{digest}:{}:{}:{}",
                    file.path.display(),
                    file.scale,
                    file.collision
                );
                (key, mesh, Cow::Owned(bytes), None)
            }
        };
        let loaded = memo().lock().ok().and_then(|m| m.get(&key).cloned());
        let geometry = match loaded {
            Some(geometry) => geometry,
            None => {
                let cache = ShapeCache::default_location();
                let (shape, file_mass, visual) = if is_urdf(&mesh.path) {
                    let scale = mesh.scale[0];
                    let urdf = UrdfObject::load(&mesh.path, scale, &mesh.collision, field, &cache)?;
                    (urdf.shape, urdf.mass, urdf.visual)
                } else {
                    let shape = mesh.load_bytes(&bytes, field, &cache)?.shape;
                    let visual = match shipped {
                        Some(shipped) => shipped_visual(shipped, field)?,
                        None => mesh.visual(&bytes, field)?,
                    };
                    (shape, 0.0, Arc::new(visual))
                };
                let geometry = Arc::new(Geometry::of(shape, file_mass, visual, field)?);
                if let Ok(mut m) = memo().lock() {
                    m.insert(key, geometry.clone());
                }
                geometry
            }
        };
        let mass = mass.unwrap_or(if geometry.file_mass > 0.0 {
            geometry.file_mass
        } else {
            FILE_MASS
        });
        Ok(Arc::new(PickableObject {
            label: self.label(),
            geometry,
            mass,
            friction,
            rolling_damping,
        }))
    }
}

/// How a shipped object looks: its visual mesh in the shipped set's colours
/// (`assets/objects/objects.mtl`, compiled in).
fn shipped_visual(shipped: &ShippedObject, field: &str) -> Result<ObjectVisual> {
    let materials = |path: &std::path::Path| {
        if path.file_name().is_some_and(|n| n == "objects.mtl") {
            Ok(OBJECT_MATERIALS.to_vec())
        } else {
            Err(std::io::ErrorKind::NotFound.into())
        }
    };
    MeshFile::new(shipped.source()).visual_with(shipped.mesh, field, &materials)
}

/// The mesh a shipped object collides with: its convex parts where shipped, else its mesh
/// decomposed.
fn shipped_mesh(shipped: &ShippedObject) -> MeshFile {
    match shipped.collision {
        Some(_) => MeshFile {
            collision: MeshCollision::Parts,
            ..MeshFile::new(format!("assets/objects/{}_collision.obj", shipped.name))
        },
        None => MeshFile::new(shipped.source()),
    }
}

/// Loaded geometry, shared by every object built from the same file and settings.
fn memo() -> &'static Mutex<HashMap<String, Arc<Geometry>>> {
    static MEMO: OnceLock<Mutex<HashMap<String, Arc<Geometry>>>> = OnceLock::new();
    MEMO.get_or_init(Default::default)
}

/// What an object's shape decides: its convex parts, bounding box and grasp.
#[derive(Debug)]
pub(crate) struct Geometry {
    /// The collision shape, in the file's frame.
    pub(crate) shape: ObjectShape,
    /// Lowest and highest corners of its bounding box (object frame).
    pub(crate) low: Vector3<f64>,
    pub(crate) high: Vector3<f64>,
    /// The planned top-down grasp.
    pub(crate) grasp: TopGrasp,
    /// The mass the file gives (a URDF's), 0 where it gives none.
    pub(crate) file_mass: f64,
    /// How it looks.
    pub(crate) visual: Arc<ObjectVisual>,
}

impl Geometry {
    fn of(
        shape: ObjectShape,
        file_mass: f64,
        visual: Arc<ObjectVisual>,
        field: &str,
    ) -> Result<Self> {
        let (low, high) = shape.bounds();
        let grasp = shape.top_grasp(&GripperGeometry::PANDA)?.ok_or_else(|| {
            invalid(
                field,
                format!(
                    "the gripper cannot grasp it from above: it is {:.3} x {:.3} x {:.3} m and \
                     no part of it is narrower than the fingers open ({} m) where they can \
                     come down",
                    high.x - low.x,
                    high.y - low.y,
                    high.z - low.z,
                    GripperGeometry::PANDA.max_opening
                ),
            )
        })?;
        Ok(Self {
            shape,
            low,
            high,
            grasp,
            file_mass,
            visual,
        })
    }
}

/// One object of a set, loaded: its geometry with its mass and friction.
#[derive(Debug, Clone)]
pub(crate) struct PickableObject {
    /// The entry's label ([`ObjectEntry::label`]).
    pub(crate) label: String,
    pub(crate) geometry: Arc<Geometry>,
    pub(crate) mass: f64,
    pub(crate) friction: f64,
    pub(crate) rolling_damping: f64,
}

impl PickableObject {
    /// The centre of its bounding box (object frame): the point the goal is for.
    pub(crate) fn centre(&self) -> Vector3<f64> {
        (self.geometry.low + self.geometry.high) / 2.0
    }

    /// Half the bounding box's sides (m).
    pub(crate) fn half_extents(&self) -> Vector3<f64> {
        (self.geometry.high - self.geometry.low) / 2.0
    }
}

impl Serialize for ObjectEntry {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            ObjectEntry::Shipped(name) => serializer.serialize_str(name),
            ObjectEntry::File(file) => file.serialize(serializer),
        }
    }
}

impl<'de> Deserialize<'de> for ObjectEntry {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        let value = serde_json::Value::deserialize(deserializer)?;
        match value {
            serde_json::Value::String(s) => Ok(ObjectEntry::from_name(&s)),
            serde_json::Value::Object(_) => serde_json::from_value(value)
                .map(ObjectEntry::File)
                .map_err(|e| D::Error::custom(format!("an object file entry: {e}"))),
            other => Err(D::Error::custom(format!(
                "an object is a shipped object's name, a mesh file's path or a map \
                 {{\"path\": ..., \"mass\": ...}}, got {other}"
            ))),
        }
    }
}

impl ObjectEntry {
    /// The entry a string names: a file's path where it ends in `.obj`, `.stl`, `.dae` or
    /// `.urdf` (any case), else a shipped object's name.
    pub fn from_name(s: &str) -> Self {
        let lower = s.to_ascii_lowercase();
        if [".obj", ".stl", ".dae", ".urdf"]
            .iter()
            .any(|e| lower.ends_with(e))
        {
            ObjectEntry::File(ObjectFile {
                path: s.into(),
                ..ObjectFile::default()
            })
        } else {
            ObjectEntry::Shipped(s.into())
        }
    }
}
