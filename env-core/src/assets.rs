//! Bundled assets, compiled into the library so they are found wherever it is installed.

/// The bundled Franka Panda URDF (primitive collision shapes, no mesh files).
pub const PANDA_URDF: &str = include_str!("../../assets/panda/panda.urdf");

/// [`PANDA_URDF`] as error messages name it.
pub const PANDA_URDF_SOURCE: &str = "assets/panda/panda.urdf";

/// The shipped cabinet with one drawer (`assets/cabinet/cabinet.urdf`, made by
/// `scripts/make_cabinet.py`; every part a box, so it needs no mesh files).
pub const CABINET_URDF: &str = include_str!("../../assets/cabinet/cabinet.urdf");

/// Where [`CABINET_URDF`] comes from, for messages.
pub const CABINET_URDF_SOURCE: &str = "assets/cabinet/cabinet.urdf";

/// The tool centre points of the bundled robots' conventions, as (link, offset in m along
/// the link's z axis): a description with one of these links gets that TCP
/// ([`crate::model::RobotModel`]), any other its last link. The Panda's sits between the
/// fingertips, 0.1034 m from the hand.
pub const KNOWN_TCPS: &[(&str, f64)] = &[("panda_hand", 0.1034)];

/// One object of the shipped object set (`assets/objects`, made by `scripts/make_objects.py`;
/// see its README): its mesh (OBJ, metres, base on z = 0, centred on the z axis) and, for the
/// solid ones, its exact convex parts (`NAME_collision.obj`, one `o` block per hull).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShippedObject {
    /// Its name (`"mug"`): the stem of its files.
    pub name: &'static str,
    /// `NAME.obj`.
    pub mesh: &'static [u8],
    /// `NAME_collision.obj`, where shipped; the others (the hollow bowl and mug) are
    /// decomposed.
    pub collision: Option<&'static [u8]>,
}

impl ShippedObject {
    /// Where its mesh lies in the repository, as error messages name it.
    pub fn source(&self) -> String {
        format!("assets/objects/{}.obj", self.name)
    }
}

macro_rules! shipped {
    ($name:literal) => {
        ShippedObject {
            name: $name,
            mesh: include_bytes!(concat!("../../assets/objects/", $name, ".obj")),
            collision: None,
        }
    };
    ($name:literal, parts) => {
        ShippedObject {
            name: $name,
            mesh: include_bytes!(concat!("../../assets/objects/", $name, ".obj")),
            collision: Some(include_bytes!(concat!(
                "../../assets/objects/",
                $name,
                "_collision.obj"
            ))),
        }
    };
}

/// The shipped object set, compiled into the library (no files needed at run time).
pub const OBJECT_SET: &[ShippedObject] = &[
    shipped!("can", parts),
    shipped!("bottle", parts),
    shipped!("bowl"),
    shipped!("mug"),
    shipped!("banana", parts),
    shipped!("tennis_ball", parts),
    shipped!("block", parts),
    shipped!("hammer", parts),
    shipped!("screwdriver", parts),
    shipped!("pear", parts),
];

/// The shipped objects' colours (`assets/objects/objects.mtl`, the material library their
/// meshes name).
pub const OBJECT_MATERIALS: &[u8] = include_bytes!("../../assets/objects/objects.mtl");

/// The shipped object called `name`.
pub fn shipped_object(name: &str) -> Option<&'static ShippedObject> {
    OBJECT_SET.iter().find(|o| o.name == name)
}
