//! The robot of an environment, without a world: the Panda's description, its arm fidelity, its
//! gripper, its start pose and the controller that turns actions into joint targets.
//!
//! Everything here is readable without building a physics world (the scripted policy and the
//! Python side ask these facts of a [`RobotSpec`], not of a [`crate::Simulation`]); what is
//! specific to the Franka Panda sits in [`panda`]. (Python's `panda_rapier.Robot` is another
//! object: a live handle on an environment's world, the robot side of [`crate::Simulation`].)

pub mod panda;

use nalgebra::{Isometry3, UnitQuaternion};

use crate::config::{ArmFidelity, SimConfig};
use crate::error::{Error, Result};
use crate::kinematics::pointing_down;
use crate::model::{JointType, RobotModel};

/// The gripper: the prismatic joint that drives the fingers and the joints that follow it.
#[derive(Debug, Clone, PartialEq)]
pub struct Gripper {
    /// The driving joint (index into [`RobotModel::joints`]).
    pub joint: usize,
    /// Its entry in the configuration `q`.
    pub dof: usize,
    /// The driving joint followed by the joints mimicking it: one per finger.
    pub finger_joints: Vec<usize>,
    /// Child link of each finger joint, in the same order.
    pub finger_links: Vec<usize>,
    /// The widest opening the fingers allow (m): the sum of the finger joints' upper limits.
    pub max_width: f64,
    /// Opening (m) per unit of the driving joint's position: the sum of the finger joints'
    /// gains on it (2 for the Panda, whose fingers move apart symmetrically).
    pub width_gain: f64,
}

impl Gripper {
    /// The gripper of `model`: driven by [`panda::FINGER_JOINT`] for the Panda, else by the
    /// first actuated prismatic joint that another joint mimics; `None` without one.
    pub fn of(model: &RobotModel) -> Option<Self> {
        let joint = model.joint_index(panda::FINGER_JOINT).ok().or_else(|| {
            model
                .joints()
                .iter()
                .filter(|j| j.joint_type == JointType::Prismatic && j.dof.is_some())
                .find(|j| {
                    model
                        .joints()
                        .iter()
                        .any(|o| o.mimic.is_some_and(|m| m.master == j.index))
                })
                .map(|j| j.index)
        })?;
        let dof = model.joints()[joint].dof?;
        let finger_joints: Vec<usize> = model
            .joints()
            .iter()
            .filter(|j| j.index == joint || j.mimic.is_some_and(|m| m.master == joint))
            .map(|j| j.index)
            .collect();
        let finger_links = finger_joints
            .iter()
            .map(|&j| model.joints()[j].child_link_index)
            .collect();
        let max_width = finger_joints.iter().map(|&j| model.joints()[j].upper).sum();
        let width_gain = finger_joints
            .iter()
            .filter_map(|&j| model.joint_driver(j).map(|(_, g)| g))
            .sum();
        Some(Self {
            joint,
            dof,
            finger_joints,
            finger_links,
            max_width,
            width_gain,
        })
    }

    /// Whether `link` is one of the fingers.
    pub fn is_finger(&self, link: usize) -> bool {
        self.finger_links.contains(&link)
    }
}

/// The robot of an environment, without a world: its description, how its arm is simulated,
/// where it stands, the configuration a reset puts it in, its gripper and the orientation `ee`
/// control holds the hand at. Built from [`SimConfig`] (the resolved `robot` and `arm`
/// options), as [`crate::ObjectSpec`] describes an object before a world holds it.
#[derive(Debug, Clone)]
pub struct RobotSpec {
    model: RobotModel,
    arm: ArmFidelity,
    base: Isometry3<f64>,
    start: Vec<f64>,
    gripper: Gripper,
    arm_dofs: Vec<usize>,
    movable_joints: Vec<usize>,
    hand_down: UnitQuaternion<f64>,
}

/// The name of [`RobotSpec`] before 0.2.
#[deprecated(
    since = "0.2.0",
    note = "renamed `RobotSpec` (Python's `Robot` is a live handle on a world, another object); \
            the old name is removed in 0.3.0"
)]
pub type Robot = RobotSpec;

impl RobotSpec {
    /// The robot `config` describes (the bundled Panda unless `robot.urdf` is set).
    pub fn new(config: &SimConfig) -> Result<Self> {
        Self::with_model(config, RobotModel::from_config(config)?)
    }

