//! Reading configurations from before 0.2, with a [`Deprecation`] note per old key (Python
//! shows each as a `FutureWarning`) until [`LEGACY_KEYS_REMOVED_IN`]:
//!
//! - the `sim` section, whose keys now belong to `physics` (gravity, floor, solver), `robot`
//!   (model, base, joints, motors), the top-level `arm`, and the task's section (its `cube`
//!   and `platform`) (`migrate_sim_section`);
//! - top-level task keys (`pick_region`, `reach_goal_region`, ...) that now live in the task's
//!   section (`migrate_legacy_keys`);
//! - reward weights of terms a task's reward does not have (`migrate_reward_weights`).
//!
//! An old key that would now do nothing (another task's option, an object the task does not
//! have) is dropped with a note when it holds its old default, and is an error otherwise.

use serde_json::{Map, Value};

#[cfg(doc)]
use super::EnvConfig;
use crate::config::invalid;
use crate::error::Result;
#[cfg(doc)]
use crate::task::registry::TaskSpec;
use crate::task::registry::{TaskConfig, TaskKind};

/// Every migration, in order, applied to a parsed document before it is read.
pub(crate) fn migrate(document: &mut Value) -> Result<Vec<Deprecation>> {
    let mut notes = migrate_sim_section(document)?;
    notes.extend(migrate_legacy_keys(document)?);
    notes.extend(migrate_reward_weights(document)?);
    Ok(notes)
}

