//! The observation and info schema: one definition that the environment writes by, and that
//! Python (through `_native`) builds its spaces, dict splitting and reward contexts from.
//!
//! An observation is one flat `f32` vector `[achieved_goal, desired_goal, observation]`, the
//! order in which Gymnasium's `spaces.flatten` lays out the goal dict (keys sorted), so
//! flattening the dict gives exactly the flat layout. `observation` holds the robot's slots
//! ([`ROBOT_SLOTS`], the same for every task) followed by the task's own
//! ([`crate::task::Task::observation_slots`]). All positions and velocities are in the world
//! frame (m, m/s, rad, rad/s). The pick-and-place table, with indices, is in
//! [`crate::task::pick_and_place`].

use std::ops::Range;

/// One named slot of the observation, as a task or the robot declares it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlotSpec {
    /// The slot's name.
    pub name: &'static str,
    /// Number of entries; `None`: one per moving joint of the robot.
    pub size: Option<usize>,
    /// What it holds, with units.
    pub description: &'static str,
}

/// The robot's slots at the start of `observation`, the same for every task. Indices into
/// this table name them in [`ObservationLayout::robot_slot`].
pub const ROBOT_SLOTS: [SlotSpec; 5] = [
    SlotSpec {
        name: "joint_positions",
        size: None,
        description: "moving joints (rad; m for the fingers): arm joints 1-7, finger joints 1-2",
    },
    SlotSpec {
        name: "joint_velocities",
        size: None,
        description: "their velocities",
    },
    SlotSpec {
        name: "tcp_position",
        size: Some(3),
        description: "tool centre point (between the fingertips)",
    },
    SlotSpec {
        name: "tcp_velocity",
        size: Some(3),
        description: "its linear velocity",
    },
    SlotSpec {
        name: "gripper_width",
        size: Some(1),
        description: "opening between the finger pads (m)",
    },
];

/// Index of `joint_positions` in [`ROBOT_SLOTS`].
pub const JOINT_POSITIONS: usize = 0;
/// Index of `joint_velocities` in [`ROBOT_SLOTS`].
pub const JOINT_VELOCITIES: usize = 1;
/// Index of `tcp_position` in [`ROBOT_SLOTS`].
pub const TCP_POSITION: usize = 2;
/// Index of `tcp_velocity` in [`ROBOT_SLOTS`].
pub const TCP_VELOCITY: usize = 3;
/// Index of `gripper_width` in [`ROBOT_SLOTS`].
pub const GRIPPER_WIDTH: usize = 4;

/// The goal dict's keys, in flat order.
pub const DICT_KEYS: [&str; 3] = ["achieved_goal", "desired_goal", "observation"];

/// Whose state a slot reports: what a policy may see without privileged state is the robot's
/// own (its proprioception) and the commanded goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlotSource {
    /// A goal of the goal dict (`achieved_goal`: the simulator's object state; `desired_goal`:
    /// the command).
    Goal,
    /// The robot's own state ([`ROBOT_SLOTS`]): joint encoders and what follows from them.
    Robot,
    /// The task's objects (cube poses and velocities): privileged simulator state.
    Task,
}

impl SlotSource {
    /// Its name in the Python schema (`goal`, `robot`, `task`).
    pub fn as_str(self) -> &'static str {
        match self {
            SlotSource::Goal => "goal",
            SlotSource::Robot => "robot",
            SlotSource::Task => "task",
        }
    }
}

/// One slot with its place in the flat vector.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Slot {
    /// The slot's name (`achieved_goal`, `desired_goal`, or a name from [`ROBOT_SLOTS`] or the
    /// task's slots).
    pub name: &'static str,
    /// The goal-dict entry it belongs to (one of [`DICT_KEYS`]).
    pub key: &'static str,
    /// Indices in the flat vector.
    pub range: Range<usize>,
    /// What it holds.
    pub description: &'static str,
    /// Whose state it reports.
    pub source: SlotSource,
}

/// Where everything sits in the flat observation of one task on one robot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ObservationLayout {
    num_joints: usize,
    goal_dim: usize,
    /// Goals, then [`ROBOT_SLOTS`], then the task's slots.
    slots: Vec<Slot>,
}

