"""A bc recipe's ``phase_weights``: the expert's phases weigh their states in the cloning loss
(:func:`panda_rapier.learning.imitation.phase_row_weights`), checked when the recipe loads and
when the expert's demonstrations are in."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")

import torch as th  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402

from panda_rapier import ConfigError, InvalidArgumentError, ScriptedPolicy  # noqa: E402
from panda_rapier.learning.imitation import (  # noqa: E402
    Demonstrations,
    behaviour_cloning,
    collect,
    dagger,
    phase_row_weights,
)
from panda_rapier.learning.normalization import NormalizedFlatten, fit_normalizers  # noqa: E402
from panda_rapier.learning.recipes import BC_KEYS, load_recipe  # noqa: E402
from panda_rapier.registration import env_config  # noqa: E402
from panda_rapier.sb3 import make_vec_env  # noqa: E402

th.set_num_threads(1)

REACH = "panda_rapier/Reach-v0"


def _model(env_id: str = REACH) -> PPO:
    return PPO(
        "MultiInputPolicy",
        make_vec_env(env_id),
        policy_kwargs={
            "features_extractor_class": NormalizedFlatten,
            "net_arch": {"pi": [64, 64], "vf": [8]},
        },
        seed=0,
        device="cpu",
    )


def _recipe(tmp_path: Path, entry: dict) -> Path:
    path = tmp_path / "bc.yml"
    path.write_text(yaml.safe_dump({"panda_rapier/Slide-v0": entry}))
    return path


def test_a_recipe_without_phase_weights_loads_as_before(tmp_path: Path) -> None:
    """The key has no default: recipes that do not set it are unchanged."""
    recipe = load_recipe("bc", "panda_rapier/Slide-v0", _recipe(tmp_path, {"epochs": 3}))
    assert "phase_weights" not in recipe and set(recipe) == set(BC_KEYS)
    weighted = {"phase_weights": {"slide": 5, "let_go": 2.5}}
    recipe = load_recipe("bc", "panda_rapier/Slide-v0", _recipe(tmp_path, weighted))
    assert recipe["phase_weights"] == {"slide": 5, "let_go": 2.5}


@pytest.mark.parametrize(
    "value",
    [
        [1.0, 2.0],
        {},
        {"slide": -1.0},
        {"slide": float("nan")},
        {"slide": float("inf")},
        {"slide": "heavy"},
        {"slide": True},
        {3: 1.0},
    ],
)
def test_bad_phase_weights_name_the_key(tmp_path: Path, value: object) -> None:
    with pytest.raises(ConfigError, match="phase_weights"):
        load_recipe("bc", "panda_rapier/Slide-v0", _recipe(tmp_path, {"phase_weights": value}))


def test_phase_weights_are_not_a_student_key(tmp_path: Path) -> None:
    entry = {"student": {}, "phase_weights": {"slide": 2.0}}
    with pytest.raises(ConfigError, match="unknown bc recipe keys"):
        load_recipe("bc", "panda_rapier/Slide-v0", _recipe(tmp_path, entry))


def test_rows_weigh_what_their_expert_phase_weighs() -> None:
    """Each row gets its phase's weight (as ScriptedPolicy.phases names it), others 1."""
    config = env_config("panda_rapier/Slide-v0")
    demos, _ = collect(config, 2, first_seed=11, num_envs=2)
    phases = ScriptedPolicy(config).phases(demos.observations)
    weights, seen = phase_row_weights(config, demos.observations, {"slide": 5.0, "wait": 0.5})
    expected = [5.0 if p == "slide" else 0.5 if p == "wait" else 1.0 for p in phases]
    np.testing.assert_array_equal(weights, np.array(expected, dtype=np.float32))
    assert {"approach", "slide", "wait"} <= seen == set(phases)


def test_the_loss_follows_the_weighted_rows() -> None:
    """The same states twice, labelled with the expert's actions and with their negatives:
    unweighted, the fit lands between the two; with the negatives weighing 0, on the expert's."""
    config = env_config(REACH)
    demos, _ = collect(config, 4, first_seed=5, num_envs=4)
    n = len(demos)
    twice = Demonstrations(
        config=demos.config,
        observations=np.concatenate([demos.observations, demos.observations]),
        actions=np.concatenate([demos.actions, -demos.actions]),
        episode_index=np.concatenate([demos.episode_index, demos.episode_index + 4]),
    )
    weights = np.concatenate([np.ones(n), np.zeros(n)]).astype(np.float32)

    def fitted(row_weights: np.ndarray | None) -> np.ndarray:
        model = _model()
        fit_normalizers(model.policy, twice.observations)
        behaviour_cloning(model, twice, epochs=60, batch_size=64, seed=0, weights=row_weights)
        obs = {k: th.as_tensor(v) for k, v in _goal_dict(demos).items()}
        with th.no_grad():
            return model.policy.get_distribution(obs).distribution.mean.numpy()

    expert = demos.actions
    scale = float(np.sqrt((expert**2).mean()))
    weighted = fitted(weights)
    plain = fitted(None)
    # Measured when written: rms error to the expert 0.074 (weighted); rms of the plain fit
    # 0.008 (the two labels cancel); the rms of the expert's actions 0.58.
    assert np.sqrt(((weighted - expert) ** 2).mean()) < 0.3 * scale
    assert np.sqrt((plain**2).mean()) < 0.3 * scale  # the two labels cancel


def _goal_dict(demos: Demonstrations) -> dict[str, np.ndarray]:
    from panda_rapier import _common

    schema = _common.Schema.of(_common.config_json(demos.config))
    return _common.split_observation(demos.observations, schema)


@pytest.mark.parametrize(
    "weights", [np.ones(3), np.full(10, np.nan), -np.ones(10), np.ones((10, 1))]
)
def test_bad_row_weights_are_refused(weights: np.ndarray) -> None:
    config = env_config(REACH)
    demos, _ = collect(config, 1, first_seed=5, num_envs=1)
    demos = Demonstrations(demos.config, demos.observations[:10], demos.actions[:10],
                           demos.episode_index[:10])  # fmt: skip
    model = _model()
    fit_normalizers(model.policy, demos.observations)
    with pytest.raises(InvalidArgumentError, match="weights"):
        behaviour_cloning(model, demos, epochs=1, weights=weights)


def test_a_phase_the_expert_never_enters_is_a_config_error() -> None:
    """A misspelt phase is refused once the demonstrations show the expert's phases, before
    any fitting, with the phases it did enter."""
    model = _model()
    with pytest.raises(ConfigError, match=r"\['slde'\].*never enters.*phases there: \["):
        dagger(
            model,
            env_config(REACH),
            demo_episodes=2,
            rounds=0,
            episodes_per_round=1,
            epochs=1,
            epochs_per_round=1,
            first_seed=0,
            num_envs=2,
            phase_weights={"slde": 2.0},
        )