/// Removes the task section from `map` (a name, a section, or absent for the default task)
/// and returns its kind and the section as a map with its `name`.
fn take_task_section(map: &mut Map<String, Value>) -> Result<(TaskKind, Map<String, Value>)> {
    let mut section = match map.remove("task") {
        None => Map::new(),
        Some(Value::String(name)) => Map::from_iter([("name".to_string(), Value::String(name))]),
        Some(Value::Object(section)) => section,
        Some(other) => {
            return Err(invalid(
                "task",
                format!("must be a name or a section, got {other}"),
            ))
        }
    };
    let name = match section.get("name") {
        None => TaskKind::default().as_str().to_string(),
        Some(Value::String(name)) => name.clone(),
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
    Ok((kind, section))
}

/// Where a key of the old `sim` section lives now: `(section, key)`, the section `"task"` for
/// the task's objects.
const SIM_KEYS: [(&str, (&str, &str)); 13] = [
    ("gravity", ("physics", "gravity")),
    ("floor_friction", ("physics", "floor_friction")),
    ("solver", ("physics", "solver")),
    ("robot_urdf", ("robot", "urdf")),
    ("robot_base", ("robot", "base")),
    ("initial_configuration", ("robot", "initial_configuration")),
    ("finger_friction", ("robot", "finger_friction")),
    ("robot_friction", ("robot", "link_friction")),
    ("joint_damping", ("robot", "joint_damping")),
    ("joint_friction", ("robot", "joint_friction")),
    ("motors", ("robot", "motors")),
    ("platform", ("task", "platform")),
    ("cube", ("task", "cube")),
];

/// Where the old `sim.cube.position` put the cube (never used: tasks place it every reset).
const OLD_CUBE_POSITION: [f64; 3] = [0.5, -0.15, 0.025];

fn sim_note(old: &str, new: String) -> Deprecation {
    Deprecation {
        message: format!(
            "{old} is deprecated and will be removed in {LEGACY_KEYS_REMOVED_IN}: write {new}"
        ),
        key: old.to_string(),
    }
}

/// Whether every field of `given` equals the same field of `defaults`.
fn holds_defaults(given: &Value, defaults: Option<&Value>) -> bool {
    match (given, defaults) {
        (Value::Object(fields), Some(Value::Object(defaults))) => fields
            .iter()
            .all(|(k, v)| holds_defaults(v, defaults.get(k))),
        (value, Some(default)) => value
            .as_f64()
            .zip(default.as_f64())
            .map_or(value == default, |(a, b)| a == b),
        (_, None) => false,
    }
}

/// Spreads the `sim` section of configurations before 0.2 over its owners: `physics`,
/// `robot`, the top-level `arm` and the task section (`cube`, `platform`), noting each key.
/// `sim.solver.substeps` (always derived from `control_frequency`) and `sim.cube.position`
/// (tasks place the cube at every reset) never had an effect: they are dropped with a note.
/// `sim.arm` at `"dynamic"` always gave way to the top-level `arm`; another value becomes the
/// top-level `arm` unless that says otherwise (an error, as before).
pub(crate) fn migrate_sim_section(document: &mut Value) -> Result<Vec<Deprecation>> {
    let Value::Object(map) = document else {
        return Ok(Vec::new());
    };
    let Some(sim) = map.remove("sim") else {
        return Ok(Vec::new());
    };
    let Value::Object(sim) = sim else {
        return Err(invalid("sim", format!("must be a section, got {sim}")));
    };
    let (kind, mut section) = take_task_section(map)?;
    let task_defaults = TaskConfig::defaults(kind).fields().unwrap_or(Value::Null);
    let mut notes = Vec::new();
    for (key, mut value) in sim {
        let old = format!("sim.{key}");
        if key == "arm" {
            let top = map.get("arm");
            if value == "dynamic" || top == Some(&value) {
                notes.push(Deprecation {
                    message: format!(
                        "{old} is deprecated, will be removed in {LEGACY_KEYS_REMOVED_IN}, and \
                         is ignored here: the top-level `arm` sets the arm"
                    ),
                    key: old,
                });
            } else if top.is_none() {
                map.insert("arm".into(), value);
                notes.push(sim_note(&old, "the top-level `arm`".into()));
            } else {
                return Err(invalid(
                    &old,
                    format!(
                        "is {value} but arm is {}: set the top-level `arm` only",
                        top.expect("checked")
                    ),
                ));
            }
            continue;
        }
        let Some((_, (owner, field))) = SIM_KEYS.iter().find(|(k, _)| *k == key) else {
            return Err(invalid(&old, "is not an option (of the old `sim` section)"));
        };
        if key == "solver" {
            if let Some(Value::Object(solver)) = Some(&mut value) {
                if solver.remove("substeps").is_some() {
                    notes.push(Deprecation {
                        key: "sim.solver.substeps".into(),
                        message: "sim.solver.substeps is ignored, as it always was: the physics \
                                  steps per action follow from control_frequency and \
                                  physics.solver.dt (the key is an error from 0.3.0)"
                            .into(),
                    });
                }
            }
        }
        if key == "cube" {
            if let Value::Object(cube) = &mut value {
                if let Some(position) = cube.remove("position") {
                    let old_default = serde_json::to_value(OLD_CUBE_POSITION).expect("numbers");
                    notes.push(Deprecation {
                        key: "sim.cube.position".into(),
                        message: format!(
                            "sim.cube.position is ignored, as it always was: the task places \
                             the cube at every reset (task.cube_region, or reset(options=\
                             {{\"cube_position\": ...}})){}; the key is an error from \
                             {LEGACY_KEYS_REMOVED_IN}",
                            if holds_defaults(&position, Some(&old_default)) {
                                String::new()
                            } else {
                                format!(", so {position} had no effect")
                            }
                        ),
                    });
                }
                if cube.is_empty() {
                    continue;
                }
            }
        }
        if *owner == "task" {
            if task_defaults.get(*field).is_none() {
                if holds_defaults(&value, Some(&default_object(field))) {
                    notes.push(Deprecation {
                        message: format!(
                            "{old} is deprecated, will be removed in {LEGACY_KEYS_REMOVED_IN}, \
                             and is ignored here: the {kind} task has no {field}"
                        ),
                        key: old,
                    });
                    continue;
                }
                return Err(invalid(
                    &old,
                    format!("configures a {field}, but the {kind} task has none"),
                ));
            }
            if section.contains_key(*field) {
                return Err(invalid(
                    &old,
                    format!("is the old spelling of task.{field}, which is also given: keep one"),
                ));
            }
            section.insert(field.to_string(), value);
            notes.push(sim_note(
                &old,
                format!("{{\"task\": {{\"name\": \"{kind}\", \"{field}\": ...}}}}"),
            ));
            continue;
        }
        let target = map
            .entry(owner.to_string())
            .or_insert_with(|| Value::Object(Map::new()));
        let Value::Object(target) = target else {
            return Err(invalid(owner, format!("must be a section, got {target}")));
        };
        if target.contains_key(*field) {
            return Err(invalid(
                &old,
                format!("is the old spelling of {owner}.{field}, which is also given: keep one"),
            ));
        }
        target.insert(field.to_string(), value);
        notes.push(sim_note(&old, format!("{owner}.{field}")));
    }
    map.insert("task".into(), Value::Object(section));
    Ok(notes)
}

/// The default of an object a task may hold (for tasks that do not: what the old `sim`
/// section's default was).
fn default_object(field: &str) -> Value {
    match field {
        "cube" => serde_json::to_value(crate::config::CubeConfig::default()),
        _ => serde_json::to_value(crate::config::PlatformConfig::default()),
    }
    .expect("plain data")
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

/// The version that stops reading configurations from before 0.2: the keys of
/// [`TaskSpec::LEGACY_KEYS`] and the `sim` section.
pub const LEGACY_KEYS_REMOVED_IN: &str = "0.3.0";

/// Moves the top-level keys of configurations before 0.2 (`pick_region`, `reach_goal_region`,
/// ...) into the task section of `document`, noting each; keys of another task are dropped
/// with a note when they hold that key's old default, and are an error otherwise (they would
/// silently do nothing).
pub(crate) fn migrate_legacy_keys(document: &mut Value) -> Result<Vec<Deprecation>> {
    let Value::Object(map) = document else {
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
    let (kind, mut section) = take_task_section(map)?;
    let name = kind.as_str();
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
    map.insert("task".into(), Value::Object(section));
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
/// and, from such a dump, the terms the task gained since (its
/// [`TaskSpec::TERMS_ADDED_AFTER_0_2`]),
/// noting each; any other value is left for validation to refuse (it would do nothing).
pub(crate) fn migrate_reward_weights(document: &mut Value) -> Result<Vec<Deprecation>> {
    let kind = match document.get("task") {
        None => TaskKind::default(),
        Some(Value::String(name)) => match TaskKind::from_name(name) {
            Some(kind) => kind,
            None => return Ok(Vec::new()),
        },
        Some(Value::Object(section)) => {
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
    let Some(Value::Object(weights)) = document.get_mut("reward_weights") else {
        return Ok(Vec::new());
    };
    let terms = kind.descriptor().reward_terms;
    // All six and nothing else: a dump of today's configuration holds every term of the
    // task's reward, Stack's `stage` among them, so Stack's (all six since `release` joined
    // it) is not taken for one from before.
    let legacy_dump = weights.len() == LEGACY_WEIGHTS.len()
        && LEGACY_WEIGHTS
            .iter()
            .all(|(name, _)| weights.contains_key(*name));
    let mut notes = Vec::new();
    for &name in kind.terms_added_after_0_2() {
        if legacy_dump && weights.remove(name).is_some() {
            notes.push(Deprecation {
                key: format!("reward_weights.{name}"),
                message: format!(
                    "reward_weights.{name} is ignored: these weights were dumped before 0.2, \
                     when the {kind} task's reward had no {name:?} term (it is off by default \
                     now; set it in a configuration of today's form to use it)"
                ),
            });
        }
    }
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
    use crate::config::ArmFidelity;
    use crate::env::EnvConfig;

    /// The defaults with `task` (old documents set no episode length: the default 70 steps).
    fn with_task(task: TaskKind) -> EnvConfig {
        EnvConfig {
            task: task.into(),
            ..EnvConfig::default()
        }
    }

    #[test]
    fn a_term_added_after_0_2_is_off_in_a_dump_from_before_and_on_where_set_today() {
        let dumped = r#"{"task": "stack", "reward_weights": {"reach": 1.0, "grasp": 1.0,
            "lift": 1.0, "carry": 2.0, "place": 5.0, "release": 0.0}}"#;
        let (config, notes) = EnvConfig::from_json_with_notes(dumped).unwrap();
        assert_eq!(config.reward_weights_resolved()["lift"], 0.0);
        assert!(
            notes.iter().any(|n| n.key == "reward_weights.lift"),
            "{notes:?}"
        );
        let today = r#"{"task": "stack", "reward_weights": {"lift": 1.0, "carry": 4.0}}"#;
        let (config, notes) = EnvConfig::from_json_with_notes(today).unwrap();
        assert_eq!(config.reward_weights_resolved()["lift"], 1.0);
        assert!(notes.is_empty(), "{notes:?}");
        // Today's dump (every term of the task's reward, the six old ones among them for
        // Stack) reads back as it was written.
        let set = r#"{"task": "stack", "reward_weights": {"lift": 1.0, "release": 3.0}}"#;
        let config = EnvConfig::from_json(set).unwrap();
        let dump = serde_json::to_string(&config.resolved()).unwrap();
        let (again, notes) = EnvConfig::from_json_with_notes(&dump).unwrap();
        assert_eq!(again.reward_weights_resolved()["lift"], 1.0);
        assert_eq!(again.reward_weights_resolved()["release"], 3.0);
        assert!(notes.is_empty(), "{notes:?}");
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
        assert_eq!(config, with_task(TaskKind::Push));
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
            assert_eq!(config, with_task(*task), "{task}");
            assert_eq!(notes.len(), 8, "{task}");
        }
    }

    #[test]
    fn the_sim_section_from_before_0_2_spreads_over_its_owners() {
        let old = r#"{"task": "pick_and_place", "sim": {
            "gravity": [0.0, 0.0, -9.0], "floor_friction": 0.8,
            "solver": {"dt": 0.005, "substeps": 8, "solver_iterations": 8},
            "robot_friction": 0.4, "motors": {"stiffness": 30000.0},
            "cube": {"mass": 0.2, "position": [0.5, -0.15, 0.025]},
            "platform": {"friction": 0.9}, "arm": "kinematic"}}"#;
        let new = r#"{"task": {"name": "pick_and_place", "cube": {"mass": 0.2},
            "platform": {"friction": 0.9}}, "arm": "kinematic",
            "physics": {"gravity": [0.0, 0.0, -9.0], "floor_friction": 0.8,
                "solver": {"dt": 0.005, "solver_iterations": 8}},
            "robot": {"link_friction": 0.4, "motors": {"stiffness": 30000.0}}}"#;
        let (config, notes) = EnvConfig::from_json_with_notes(old).unwrap();
        assert_eq!(config, EnvConfig::from_json(new).unwrap());
        assert_eq!(config.arm, ArmFidelity::Kinematic);
        let keys: Vec<&str> = notes.iter().map(|n| n.key.as_str()).collect();
        for key in [
            "sim.gravity",
            "sim.solver",
            "sim.solver.substeps",
            "sim.robot_friction",
            "sim.cube",
            "sim.cube.position",
            "sim.platform",
            "sim.arm",
        ] {
            assert!(keys.contains(&key), "{key} not in {keys:?}");
        }
        assert!(
            notes.iter().all(|n| n.message.contains("0.3.0")),
            "{notes:?}"
        );
        // A task without a platform: the old default platform is dropped with a note, another
        // one is an error (it would do nothing).
        let (config, notes) = EnvConfig::from_json_with_notes(
            r#"{"task": "reach", "sim": {"platform": {"friction": 1.0}, "cube": {"size": 0.05}}}"#,
        )
        .unwrap();
        assert_eq!(config, with_task(TaskKind::Reach));
        assert_eq!(notes.len(), 2, "{notes:?}");
        let err = EnvConfig::from_json(r#"{"task": "reach", "sim": {"cube": {"mass": 0.3}}}"#)
            .unwrap_err()
            .to_string();
        assert!(err.contains("sim.cube") && err.contains("reach"), "{err}");
        let err =
            EnvConfig::from_json(r#"{"task": "push", "sim": {"platform": {"size": [1, 1, 1]}}}"#)
                .unwrap_err();
        assert!(err.to_string().contains("sim.platform"), "{err}");
        // Both spellings, arms that disagree, and unknown old keys are errors.
        for (bad, field) in [
            (
                r#"{"sim": {"gravity": [0, 0, -9]}, "physics": {"gravity": [0, 0, -9]}}"#,
                "sim.gravity",
            ),
            (
                r#"{"sim": {"arm": "kinematic"}, "arm": "dynamic"}"#,
                "sim.arm",
            ),
            (r#"{"sim": {"weight": 1}}"#, "sim.weight"),
            (r#"{"sim": 3}"#, "sim"),
        ] {
            let err = EnvConfig::from_json(bad).unwrap_err().to_string();
            assert!(err.contains(field), "{bad}: {err}");
        }
        // The whole 0.1 default `sim` section reads for every task, as that task's defaults.
        let old_default = r#"{"arm": "dynamic", "gravity": [0.0, 0.0, -9.81],
            "robot_urdf": null, "robot_base": [0.0, 0.0, 0.0], "initial_configuration": null,
            "finger_friction": 1.0, "robot_friction": 0.5, "floor_friction": 1.0,
            "joint_damping": null, "joint_friction": null,
            "solver": {"dt": 0.01, "substeps": 4, "solver_iterations": 6,
                "contact_natural_frequency": 120.0, "contact_damping_ratio": 5.0,
                "length_unit": 0.1, "contact_prediction_distance": 0.002,
                "multibody_update": "step"},
            "motors": {"stiffness": 40000.0, "damping": 400.0, "velocity_damping": 400.0,
                "gripper_force": 20.0, "gripper_stiffness": 5000.0, "gripper_damping": 50.0,
                "arm_armature": 0.0, "finger_armature": 0.05, "kinematic_acceleration": 50.0},
            "platform": {"top_center": [0.5, 0.3, 0.1], "size": [0.3, 0.3, 0.1], "friction": 1.0},
            "cube": {"size": 0.05, "mass": 0.1, "friction": 1.0, "position": [0.5, -0.15, 0.025]}}"#;
        for &task in TaskKind::ALL {
            let text = format!(r#"{{"task": "{task}", "sim": {old_default}}}"#);
            let (config, notes) = EnvConfig::from_json_with_notes(&text).unwrap();
            assert_eq!(config, with_task(task), "{task}");
            assert_eq!(notes.len(), 16, "{task}: {notes:?}");
        }
    }
}
