//! What an episode is made of besides the observation: reset options, the step info, the
//! outcome of a step, and how an episode starts.

use nalgebra::{UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{ensure_len, Error, Result};
use crate::physics::ObjectId;
use crate::task::observation::{InfoValue, INFO_FIELDS};
use crate::task::reward::{RewardContext, RewardTerms};

/// Largest magnitude of a position a reset option may give (m): the observation's bound.
pub const MAX_POSITION: f64 = 1000.0;

/// Overrides for one reset (Gymnasium's `options`); anything left `None` is drawn at random.
/// The random draws happen either way, so an override does not shift the rest of the episode's
/// randomness.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ResetOptions {
    /// Start position of the cube's centre (m).
    pub cube_position: Option<[f64; 3]>,
    /// Start yaw of the cube (rad).
    pub cube_yaw: Option<f64>,
    /// Goal position for the cube's centre (m).
    pub goal: Option<[f64; 3]>,
    /// Start configuration of the robot (one value per actuated joint).
    pub joint_positions: Option<Vec<f64>>,
}

impl ResetOptions {
    /// Fails with [`Error::InvalidOption`] naming the first bad value.
    pub(crate) fn validate(&self, num_dofs: usize) -> Result<()> {
        self.check_values(num_dofs).map_err(|e| match e {
            Error::NonFinite { what, value } => Error::InvalidOption {
                what,
                reason: format!("must be finite, got {value}"),
            },
            Error::WrongLength {
                what,
                expected,
                got,
            } => Error::InvalidOption {
                what,
                reason: format!("must have {expected} values, got {got}"),
            },
            other => other,
        })
    }

    fn check_values(&self, num_dofs: usize) -> Result<()> {
        let check = |what: &str, values: &[f64]| crate::error::ensure_all_finite(what, values);
        // Positions also fit the observation: its entries are bounded by +-MAX_POSITION (and an
        // f64 beyond f32's range would become infinite there).
        let position = |what: &str, values: &[f64]| {
            check(what, values)?;
            match values.iter().position(|v| v.abs() > MAX_POSITION) {
                Some(i) => Err(Error::InvalidOption {
                    what: format!("{what}[{i}]"),
                    reason: format!("must be within +-{MAX_POSITION} m, got {}", values[i]),
                }),
                None => Ok(()),
            }
        };
        if let Some(p) = &self.cube_position {
            position("options.cube_position", p)?;
        }
        if let Some(y) = self.cube_yaw {
            check("options.cube_yaw", &[y])?;
        }
        if let Some(g) = &self.goal {
            position("options.goal", g)?;
        }
        if let Some(q) = &self.joint_positions {
            ensure_len("options.joint_positions", num_dofs, q.len())?;
            check("options.joint_positions", q)?;
        }
        Ok(())
    }
}

/// What a step or reset reports besides the observation (Gymnasium's `info`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepInfo {
    /// The cube is within the success threshold of the goal.
    pub is_success: bool,
    /// Both fingers squeeze the cube with at least the grasp force.
    pub is_grasped: bool,
    /// Grasped and touching neither the floor nor the platform.
    pub is_lifted: bool,
    /// Released, at rest, on the platform and within the threshold.
    pub is_placed: bool,
    /// The physics blew up in this step (non-finite state or runaway speeds): the episode is
    /// truncated and the observation is the last valid one.
    pub physics_unstable: bool,
    /// Distance from the cube to the goal (m).
    pub goal_distance: f64,
    /// Goal-free inputs of the reward (pass them back to `compute_reward`).
    pub context: RewardContext,
    /// The dense reward's weighted terms (zero for the sparse reward).
    pub terms: RewardTerms,
    /// Position error (m) the inverse kinematics left on the TCP target (`ee` control).
    pub ik_position_error: f64,
    /// Steps taken in this episode.
    pub elapsed_steps: u32,
    /// The kinematic arm ([`crate::ArmFidelity::Kinematic`]) refused part of this step's motion
    /// because a link would have entered the floor or the platform; always false for the
    /// dynamic arm.
    pub arm_blocked: bool,
}

impl StepInfo {
    /// Every entry, in [`INFO_FIELDS`] order (the info dict's keys).
    pub fn values(&self) -> [InfoValue; INFO_FIELDS.len()] {
        use InfoValue::{Bool, Float, Int};
        let (c, t) = (&self.context, &self.terms);
        [
            Bool(self.is_success),
            Bool(self.is_grasped),
            Bool(self.is_lifted),
            Bool(self.is_placed),
            Bool(self.physics_unstable),
            Float(self.goal_distance),
            Float(c.reach as f64),
            Float(c.grasp as f64),
            Float(c.lift as f64),
            Float(t.carry as f64),
            Float(t.place as f64),
            Float(t.release as f64),
            Float(c.gripper_opening as f64),
            Bool(c.cube_released),
            Bool(c.cube_at_rest),
            Bool(c.cube_on_platform),
            Float(self.ik_position_error),
            Bool(self.arm_blocked),
            Int(self.elapsed_steps as i64),
        ]
    }
}

