//! The one list of tasks. Adding a task is a file in `task/` whose type implements [`Task`]
//! and [`TaskSpec`] (its descriptor, its own configuration section with defaults and
//! validation, how it is built) and one line in the `tasks!` invocation below; the
//! [`TaskKind`] enum, the tagged [`TaskConfig`] section of the environment's configuration
//! ([`EnvConfig`](crate::env::EnvConfig)), building a task, the legacy keys and terms the
//! configuration reader migrates, the Python ids and their episode lengths, the docs tables and the contract tests all come from
//! here.

use std::fmt;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::context::TaskContext;
use super::observation::InfoField;
use super::reward::RewardTerm;
use super::Task;
use crate::config::{CubeConfig, PlatformConfig};
use crate::error::Result;

/// The static facts of a task, the same for every configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskDescriptor {
    /// The name in configurations and on the command line (`"pick_and_place"`).
    pub name: &'static str,
    /// The stem of its Gymnasium ids (`"PickAndPlace"` gives `panda_rapier/PickAndPlace-v0`,
    /// `PickAndPlaceJoints-v0`, ...).
    pub id_stem: &'static str,
    /// Steps of a registered id's episode (Gymnasium's `TimeLimit`): long enough for the
    /// scripted expert in both action modes.
    pub episode_steps: u32,
    /// Whether its scene has the platform (what [`Task::build_scene`] builds; a contract test holds
    /// the two together). `ee` targets keep clear of the platform's top only where it exists.
    pub has_platform: bool,
    /// One line for tables and `--help`.
    pub summary: &'static str,
    /// The task's own info entries, after every task's
    /// ([`COMMON_INFO_FIELDS`](super::observation::COMMON_INFO_FIELDS)): its predicates
    /// (`is_placed` where the task has a "placed" predicate, which evaluations report), its
    /// reward terms (`reward_<term>`) and its reward's inputs.
    pub info_fields: &'static [InfoField],
    /// The dense reward's terms with their default weights; `reward_weights` overrides them
    /// by name, and names no other.
    pub reward_terms: &'static [RewardTerm],
    /// The info keys `compute_reward` reads back, in the order [`Task::compute_rewards`]
    /// takes them (empty when the reward depends on the goals alone).
    pub reward_context_keys: &'static [&'static str],
}

impl TaskDescriptor {
    /// Whether the task has a "placed" predicate (an `is_placed` info entry).
    pub fn has_placed(&self) -> bool {
        self.info_fields.iter().any(|f| f.key == "is_placed")
    }
}

/// The static side of a task: what the registry needs to list, configure and build it.
pub trait TaskSpec: Task + Sized + 'static {
    /// The task's own section of the configuration (`{"task": {"name": ..., <fields>}}`): its
    /// regions, ranges and objects. Every field has a default; unknown fields are errors.
    type Config: Default
        + Clone
        + PartialEq
        + fmt::Debug
        + Serialize
        + DeserializeOwned
        + Send
        + Sync;

    /// The task's static facts.
    const DESCRIPTOR: TaskDescriptor;

    /// Top-level keys of configurations before 0.2 that now live in the task's section, as
    /// `(old key, field of the section)`: read with a deprecation warning until 0.3.
    const LEGACY_KEYS: &'static [(&'static str, &'static str)] = &[];

    /// Terms the task's reward gained after 0.2 under a name every task took before 0.2: a
    /// configuration dumped before 0.2 (it holds all six of the staged reward's weights)
    /// carries them with a weight that did nothing then, so the reader drops them (with a
    /// note) and the term's default applies.
    const TERMS_ADDED_AFTER_0_2: &'static [&'static str] = &[];

    /// The joint action scale (`joint_step`, rad per step at action 1.0) of the task's
    /// `joints` ids where it differs from the default: a task whose expert needs the hand
    /// faster than 0.05 rad per step moves it.
    const ID_JOINT_STEP: Option<f64> = None;

    /// Whether the task's end-effector ids (`<Stem>-v0`, `<Stem>Dense-v0`) take `ee_pose`
    /// actions instead of `ee`: a task whose hand must turn.
    const ID_POSE_ACTIONS: bool = false;

    /// Checks `section` (with the options of `context` it depends on); errors name the field
    /// as `task.<field>`. (The section's cube and platform are checked before this is called.)
    fn validate(section: &Self::Config, context: &TaskContext) -> Result<()>;

    /// The section's cube (its `cube` field), for tasks that move one: the size, mass and
    /// friction every cube of the task starts from (`randomization` may draw them instead).
    fn cube(_section: &Self::Config) -> Option<&CubeConfig> {
        None
    }

    /// The section's platform (its `platform` field), for tasks whose scene has one.
    fn platform(_section: &Self::Config) -> Option<&PlatformConfig> {
        None
    }

    /// The task as `section` and `context` set it up.
    fn build(section: &Self::Config, context: &TaskContext) -> Self;
}

