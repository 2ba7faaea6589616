//! Tests of the task section of [`EnvConfig`] (its name or fields) and of the reward weights
//! it names, read through the environment's configuration.

use crate::env::EnvConfig;
use crate::error::Error;
use crate::task::TaskKind;

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
        r#"{"task": "juggle"}"#,
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
        let shared = task
            .descriptor()
            .reward_terms
            .iter()
            .filter(|t| full.contains(&format!("\"{}\"", t.name)))
            .filter(|t| !task.terms_added_after_0_2().contains(&t.name))
            .count();
        assert_eq!(notes.len(), 6 - shared, "{task}");
        assert_eq!(
            config.resolved(),
            EnvConfig {
                task: task.into(),
                ..EnvConfig::default()
            }
            .resolved(),
            "{task}"
        );
    }
    // The resolved configuration reads back as the same environment.
    let config = EnvConfig::for_task(TaskKind::Stack).resolved();
    let text = serde_json::to_string(&config).unwrap();
    assert_eq!(EnvConfig::from_json(&text).unwrap(), config);
}

#[test]
fn every_task_s_reward_terms_have_a_weight_of_their_own() {
    use crate::task::RewardWeights;
    for &task in TaskKind::ALL {
        for term in task.descriptor().reward_terms {
            let set = [(term.name.to_string(), 0.5)].into_iter().collect();
            let weights = RewardWeights::resolve(&[*term], &set);
            assert_eq!(weights.get(term.name), 0.5, "{task}: {}", term.name);
            assert_eq!(
                weights.named(&[*term]),
                [(term.name, 0.5)].into_iter().collect()
            );
        }
    }
}