/// The outcome of one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Transition {
    /// The reward.
    pub reward: f32,
    /// The episode ended by reaching the goal (only with `terminate_on_success`).
    pub terminated: bool,
    /// The episode was cut: time limit, or the physics blew up.
    pub truncated: bool,
    /// Everything else.
    pub info: StepInfo,
}

/// How one object starts an episode.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectStart {
    /// The object.
    pub object: ObjectId,
    /// Position of its centre (m).
    pub position: Vector3<f64>,
    /// Orientation.
    pub orientation: UnitQuaternion<f64>,
    /// Edge length (m), mass (kg) and friction for this episode, when randomised.
    pub properties: Option<(f64, f64, f64)>,
}

/// How an episode starts: where the objects go and the goal. A task fills it in
/// [`crate::task::Task::draw_episode`]; the environment applies it (properties, then the
/// robot, then object poses). Kept between resets, so resetting does not allocate.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EpisodeStart {
    /// The objects to place.
    pub objects: Vec<ObjectStart>,
    /// The goal (the task's `goal_dim` entries).
    pub goal: Vec<f64>,
}

/// A cube's edge length (m), mass (kg) and friction for one episode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CubeProperties {
    pub(crate) size: f64,
    pub(crate) mass: f64,
    pub(crate) friction: f64,
    /// Whether `randomization` gives any of them a range (the world is told only then).
    randomised: bool,
}

impl CubeProperties {
    /// The properties from three uniform draws in `[0, 1)`: each the configured value unless
    /// `randomization` gives it a range.
    pub(crate) fn draw(config: &crate::task::EnvConfig, u: [f64; 3]) -> Self {
        let pick = |range: Option<[f64; 2]>, default: f64, u: f64| {
            range.map_or(default, |r| r[0] + (r[1] - r[0]) * u)
        };
        let r = &config.randomization;
        let cube = &config.sim.cube;
        Self {
            size: pick(r.cube_size, cube.size, u[0]),
            mass: pick(r.cube_mass, cube.mass, u[1]),
            friction: pick(r.cube_friction, cube.friction, u[2]),
            randomised: r.cube_size.is_some() || r.cube_mass.is_some() || r.cube_friction.is_some(),
        }
    }

    /// The cube `object` with these properties, resting on the floor at `xy` (or at
    /// `position`, when given), turned to `orientation`.
    pub(crate) fn resting(
        &self,
        object: ObjectId,
        xy: [f64; 2],
        position: Option<[f64; 3]>,
        orientation: UnitQuaternion<f64>,
    ) -> ObjectStart {
        ObjectStart {
            object,
            position: position.map_or(Vector3::new(xy[0], xy[1], self.size / 2.0), Vector3::from),
            orientation,
            properties: self
                .randomised
                .then_some((self.size, self.mass, self.friction)),
        }
    }
}

impl EpisodeStart {
    /// Sets the objects and the goal (reusing the buffers: no allocation after the first
    /// episode).
    pub(crate) fn set(
        &mut self,
        objects: impl IntoIterator<Item = ObjectStart>,
        goal: impl IntoIterator<Item = f64>,
    ) {
        self.objects.clear();
        self.objects.extend(objects);
        self.goal.clear();
        self.goal.extend(goal);
    }
}

/// Where the cube tasks' cubes start by default: on the floor in front of the robot, clear of
/// the platform.
pub(crate) const CUBE_REGION: crate::task::config::Region = crate::task::config::Region {
    low: [0.4, -0.2],
    high: [0.6, 0.0],
};

/// The cube tasks' default range of start yaws (rad).
pub(crate) const CUBE_YAW_RANGE: crate::task::config::Range = [-0.25, 0.25];

/// A cube's start orientation: the yaw `options.cube_yaw`, else a uniform draw `u` across
/// `yaw_range`.
pub(crate) fn cube_orientation(
    yaw_range: crate::task::config::Range,
    u: f64,
    options: &ResetOptions,
) -> UnitQuaternion<f64> {
    let [low, high] = yaw_range;
    let yaw = options.cube_yaw.unwrap_or(low + (high - low) * u);
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw)
}