macro_rules! tasks {
    ($($variant:ident => $task:ty),* $(,)?) => {
        /// Which task an environment runs (one variant per registered task, in the order of
        /// the registry).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
        pub enum TaskKind {
            #[default]
            $(
                #[doc = concat!("[`", stringify!($task), "`].")]
                $variant
            ),*
        }

        impl TaskKind {
            /// Every task, in the order of the registry.
            pub const ALL: &'static [TaskKind] = &[$(TaskKind::$variant),*];

            /// The task's static facts.
            pub fn descriptor(self) -> &'static TaskDescriptor {
                match self {
                    $(TaskKind::$variant => &<$task as TaskSpec>::DESCRIPTOR),*
                }
            }

            /// The `joint_step` of the task's `joints` ids, where it differs from the default
            /// ([`TaskSpec::ID_JOINT_STEP`]).
            pub fn id_joint_step(self) -> Option<f64> {
                match self {
                    $(TaskKind::$variant => <$task as TaskSpec>::ID_JOINT_STEP),*
                }
            }

            /// Whether the task's end-effector ids take `ee_pose` actions
            /// ([`TaskSpec::ID_POSE_ACTIONS`]).
            pub fn id_pose_actions(self) -> bool {
                match self {
                    $(TaskKind::$variant => <$task as TaskSpec>::ID_POSE_ACTIONS),*
                }
            }

            /// Top-level keys from before 0.2 that now live in the task's section
            /// ([`TaskSpec::LEGACY_KEYS`]).
            pub fn legacy_keys(self) -> &'static [(&'static str, &'static str)] {
                match self {
                    $(TaskKind::$variant => <$task as TaskSpec>::LEGACY_KEYS),*
                }
            }

            /// Reward terms the task gained after 0.2 ([`TaskSpec::TERMS_ADDED_AFTER_0_2`]).
            pub fn terms_added_after_0_2(self) -> &'static [&'static str] {
                match self {
                    $(TaskKind::$variant => <$task as TaskSpec>::TERMS_ADDED_AFTER_0_2),*
                }
            }
        }

        /// The task section of the environment's configuration
        /// ([`EnvConfig`](crate::env::EnvConfig)): which task, with its own configuration. In
        /// JSON, `{"name": "reach", "goal_region": ...}` (fields left out take their
        /// defaults), or just the name, `"reach"`, for the defaults.
        #[derive(Debug, Clone, PartialEq)]
        pub enum TaskConfig {
            $(
                #[doc = concat!("The section of [`", stringify!($task), "`].")]
                $variant(<$task as TaskSpec>::Config)
            ),*
        }

        impl TaskConfig {
            /// Which task the section configures.
            pub fn kind(&self) -> TaskKind {
                match self {
                    $(TaskConfig::$variant(_) => TaskKind::$variant),*
                }
            }

            /// The section of `kind` with its defaults.
            pub fn defaults(kind: TaskKind) -> Self {
                match kind {
                    $(TaskKind::$variant => TaskConfig::$variant(Default::default())),*
                }
            }

            /// The section's cube, for tasks that move one.
            pub fn cube(&self) -> Option<&CubeConfig> {
                match self {
                    $(TaskConfig::$variant(section) => <$task as TaskSpec>::cube(section)),*
                }
            }

            /// The section's platform, for tasks whose scene has one.
            pub fn platform(&self) -> Option<&PlatformConfig> {
                match self {
                    $(TaskConfig::$variant(section) => <$task as TaskSpec>::platform(section)),*
                }
            }

            /// Checks the section (its cube and platform first), with the options of
            /// `context` it depends on.
            pub fn validate(&self, context: &TaskContext) -> Result<()> {
                if let Some(cube) = self.cube() {
                    cube.validate("task.cube")?;
                }
                if let Some(platform) = self.platform() {
                    platform.validate("task.platform")?;
                }
                match self {
                    $(TaskConfig::$variant(section) => <$task as TaskSpec>::validate(section, context)),*
                }
            }

            /// Builds the task from the section and `context`.
            pub fn build(&self, context: &TaskContext) -> Box<dyn Task> {
                match self {
                    $(TaskConfig::$variant(section) => Box::new(<$task as TaskSpec>::build(section, context))),*
                }
            }

            pub(crate) fn fields(&self) -> serde_json::Result<serde_json::Value> {
                match self {
                    $(TaskConfig::$variant(section) => serde_json::to_value(section)),*
                }
            }

            fn from_fields(kind: TaskKind, fields: serde_json::Value) -> serde_json::Result<Self> {
                match kind {
                    $(TaskKind::$variant => serde_json::from_value(fields).map(TaskConfig::$variant)),*
                }
            }
        }
    };
}

