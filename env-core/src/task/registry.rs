//! The one list of tasks. Adding a task is a file in `task/` whose type implements [`Task`]
//! and [`TaskSpec`] (its descriptor, its own configuration section with defaults and
//! validation, how it is built) and one line in the `tasks!` invocation below; the
//! [`TaskKind`] enum, the tagged [`TaskConfig`] section of [`EnvConfig`], [`make_task`], the
//! Python ids and their episode lengths, the docs tables and the contract tests all come from
//! here.

use std::fmt;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::config::EnvConfig;
use super::observation::InfoField;
use super::reward::RewardTerm;
use super::Task;
use crate::config::invalid;
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
    /// Whether its scene has the platform (what [`Task::scene`] builds; a contract test holds
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

    /// Checks `section` against the whole configuration; errors name the field as
    /// `task.<field>`.
    fn validate(section: &Self::Config, config: &EnvConfig) -> Result<()>;

    /// The task as `section` and `config` set it up.
    fn build(section: &Self::Config, config: &EnvConfig) -> Self;
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

            fn legacy_keys(self) -> &'static [(&'static str, &'static str)] {
                match self {
                    $(TaskKind::$variant => <$task as TaskSpec>::LEGACY_KEYS),*
                }
            }
        }

        /// The task section of [`EnvConfig`]: which task, with its own configuration. In
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

            /// Checks the section against the whole configuration.
            pub fn validate(&self, config: &EnvConfig) -> Result<()> {
                match self {
                    $(TaskConfig::$variant(section) => <$task as TaskSpec>::validate(section, config)),*
                }
            }

            /// Builds the task.
            pub fn build(&self, config: &EnvConfig) -> Box<dyn Task> {
                match self {
                    $(TaskConfig::$variant(section) => Box::new(<$task as TaskSpec>::build(section, config))),*
                }
            }

            fn fields(&self) -> serde_json::Result<serde_json::Value> {
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
    PickAndPlace => crate::task::PickAndPlace,
    Reach => crate::task::Reach,
    Lift => crate::task::Lift,
    Stack => crate::task::Stack,
    Push => crate::task::Push,
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
    fn names() -> String {
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

/// Builds the task `config` names.
pub fn make_task(config: &EnvConfig) -> Box<dyn Task> {
    config.task.build(config)
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

/// A note about a configuration read with keys from before 0.2 (see
/// [`EnvConfig::from_json_with_notes`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Deprecation {
    /// The old key.
    pub key: String,
    /// What to write instead, or why it is ignored; with the removal version.
    pub message: String,
}

/// The version that stops reading the keys of [`TaskSpec::LEGACY_KEYS`].
pub const LEGACY_KEYS_REMOVED_IN: &str = "0.3.0";

/// Moves the top-level keys of configurations before 0.2 (`pick_region`, `reach_goal_region`,
/// ...) into the task section of `document`, noting each; keys of another task are dropped
/// with a note when they hold that key's old default, and are an error otherwise (they would
/// silently do nothing).
pub(crate) fn migrate_legacy_keys(document: &mut serde_json::Value) -> Result<Vec<Deprecation>> {
    let serde_json::Value::Object(map) = document else {
        return Ok(Vec::new());
    };
    let is_legacy = |key: &str| {
        TaskKind::ALL
            .iter()
            .any(|t| t.legacy_keys().iter().any(|(old, _)| *old == key))
    };
    let legacy: Vec<String> = map.keys().filter(|k| is_legacy(k)).cloned().collect();
    if legacy.is_empty() {
        return Ok(Vec::new());
    }
    // The section as given (a name or a map), as a map with its name.
    let mut section = match map.remove("task") {
        None => serde_json::Map::new(),
        Some(serde_json::Value::String(name)) => {
            serde_json::Map::from_iter([("name".to_string(), serde_json::Value::String(name))])
        }
        Some(serde_json::Value::Object(section)) => section,
        Some(other) => {
            return Err(invalid(
                "task",
                format!("must be a name or a section, got {other}"),
            ))
        }
    };
    let name = match section.get("name") {
        None => TaskKind::default().as_str().to_string(),
        Some(serde_json::Value::String(name)) => name.clone(),
        Some(other) => {
            return Err(invalid(
                "task.name",
                format!("must be a task name, got {other}"),
            ))
        }
    };
    section.insert("name".into(), name.clone().into());
    let kind = TaskKind::from_name(&name).ok_or_else(|| {
        invalid(
            "task",
            format!(
                "unknown task {name:?}, expected one of {}",
                TaskKind::names()
            ),
        )
    })?;
    let mut notes = Vec::new();
    for key in legacy {
        let value = map.remove(&key).expect("listed above");
        if let Some((_, field)) = kind.legacy_keys().iter().find(|(old, _)| *old == key) {
            if section.contains_key(*field) {
                return Err(invalid(
                    &key,
                    format!("is the old spelling of task.{field}, which is also given: keep one"),
                ));
            }
            section.insert(field.to_string(), value);
            notes.push(Deprecation {
                message: format!(
                    "the top-level option {key:?} is deprecated and will be removed in \
                     {LEGACY_KEYS_REMOVED_IN}: write it in the task section, \
                     {{\"task\": {{\"name\": \"{name}\", \"{field}\": ...}}}}"
                ),
                key,
            });
            continue;
        }
        // Another task's key: harmless only if it says what that task's default says.
        let owner = TaskKind::ALL
            .iter()
            .copied()
            .find_map(|t| {
                let (_, field) = t.legacy_keys().iter().find(|(old, _)| *old == key)?;
                let defaults = TaskConfig::defaults(t).fields().ok()?;
                Some((t, defaults.get(*field).cloned()))
            })
            .expect("a legacy key has an owner");
        if owner.1.as_ref() == Some(&value) {
            notes.push(Deprecation {
                message: format!(
                    "the top-level option {key:?} is deprecated, will be removed in \
                     {LEGACY_KEYS_REMOVED_IN}, and is ignored here: it configures the {} \
                     task, and this configuration's task is {name:?}",
                    owner.0
                ),
                key,
            });
        } else {
            return Err(invalid(
                &key,
                format!(
                    "configures the {} task (an option from before 0.2), but this \
                     configuration's task is {name:?}, which would ignore it",
                    owner.0
                ),
            ));
        }
    }
    map.insert("task".into(), serde_json::Value::Object(section));
    Ok(notes)
}

/// The weights of the staged cube reward's terms before 0.2, when every task took all six.
const LEGACY_WEIGHTS: [(&str, f64); 6] = [
    ("reach", 1.0),
    ("grasp", 1.0),
    ("lift", 1.0),
    ("carry", 2.0),
    ("place", 5.0),
    ("release", 0.0),
];

/// Drops from `document`'s `reward_weights` the terms the task's reward does not have but
/// every task took before 0.2, when they hold their old default (a dumped configuration),
/// noting each; any other value is left for validation to refuse (it would do nothing).
pub(crate) fn migrate_reward_weights(document: &mut serde_json::Value) -> Result<Vec<Deprecation>> {
    let kind = match document.get("task") {
        None => TaskKind::default(),
        Some(serde_json::Value::String(name)) => match TaskKind::from_name(name) {
            Some(kind) => kind,
            None => return Ok(Vec::new()),
        },
        Some(serde_json::Value::Object(section)) => {
            match section
                .get("name")
                .and_then(|n| n.as_str())
                .and_then(TaskKind::from_name)
            {
                Some(kind) => kind,
                None => return Ok(Vec::new()),
            }
        }
        Some(_) => return Ok(Vec::new()),
    };
    let Some(serde_json::Value::Object(weights)) = document.get_mut("reward_weights") else {
        return Ok(Vec::new());
    };
    let terms = kind.descriptor().reward_terms;
    let mut notes = Vec::new();
    for (name, old_default) in LEGACY_WEIGHTS {
        if terms.iter().any(|t| t.name == name) {
            continue;
        }
        if weights.get(name).and_then(|v| v.as_f64()) == Some(old_default) {
            weights.remove(name);
            notes.push(Deprecation {
                key: format!("reward_weights.{name}"),
                message: format!(
                    "reward_weights.{name} is ignored: the {kind} task's reward has no {name:?} \
                     term (its weight at the old default is accepted until \
                     {LEGACY_KEYS_REMOVED_IN}, then it is an error)"
                ),
            });
        }
    }
    Ok(notes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;

    #[test]
    fn the_task_section_takes_a_name_or_fields() {
        let short = EnvConfig::from_json(r#"{"task": "reach"}"#).unwrap();
        assert_eq!(short.task.kind(), TaskKind::Reach);
        let long = EnvConfig::from_json(
            r#"{"task": {"name": "reach", "goal_region": [[0.4, -0.1, 0.1], [0.6, 0.1, 0.3]]}}"#,
        )
        .unwrap();
        assert_ne!(long.task, short.task);
        let text = serde_json::to_string(&long).unwrap();
        assert_eq!(EnvConfig::from_json(&text).unwrap(), long);
        for bad in [
            r#"{"task": "slide"}"#,
            r#"{"task": {"goal_region": [[0, 0, 0], [1, 1, 1]]}}"#,
            r#"{"task": {"name": "reach", "goal_height": [0.1, 0.2]}}"#,
            r#"{"task": 3}"#,
        ] {
            let err = EnvConfig::from_json(bad).unwrap_err();
            assert!(matches!(err, Error::InvalidConfig { .. }), "{bad}: {err}");
        }
        let err = EnvConfig::from_json(r#"{"task": {"name": "reach", "goal_height": 1}}"#)
            .unwrap_err()
            .to_string();
        assert!(err.contains("goal_height"), "{err}");
    }

    #[test]
    fn keys_from_before_0_2_move_into_the_task_section_with_a_note() {
        let (config, notes) = EnvConfig::from_json_with_notes(
            r#"{"task": "reach", "reach_goal_region": [[0.4, -0.1, 0.1], [0.6, 0.1, 0.3]]}"#,
        )
        .unwrap();
        let expected = EnvConfig::from_json(
            r#"{"task": {"name": "reach", "goal_region": [[0.4, -0.1, 0.1], [0.6, 0.1, 0.3]]}}"#,
        )
        .unwrap();
        assert_eq!(config, expected);
        assert_eq!(notes.len(), 1);
        assert_eq!(notes[0].key, "reach_goal_region");
        assert!(notes[0].message.contains("0.3.0"), "{}", notes[0].message);
        // Without a task: the default one's keys.
        let (config, notes) =
            EnvConfig::from_json_with_notes(r#"{"goal_air_probability": 0.5}"#).unwrap();
        let TaskConfig::PickAndPlace(section) = &config.task else {
            panic!("{config:?}")
        };
        assert_eq!(section.goal_air_probability, 0.5);
        assert_eq!(notes.len(), 1);
        // Another task's key at its old default: dropped with a note; otherwise an error.
        let (config, notes) =
            EnvConfig::from_json_with_notes(r#"{"task": "push", "lift_height": [0.05, 0.25]}"#)
                .unwrap();
        assert_eq!(config, EnvConfig::for_task(TaskKind::Push));
        assert!(notes[0].message.contains("ignored"), "{}", notes[0].message);
        let err =
            EnvConfig::from_json(r#"{"task": "push", "lift_height": [0.1, 0.2]}"#).unwrap_err();
        assert!(err.to_string().contains("lift_height"), "{err}");
        // Both spellings at once.
        let err = EnvConfig::from_json(
            r#"{"task": {"name": "lift", "goal_height": [0.1, 0.2]}, "lift_height": [0.1, 0.2]}"#,
        )
        .unwrap_err();
        assert!(err.to_string().contains("keep one"), "{err}");
        // The old default document (every key of 0.1.0) still reads, for every task.
        for task in TaskKind::ALL {
            let old = format!(
                r#"{{"task": "{task}", "pick_region": {{"low": [0.4, -0.2], "high": [0.6, 0.0]}},
                "cube_yaw_range": [-0.25, 0.25],
                "goal_region": {{"low": [0.42, 0.22], "high": [0.58, 0.38]}},
                "goal_air_probability": 0.0, "goal_air_height": [0.05, 0.2],
                "reach_goal_region": [[0.35, -0.25, 0.1], [0.65, 0.25, 0.4]],
                "lift_height": [0.05, 0.25],
                "push_goal_region": {{"low": [0.4, 0.05], "high": [0.6, 0.25]}}}}"#
            );
            let (config, notes) = EnvConfig::from_json_with_notes(&old).unwrap();
            assert_eq!(config, EnvConfig::for_task(*task), "{task}");
            assert_eq!(notes.len(), 8, "{task}");
        }
    }

    #[test]
    fn reward_weights_name_the_task_s_terms() {
        let reach =
            EnvConfig::from_json(r#"{"task": "reach", "reward_weights": {"reach": 2}}"#).unwrap();
        assert_eq!(reach.reward_weights_resolved()["reach"], 2.0);
        assert_eq!(reach.resolved().reward_weights.len(), 1);
        let err = EnvConfig::from_json(r#"{"task": "reach", "reward_weights": {"place": 7}}"#)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("reward_weights.place") && err.contains("reach"),
            "{err}"
        );
        let err = EnvConfig::from_json(r#"{"reward_weights": {"carry": -1}}"#).unwrap_err();
        assert!(err.to_string().contains("reward_weights.carry"), "{err}");
        // Pick-and-place's full default set, as 0.1 dumped it, for every task: the terms a task
        // lacks are dropped with a note.
        let full = r#"{"reach": 1.0, "grasp": 1.0, "lift": 1.0, "carry": 2.0, "place": 5.0,
            "release": 0.0}"#;
        for &task in TaskKind::ALL {
            let text = format!(r#"{{"task": "{task}", "reward_weights": {full}}}"#);
            let (config, notes) = EnvConfig::from_json_with_notes(&text).unwrap();
            let terms = task.descriptor().reward_terms.len();
            assert_eq!(notes.len(), 6 - terms, "{task}");
            assert_eq!(
                config.resolved(),
                EnvConfig::for_task(task).resolved(),
                "{task}"
            );
        }
        // The resolved configuration reads back as the same environment.
        let config = EnvConfig::for_task(TaskKind::Stack).resolved();
        let text = serde_json::to_string(&config).unwrap();
        assert_eq!(EnvConfig::from_json(&text).unwrap(), config);
    }
}
