//! Contract: whatever a caller passes to the public entry points (actions of any length and
//! value, configuration documents of any shape, seeds, reset options), the result is a finite
//! observation or a typed `Error`, never a panic.

use panda_rapier::env::PandaEnv;
use panda_rapier::task::{EnvConfig, ResetOptions};
use panda_rapier::vector::{AutoresetMode, PandaVecEnv};
use panda_rapier::Error;
use proptest::prelude::*;

fn any_value() -> impl Strategy<Value = f32> {
    prop_oneof![
        proptest::num::f32::ANY,
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::MAX),
        -2.0f32..2.0,
    ]
}

/// JSON values as a hostile caller might write them.
fn any_json() -> impl Strategy<Value = serde_json::Value> {
    let leaf = prop_oneof![
        Just(serde_json::Value::Null),
        any::<bool>().prop_map(serde_json::Value::from),
        any::<f64>().prop_map(serde_json::Value::from),
        any::<i64>().prop_map(serde_json::Value::from),
        "[a-z_]{0,6}".prop_map(serde_json::Value::from),
    ];
    leaf.prop_recursive(3, 12, 4, |inner| {
        prop_oneof![
            proptest::collection::vec(inner.clone(), 0..4).prop_map(serde_json::Value::from),
            proptest::collection::btree_map(
                prop_oneof![
                    Just("sim".to_string()),
                    Just("solver".to_string()),
                    Just("dt".to_string()),
                    Just("cube".to_string()),
                    Just("mass".to_string()),
                    Just("low".to_string()),
                    Just("high".to_string()),
                    "[a-z_]{1,8}",
                ],
                inner,
                0..4
            )
            .prop_map(|m| serde_json::Value::Object(m.into_iter().collect())),
        ]
    })
}

fn config_document() -> impl Strategy<Value = serde_json::Value> {
    let key = prop_oneof![
        Just("control_mode"),
        Just("reward_type"),
        Just("max_episode_steps"),
        Just("control_frequency"),
        Just("pick_region"),
        Just("goal_region"),
        Just("cube_yaw_range"),
        Just("sim"),
        Just("arm"),
        Just("ee_step"),
        Just("no_such_key"),
    ];
    proptest::collection::btree_map(key, any_json(), 0..3).prop_map(|m| {
        serde_json::Value::Object(m.into_iter().map(|(k, v)| (k.to_string(), v)).collect())
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn any_action_steps_or_is_rejected(action in proptest::collection::vec(any_value(), 0..10)) {
        let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
        env.reset(Some(0), &ResetOptions::default()).unwrap();
        match env.step(&action) {
            Ok(t) => {
                prop_assert!(env.observation().iter().all(|v| v.is_finite()));
                prop_assert!(t.reward.is_finite());
            }
            Err(e) => prop_assert!(
                matches!(e, Error::InvalidAction { .. }),
                "{e:?}"
            ),
        }
        // A rejected action changed nothing: the environment still steps.
        prop_assert!(env.step(&[0.0; 4]).is_ok());
    }

    #[test]
    fn any_config_document_builds_an_env_or_is_rejected(doc in config_document()) {
        match EnvConfig::from_json(&doc.to_string()) {
            Ok(config) => match PandaEnv::new(config) {
                Ok(mut env) => {
                    env.reset(Some(1), &ResetOptions::default()).unwrap();
                    let zeros = vec![0.0; env.action_dim()];
                    env.step(&zeros).unwrap();
                    prop_assert!(env.observation().iter().all(|v| v.is_finite()));
                }
                Err(e) => prop_assert!(
                    matches!(e, Error::InvalidConfig { .. } | Error::MissingMesh { .. }
                        | Error::MalformedUrdf { .. } | Error::AssetNotFound { .. }),
                    "{e:?}"
                ),
            },
            Err(e) => prop_assert!(matches!(e, Error::InvalidConfig { .. }), "{e:?}"),
        }
    }

    #[test]
    fn any_batch_and_seeds_step_or_are_rejected(
        actions in proptest::collection::vec(any_value(), 0..14),
        seed in any::<u64>(),
    ) {
        let mut envs = PandaVecEnv::new(EnvConfig::default(), 3, Some(1), AutoresetMode::NextStep)
            .unwrap();
        envs.reset(Some(seed)).unwrap();
        match envs.step(&actions) {
            Ok(()) => prop_assert!(envs.observations().iter().all(|v| v.is_finite())),
            Err(e) => prop_assert!(
                matches!(e, Error::InvalidAction { .. }),
                "{e:?}"
            ),
        }
        prop_assert!(envs.step(&[0.0; 12]).is_ok());
    }
}