// The registry: one line per task.
tasks! {
    PickAndPlace => super::pick_and_place::PickAndPlace,
    Reach => super::reach::Reach,
    Lift => super::lift::Lift,
    Stack => super::stack::Stack,
    Push => super::push::Push,
    Slide => super::slide::Slide,
    Flip => super::flip::Flip,
    PegInsertion => super::peg_insertion::PegInsertion,
    PickObject => super::pick_object::PickObject,
    OpenDrawer => super::open_drawer::OpenDrawer,
}

impl TaskKind {
    /// The task called `name` (as its descriptor spells it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|t| t.as_str() == name)
    }

    /// The name used in configs and on the command line.
    pub fn as_str(self) -> &'static str {
        self.descriptor().name
    }

    /// The names of every task, for error messages.
    pub(crate) fn names() -> String {
        Self::ALL
            .iter()
            .map(|t| format!("{:?}", t.as_str()))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl fmt::Display for TaskKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for TaskKind {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        serializer.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for TaskKind {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        TaskKind::from_name(&name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "unknown task {name:?}, expected one of {}",
                TaskKind::names()
            ))
        })
    }
}

impl Default for TaskConfig {
    fn default() -> Self {
        TaskConfig::defaults(TaskKind::default())
    }
}

impl From<TaskKind> for TaskConfig {
    fn from(kind: TaskKind) -> Self {
        TaskConfig::defaults(kind)
    }
}

impl Serialize for TaskConfig {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::Error;
        let mut map = serde_json::Map::new();
        map.insert("name".into(), self.kind().as_str().into());
        match self.fields().map_err(S::Error::custom)? {
            serde_json::Value::Object(fields) => map.extend(fields),
            other => {
                return Err(S::Error::custom(format!(
                    "a task section is a map: {other}"
                )))
            }
        }
        map.serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for TaskConfig {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        use serde::de::Error;
        let value = serde_json::Value::deserialize(deserializer)?;
        let (name, fields) = match value {
            serde_json::Value::String(name) => {
                (name, serde_json::Value::Object(Default::default()))
            }
            serde_json::Value::Object(mut map) => match map.remove("name") {
                Some(serde_json::Value::String(name)) => (name, serde_json::Value::Object(map)),
                _ => {
                    return Err(D::Error::custom(format!(
                        "the task section needs its \"name\" (one of {})",
                        TaskKind::names()
                    )))
                }
            },
            other => {
                return Err(D::Error::custom(format!(
                    "task must be a name or a section {{\"name\": ..., ...}}, got {other}"
                )))
            }
        };
        let kind = TaskKind::from_name(&name).ok_or_else(|| {
            D::Error::custom(format!(
                "unknown task {name:?}, expected one of {}",
                TaskKind::names()
            ))
        })?;
        TaskConfig::from_fields(kind, fields)
            .map_err(|e| D::Error::custom(format!("task {name:?}: {e}")))
    }
}