impl ObservationLayout {
    /// The layout for a robot with `num_joints` moving joints (9 for the Panda) and a task with
    /// goals of `goal_dim` entries and its own `task_slots`.
    pub fn new(
        num_joints: usize,
        goal_dim: usize,
        goal_description: [&'static str; 2],
        task_slots: &[SlotSpec],
    ) -> Self {
        let mut slots = vec![
            Slot {
                name: DICT_KEYS[0],
                key: DICT_KEYS[0],
                range: 0..goal_dim,
                description: goal_description[0],
                source: SlotSource::Goal,
            },
            Slot {
                name: DICT_KEYS[1],
                key: DICT_KEYS[1],
                range: goal_dim..2 * goal_dim,
                description: goal_description[1],
                source: SlotSource::Goal,
            },
        ];
        let mut start = 2 * goal_dim;
        let sourced = ROBOT_SLOTS
            .iter()
            .map(|spec| (spec, SlotSource::Robot))
            .chain(task_slots.iter().map(|spec| (spec, SlotSource::Task)));
        for (spec, source) in sourced {
            let n = spec.size.unwrap_or(num_joints);
            slots.push(Slot {
                name: spec.name,
                key: DICT_KEYS[2],
                range: start..start + n,
                description: spec.description,
                source,
            });
            start += n;
        }
        Self {
            num_joints,
            goal_dim,
            slots,
        }
    }

    /// Number of moving joints reported.
    pub fn num_joints(&self) -> usize {
        self.num_joints
    }

    /// Length of each goal.
    pub fn goal_dim(&self) -> usize {
        self.goal_dim
    }

    /// Length of the `observation` entry of the dict.
    pub fn observation_dim(&self) -> usize {
        self.flat_dim() - 2 * self.goal_dim
    }

    /// Length of the flat vector: both goals and the observation.
    pub fn flat_dim(&self) -> usize {
        self.slots.last().map_or(0, |s| s.range.end)
    }

    /// `achieved_goal` in the flat vector.
    pub fn achieved_goal(&self) -> Range<usize> {
        0..self.goal_dim
    }

    /// `desired_goal` in the flat vector.
    pub fn desired_goal(&self) -> Range<usize> {
        self.goal_dim..2 * self.goal_dim
    }

    /// `observation` in the flat vector.
    pub fn observation(&self) -> Range<usize> {
        2 * self.goal_dim..self.flat_dim()
    }

    /// The range of the robot's slot `index` ([`ROBOT_SLOTS`], e.g. [`TCP_POSITION`]).
    pub fn robot_slot(&self, index: usize) -> Range<usize> {
        self.slots[2 + index].range.clone()
    }

    /// The range of the task's slot `index` (its position in the task's
    /// [`crate::task::Task::observation_slots`]).
    pub fn task_slot(&self, index: usize) -> Range<usize> {
        self.slots[2 + ROBOT_SLOTS.len() + index].range.clone()
    }

    /// Where the task's slots sit together in the flat vector (empty for a task without any).
    pub fn task_slots(&self) -> Range<usize> {
        self.robot_slot(ROBOT_SLOTS.len() - 1).end..self.flat_dim()
    }

    /// Every slot with its range in the flat vector, in order.
    pub fn slots(&self) -> &[Slot] {
        &self.slots
    }

    /// The range of the slot called `name` in the flat vector.
    pub fn slot(&self, name: &str) -> Option<Range<usize>> {
        self.slots
            .iter()
            .find(|s| s.name == name)
            .map(|s| s.range.clone())
    }
}

/// The type of an info entry, as Python sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InfoType {
    /// A flag (`bool`, numpy `bool`).
    Bool,
    /// A number (`float`, numpy `float64`).
    Float,
    /// A count (`int`, numpy `int64`).
    Int,
}

impl InfoType {
    /// The numpy dtype name.
    pub fn as_str(self) -> &'static str {
        match self {
            InfoType::Bool => "bool",
            InfoType::Float => "float64",
            InfoType::Int => "int64",
        }
    }
}

/// One value of the step info.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InfoValue {
    /// An [`InfoType::Bool`] entry.
    Bool(bool),
    /// An [`InfoType::Float`] entry.
    Float(f64),
    /// An [`InfoType::Int`] entry.
    Int(i64),
}

/// One entry of the step info.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InfoField {
    /// The info dict's key.
    pub key: &'static str,
    /// Its type.
    pub dtype: InfoType,
    /// What it means.
    pub description: &'static str,
}

/// An info entry (for the `const` lists of [`COMMON_INFO_FIELDS`] and each task's
/// [`TaskDescriptor::info_fields`](crate::task::TaskDescriptor::info_fields)).
pub const fn info_field(
    key: &'static str,
    dtype: InfoType,
    description: &'static str,
) -> InfoField {
    InfoField {
        key,
        dtype,
        description,
    }
}

