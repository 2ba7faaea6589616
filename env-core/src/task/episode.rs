//! What an episode is made of besides the observation: reset options, the step info, the
//! outcome of a step, and how an episode starts.

use nalgebra::{UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{ensure_len, Error, Result};
use crate::physics::ObjectId;
use crate::task::observation::{InfoField, InfoType, InfoValue, COMMON_INFO_FIELDS};

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
    /// The goal: a position for the cube's centre (m), or in `flip` the goal orientation as a
    /// rotation vector (axis times angle, rad).
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

/// Most info entries a task may declare besides the common ones.
pub const TASK_INFO_CAPACITY: usize = 16;

/// A task's own info entries ([`TaskDescriptor::info_fields`](crate::task::TaskDescriptor)):
/// the fields and their values, stored without allocating (flags as 0 or 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskInfo {
    fields: &'static [InfoField],
    values: [f64; TASK_INFO_CAPACITY],
}

impl Default for TaskInfo {
    fn default() -> Self {
        Self::new(&[])
    }
}

impl TaskInfo {
    /// Entries `fields`, all 0 / false.
    pub fn new(fields: &'static [InfoField]) -> Self {
        debug_assert!(fields.len() <= TASK_INFO_CAPACITY);
        Self {
            fields,
            values: [0.0; TASK_INFO_CAPACITY],
        }
    }

    /// Sets the entry `key` (a field of the task; others are ignored, and a debug build
    /// panics, so a contract test catches a misspelt key).
    pub fn set(&mut self, key: &str, value: impl Into<InfoValue>) {
        match self.fields.iter().position(|f| f.key == key) {
            Some(i) => self.set_at(i, value),
            None => debug_assert!(false, "no info field {key:?}"),
        }
    }

    /// Sets the `i`-th field's entry (out of range: ignored, and a debug build panics).
    pub fn set_at(&mut self, i: usize, value: impl Into<InfoValue>) {
        match self.values.get_mut(i) {
            Some(slot) if i < self.fields.len() => {
                *slot = match value.into() {
                    InfoValue::Bool(b) => f64::from(u8::from(b)),
                    InfoValue::Float(x) => x,
                    InfoValue::Int(n) => n as f64,
                }
            }
            _ => debug_assert!(false, "no info field {i}"),
        }
    }

    /// The task's fields.
    pub fn fields(&self) -> &'static [InfoField] {
        self.fields
    }

    /// The entry `key`, typed as its field says, if the task has it.
    pub fn get(&self, key: &str) -> Option<InfoValue> {
        let i = self.fields.iter().position(|f| f.key == key)?;
        Some(self.value(i))
    }

    fn value(&self, i: usize) -> InfoValue {
        let v = self.values[i];
        match self.fields[i].dtype {
            InfoType::Bool => InfoValue::Bool(v != 0.0),
            InfoType::Float => InfoValue::Float(v),
            InfoType::Int => InfoValue::Int(v as i64),
        }
    }

    /// Every entry, in field order.
    pub fn entries(&self) -> impl Iterator<Item = (&'static InfoField, InfoValue)> + '_ {
        self.fields
            .iter()
            .enumerate()
            .map(|(i, f)| (f, self.value(i)))
    }
}

impl From<bool> for InfoValue {
    fn from(v: bool) -> Self {
        InfoValue::Bool(v)
    }
}

impl From<f64> for InfoValue {
    fn from(v: f64) -> Self {
        InfoValue::Float(v)
    }
}

impl From<f32> for InfoValue {
    fn from(v: f32) -> Self {
        InfoValue::Float(v as f64)
    }
}

/// What a step or reset reports besides the observation (Gymnasium's `info`): the entries of
/// every task ([`COMMON_INFO_FIELDS`]) and the task's own ([`TaskInfo`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepInfo {
    /// The task's success predicate holds.
    pub is_success: bool,
    /// The physics blew up in this step (non-finite state or runaway speeds): the episode is
    /// truncated and the observation is the last valid one.
    pub physics_unstable: bool,
    /// Distance from the achieved to the desired goal (m).
    pub goal_distance: f64,
    /// The gripper opening the last action commanded, from 0 (closed) to 1 (fully open); at
    /// reset, the measured opening.
    pub gripper_opening: f32,
    /// Position error (m) the inverse kinematics left on the TCP target (`ee` control).
    pub ik_position_error: f64,
    /// The kinematic arm ([`crate::ArmFidelity::Kinematic`]) refused part of this step's motion
    /// because a link would have entered the floor or the platform; always false for the
    /// dynamic arm.
    pub arm_blocked: bool,
    /// Steps taken in this episode.
    pub elapsed_steps: u32,
    /// The task's own entries: its predicates, reward terms and reward inputs.
    pub task: TaskInfo,
}

