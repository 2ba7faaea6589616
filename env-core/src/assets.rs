//! Bundled assets, compiled into the library so they are found wherever it is installed.

/// The bundled Franka Panda URDF (primitive collision shapes, no mesh files).
pub const PANDA_URDF: &str = include_str!("../../assets/panda/panda.urdf");
