//! Everything specific to the Franka Panda, in one place: the bundled description's names and
//! the poses and offsets the rest of the crate uses when the robot is a Panda. Other robots
//! (any URDF through `RobotConfig::urdf`) get the generic fallbacks documented at each use.

use crate::model::RobotModel;

/// The bundled description ([`crate::assets::PANDA_URDF`]) as error messages name it.
pub const URDF_SOURCE: &str = crate::assets::PANDA_URDF_SOURCE;

/// The hand link, which carries the tool centre point...
pub const HAND_LINK: &str = crate::assets::KNOWN_TCPS[0].0;

/// ...this far (m) along the hand's z axis: the centre between the fingertips.
pub const TCP_OFFSET: f64 = crate::assets::KNOWN_TCPS[0].1;

/// The finger joint that drives the gripper (the second finger mimics it).
pub const FINGER_JOINT: &str = "panda_finger_joint1";

/// The first arm joint: a robot with it and [`READY`]'s length is taken for a Panda.
pub const FIRST_JOINT: &str = "panda_joint1";

/// The Panda's ready pose: hand pointing down above the work surface, gripper open (seven arm
/// joints in rad, then the driving finger joint in m).
pub const READY: [f64; 8] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785, 0.04];

/// Whether `model` is laid out like the Panda (its joint names and number of dofs), so its
/// Panda-specific defaults apply.
pub fn is_panda(model: &RobotModel) -> bool {
    model.num_dofs() == READY.len() && model.joint_index(FIRST_JOINT).is_ok()
}