impl StepInfo {
    /// The common entries, in [`COMMON_INFO_FIELDS`] order.
    pub fn common_values(&self) -> [InfoValue; COMMON_INFO_FIELDS.len()] {
        use InfoValue::{Bool, Float, Int};
        [
            Bool(self.is_success),
            Bool(self.physics_unstable),
            Float(self.goal_distance),
            Float(self.gripper_opening as f64),
            Float(self.ik_position_error),
            Bool(self.arm_blocked),
            Int(self.elapsed_steps as i64),
        ]
    }

    /// Every entry with its field: the common ones, then the task's (the info dict).
    pub fn entries(&self) -> impl Iterator<Item = (&'static InfoField, InfoValue)> + '_ {
        COMMON_INFO_FIELDS
            .iter()
            .zip(self.common_values())
            .chain(self.task.entries())
    }

    /// The entry `key`, if the task reports it.
    pub fn get(&self, key: &str) -> Option<InfoValue> {
        match COMMON_INFO_FIELDS.iter().position(|f| f.key == key) {
            Some(i) => Some(self.common_values()[i]),
            None => self.task.get(key),
        }
    }

    /// The flag `key`: false if the task does not report it.
    pub fn flag(&self, key: &str) -> bool {
        matches!(self.get(key), Some(InfoValue::Bool(true)))
    }

    /// The number `key` (a float, or a flag as 0 or 1): 0 if the task does not report it.
    pub fn number(&self, key: &str) -> f64 {
        match self.get(key) {
            Some(InfoValue::Bool(b)) => f64::from(u8::from(b)),
            Some(InfoValue::Float(x)) => x,
            Some(InfoValue::Int(n)) => n as f64,
            None => 0.0,
        }
    }

    /// This step's reward-context row for `keys` (the task's `reward_context_keys`), as
    /// `compute_reward` takes it back.
    pub fn reward_context(&self, keys: &[&str], out: &mut [f32]) {
        for (o, key) in out.iter_mut().zip(keys) {
            *o = self.number(key) as f32;
        }
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
    /// Its shape for this episode, where the task draws it (peg insertion's peg and hole).
    pub shape: Option<crate::physics::ObjectShape>,
    /// Which of a task's objects it is this episode, with that object's mass and friction,
    /// where the task draws it from a set (pick-object's); the world keeps the index
    /// ([`crate::physics::Simulation::object_variant`]).
    pub variant: Option<ObjectVariant>,
}

/// How one articulated object starts an episode.
#[derive(Debug, Clone, PartialEq)]
pub struct ArticulationStart {
    /// The object.
    pub articulation: crate::physics::ArticulationId,
    /// Its root link's pose (world frame).
    pub pose: nalgebra::Isometry3<f64>,
    /// Its joint positions (one per movable non-mimic joint, in its model's dof order).
    pub joint_positions: Vec<f64>,
}

/// Which of a task's set of objects an object is for one episode, and its mass and friction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectVariant {
    /// Its index in the task's set.
    pub index: u32,
    /// Mass (kg).
    pub mass: f64,
    /// Friction coefficient.
    pub friction: f64,
    /// Angular damping of its body (1/s), for the rolling resistance rapier lacks.
    pub rolling_damping: f64,
}

/// How an episode starts: where the objects go and the goal. A task fills it in
/// [`crate::task::Task::draw_episode`]; the environment applies it (properties, then the
/// robot, then object poses). Kept between resets, so resetting does not allocate.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EpisodeStart {
    /// The objects to place.
    pub objects: Vec<ObjectStart>,
    /// The articulated objects to place (their roots' poses and joint positions).
    pub articulations: Vec<ArticulationStart>,
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
    pub(crate) fn draw(
        cube: &crate::config::CubeConfig,
        r: &crate::task::config::Randomization,
        u: [f64; 3],
    ) -> Self {
        let pick = |range: Option<[f64; 2]>, default: f64, u: f64| {
            range.map_or(default, |r| r[0] + (r[1] - r[0]) * u)
        };
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
            shape: None,
            variant: None,
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

    /// Sets the articulated objects' starts, each its id, root pose and joint positions (after
    /// [`EpisodeStart::set`], which leaves them), into the kept buffers: no allocation after the
    /// first episode.
    pub(crate) fn set_articulations<'a>(
        &mut self,
        articulations: impl IntoIterator<
            Item = (
                crate::physics::ArticulationId,
                nalgebra::Isometry3<f64>,
                &'a [f64],
            ),
        >,
    ) {
        let mut n = 0;
        for (articulation, pose, q) in articulations {
            if n == self.articulations.len() {
                self.articulations.push(ArticulationStart {
                    articulation,
                    pose,
                    joint_positions: Vec::new(),
                });
            }
            let start = &mut self.articulations[n];
            start.articulation = articulation;
            start.pose = pose;
            start.joint_positions.clear();
            start.joint_positions.extend_from_slice(q);
            n += 1;
        }
        self.articulations.truncate(n);
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

/// Where the platform tasks draw their goals by default: on the platform's top.
pub(crate) const PLATFORM_GOAL_REGION: crate::task::config::Region = crate::task::config::Region {
    low: [0.42, 0.22],
    high: [0.58, 0.38],
};

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