    /// The robot of `config` with an already loaded description. Manipulation needs a gripper:
    /// a robot without a prismatic finger joint is refused.
    pub fn with_model(config: &SimConfig, model: RobotModel) -> Result<Self> {
        config.validate()?;
        let gripper = Gripper::of(&model).ok_or_else(|| Error::InvalidConfig {
            field: "robot.urdf".into(),
            reason: "manipulation needs a robot with a prismatic gripper joint".into(),
        })?;
        let arm_dofs = (0..model.num_dofs())
            .filter(|&d| d != gripper.dof)
            .collect();
        let movable_joints = model
            .joints()
            .iter()
            .filter(|j| j.joint_type.is_movable())
            .map(|j| j.index)
            .collect();
        let start = start_configuration(config, &model)?;
        let base = base_pose(config);
        let hand_down = pointing_down(&model.tcp_pose(&start, &base)?.rotation);
        Ok(Self {
            model,
            arm: config.arm,
            base,
            start,
            gripper,
            arm_dofs,
            movable_joints,
            hand_down,
        })
    }

    /// The description (introspection, forward and inverse kinematics).
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// How the arm is simulated.
    pub fn arm_model(&self) -> ArmFidelity {
        self.arm
    }

    /// Pose of the robot's root link in the world.
    pub fn base_pose(&self) -> &Isometry3<f64> {
        &self.base
    }

    /// The configuration `q` a reset puts the robot in (before any joint noise), as the world
    /// reports it afterwards: `initial_configuration`, else the Panda's ready pose
    /// ([`panda::READY`]), else all zeros; clamped into the joint limits, and with the joints
    /// the physics engine integrates rounded to its `f32` (all of them for the dynamic arm, the
    /// gripper for the kinematic arm, whose placed joints keep `f64`).
    pub fn start_configuration(&self) -> &[f64] {
        &self.start
    }

    /// The gripper.
    pub fn gripper(&self) -> &Gripper {
        &self.gripper
    }

    /// The entries of `q` an action moves besides the gripper's, in order (the seven arm
    /// joints).
    pub fn arm_dofs(&self) -> &[usize] {
        &self.arm_dofs
    }

    /// Every joint that moves (actuated and mimic joints, e.g. both fingers), in joint order:
    /// the joints the observation reports.
    pub fn movable_joints(&self) -> &[usize] {
        &self.movable_joints
    }

    /// The orientation `ee` control holds the TCP at: the start pose's, turned to point
    /// straight down.
    pub fn hand_down(&self) -> &UnitQuaternion<f64> {
        &self.hand_down
    }

    /// Opening of the gripper asked for by a gripper command in `[-1, 1]` (m): -1 closed, +1
    /// fully open.
    pub fn gripper_width_for(&self, command: f64) -> f64 {
        (command + 1.0) / 2.0 * self.gripper.max_width
    }

    /// A gripper width as a fraction of the full opening, in `[0, 1]`.
    pub fn gripper_opening(&self, width: f64) -> f64 {
        let max = self.gripper.max_width;
        if max > 0.0 {
            (width / max).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// Where `config` puts the robot's root.
pub(crate) fn base_pose(config: &SimConfig) -> Isometry3<f64> {
    let [x, y, z] = config.robot.base;
    Isometry3::translation(x, y, z)
}

/// The configuration a fresh world is set to: `initial_configuration`, the Panda's ready pose,
/// or zeros (unclamped, unrounded); an `initial_configuration` of the wrong length is a
/// configuration error.
pub(crate) fn home_configuration(config: &SimConfig, model: &RobotModel) -> Result<Vec<f64>> {
    let q = match &config.robot.initial_configuration {
        Some(q) => q.clone(),
        None if panda::is_panda(model) => panda::READY.to_vec(),
        None => vec![0.0; model.num_dofs()],
    };
    if q.len() != model.num_dofs() {
        return Err(Error::InvalidConfig {
            field: "initial_configuration".into(),
            reason: format!(
                "must have {} values (one per actuated joint), got {}",
                model.num_dofs(),
                q.len()
            ),
        });
    }
    Ok(q)
}

/// [`RobotSpec::start_configuration`]: the home configuration as a world built from `config`
/// reports it.
fn start_configuration(config: &SimConfig, model: &RobotModel) -> Result<Vec<f64>> {
    let mut q = home_configuration(config, model)?;
    model.validate_configuration(&q)?;
    model.clamp_configuration(&mut q);
    let gripper = Gripper::of(model).map(|g| g.dof);
    for (dof, value) in q.iter_mut().enumerate() {
        // A fresh multibody's coordinates are 0, so setting one stores exactly its f32 value.
        if config.arm == ArmFidelity::Dynamic || Some(dof) == gripper {
            *value = *value as f32 as f64;
        }
    }
    Ok(q)
}
