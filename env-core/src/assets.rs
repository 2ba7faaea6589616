//! Bundled assets, compiled into the library so they are found wherever it is installed.

/// The bundled Franka Panda URDF (primitive collision shapes, no mesh files).
pub const PANDA_URDF: &str = include_str!("../../assets/panda/panda.urdf");

/// [`PANDA_URDF`] as error messages name it.
pub const PANDA_URDF_SOURCE: &str = "assets/panda/panda.urdf";

/// The tool centre points of the bundled robots' conventions, as (link, offset in m along
/// the link's z axis): a description with one of these links gets that TCP
/// ([`crate::model::RobotModel`]), any other its last link. The Panda's sits between the
/// fingertips, 0.1034 m from the hand.
pub const KNOWN_TCPS: &[(&str, f64)] = &[("panda_hand", 0.1034)];