/// The info entries of every task, in the order [`crate::task::StepInfo::entries`] gives
/// them; each task's own entries follow
/// ([`TaskDescriptor::info_fields`](crate::task::TaskDescriptor::info_fields)).
pub const COMMON_INFO_FIELDS: [InfoField; 7] = [
    info_field(
        "is_success",
        InfoType::Bool,
        "the task's success predicate holds",
    ),
    info_field(
        "physics_unstable",
        InfoType::Bool,
        "the physics blew up in this step (the episode is truncated)",
    ),
    info_field(
        "goal_distance",
        InfoType::Float,
        "distance from the achieved to the desired goal (m; in flip the angle between the orientations, rad)",
    ),
    info_field(
        "gripper_opening",
        InfoType::Float,
        "gripper opening the last action commanded (0 closed, 1 open)",
    ),
    info_field(
        "ik_position_error",
        InfoType::Float,
        "position error (m) the inverse kinematics left (`ee` control)",
    ),
    info_field(
        "arm_blocked",
        InfoType::Bool,
        "the kinematic arm refused part of this step's motion",
    ),
    info_field(
        "elapsed_steps",
        InfoType::Int,
        "steps taken in this episode",
    ),
];

/// Checks that every slot of `task`'s layout for the Panda (9 moving joints) appears, with its
/// flat range, in the observation table of the task's source file `source`, and that the flat
/// vector has `flat_dim` entries.
#[cfg(test)]
pub(crate) fn assert_documented_layout(
    task: &dyn crate::task::Task,
    source: &str,
    flat_dim: usize,
) {
    let layout = ObservationLayout::new(
        9,
        task.goal_dim(),
        task.goal_descriptions(),
        task.observation_slots(),
    );
    assert_eq!(layout.flat_dim(), flat_dim);
    for slot in layout.slots() {
        let range = if slot.range.len() == 1 {
            format!("| {} |", slot.range.start)
        } else {
            format!("| {}..{} |", slot.range.start, slot.range.end)
        };
        let row = source
            .lines()
            .find(|l| l.contains(&format!("`{}` | {} |", slot.name, slot.range.len())))
            .unwrap_or_else(|| panic!("no table row for {}", slot.name));
        assert!(
            row.contains(&range),
            "{}: row {row:?} lacks {range}",
            slot.name
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_contiguous_and_cover_the_flat_vector() {
        let task = [SlotSpec {
            name: "extra",
            size: Some(2),
            description: "",
        }];
        let layout = ObservationLayout::new(9, 3, ["", ""], &task);
        let mut next = 0;
        for slot in layout.slots() {
            assert_eq!(slot.range.start, next, "{} is not contiguous", slot.name);
            next = slot.range.end;
        }
        assert_eq!(next, layout.flat_dim());
        assert_eq!(layout.observation_dim(), 9 + 9 + 3 + 3 + 1 + 2);
        assert_eq!(layout.task_slot(0), layout.slot("extra").unwrap());
        assert_eq!(
            layout.robot_slot(TCP_POSITION),
            layout.slot("tcp_position").unwrap()
        );
        // Goals, then the robot's own slots, then the task's: each source together.
        let sources: Vec<_> = layout.slots().iter().map(|s| s.source).collect();
        let mut expected = vec![SlotSource::Goal; 2];
        expected.extend([SlotSource::Robot; ROBOT_SLOTS.len()]);
        expected.push(SlotSource::Task);
        assert_eq!(sources, expected);
        assert_eq!(
            [SlotSource::Goal, SlotSource::Robot, SlotSource::Task].map(SlotSource::as_str),
            ["goal", "robot", "task"]
        );
    }

    #[test]
    fn every_task_s_info_keys_are_unique_and_hold_its_reward_context_and_terms() {
        for &task in crate::task::TaskKind::ALL {
            let d = task.descriptor();
            let fields: Vec<_> = COMMON_INFO_FIELDS.iter().chain(d.info_fields).collect();
            for (i, f) in fields.iter().enumerate() {
                assert!(
                    fields[..i].iter().all(|g| g.key != f.key),
                    "{task}: {} twice",
                    f.key
                );
            }
            assert!(d.info_fields.len() <= crate::task::episode::TASK_INFO_CAPACITY);
            for key in d.reward_context_keys {
                assert!(fields.iter().any(|f| f.key == *key), "{task}: {key}");
            }
            for term in d.reward_terms {
                let field = fields.iter().find(|f| f.key == term.info_key);
                assert!(
                    matches!(field, Some(f) if f.dtype == InfoType::Float),
                    "{task}: {}",
                    term.info_key
                );
            }
        }
    }
}
