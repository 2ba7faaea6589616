"""DAgger's mixed policy: a bc recipe's ``dagger_beta`` (p). In round r the expert takes each of
the learner's steps with probability p**r (``dagger`` in :mod:`panda_rapier.learning.imitation`,
``expert_share`` of :func:`panda_rapier.learning.rollouts.collect`); without the key the learner
drives alone, as before."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")

import torch as th  # noqa: E402
from conftest import tiny_bc_model  # noqa: E402

from panda_rapier import ConfigError, InvalidArgumentError  # noqa: E402
from panda_rapier.learning import imitation, rollouts  # noqa: E402
from panda_rapier.learning.recipes import BC_KEYS, dagger_beta, load_recipe  # noqa: E402
from panda_rapier.registration import env_config  # noqa: E402

th.set_num_threads(1)

PUSH = "panda_rapier/Push-v0"
SLIDE = "panda_rapier/Slide-v0"


def _still(flat: np.ndarray) -> np.ndarray:
    """A learner that never moves."""
    return np.zeros((flat.shape[0], 4), dtype=np.float32)


def test_a_recipe_without_the_key_loads_as_before(bc_recipe: Any) -> None:
    assert set(load_recipe("bc", SLIDE, bc_recipe({"epochs": 3}))) == set(BC_KEYS)
    assert load_recipe("bc", SLIDE, bc_recipe({"dagger_beta": 0.5}))["dagger_beta"] == 0.5
    assert dagger_beta(0) == 0.0


@pytest.mark.parametrize("value", [1, 1.5, -0.1, math.nan, math.inf, True, "0.5", None, [0.5]])
def test_bad_betas_name_the_key(bc_recipe: Any, value: object) -> None:
    with pytest.raises(ConfigError, match=r"'dagger_beta' must be a number in \[0, 1\)"):
        load_recipe("bc", SLIDE, bc_recipe({"dagger_beta": value}))


def test_expert_steps_depend_on_the_row_and_the_salt_only() -> None:
    rows = np.random.default_rng(0).normal(size=(4000, 12)).astype(np.float32)
    take = rollouts.expert_steps(rows, 0.25, 7)
    assert take.dtype == bool and take.shape == (4000,)
    assert 0.22 < take.mean() < 0.28
    # The same draw for any split of the rows into batches (any number of environments).
    parts = [rollouts.expert_steps(part, 0.25, 7) for part in np.array_split(rows, 13)]
    assert np.array_equal(np.concatenate(parts), take)
    assert np.array_equal(rollouts.expert_steps(rows[::-1], 0.25, 7), take[::-1])
    # Another salt (another round) draws other steps; shares 0 and 1 are none and all.
    assert not np.array_equal(rollouts.expert_steps(rows, 0.25, 8), take)
    assert not rollouts.expert_steps(rows, 0.0, 7).any()
    assert rollouts.expert_steps(rows, 1.0, 7).all()
    # A larger share takes every step a smaller one does.
    assert np.all(rollouts.expert_steps(rows, 0.5, 7)[take])
    with pytest.raises(InvalidArgumentError, match="rows"):
        rollouts.expert_steps(rows[0], 0.5, 7)


def test_the_expert_drives_the_share_of_steps_it_is_given() -> None:
    """Share 1: the expert's episodes, state for state. Share 0.5: a mix, different from both
    the expert's and the still learner's, and the same again when repeated."""
    config = env_config(PUSH)
    expert, _ = rollouts.collect(config, 4, first_seed=3, num_envs=2)
    mixed_all, stats = rollouts.collect(
        config, 4, first_seed=3, actor=_still, num_envs=2, expert_share=1.0
    )
    assert np.array_equal(mixed_all.observations, expert.observations)
    assert np.array_equal(mixed_all.actions, expert.actions)
    assert stats.success_rate == np.mean(expert.episode_success)
    alone, _ = rollouts.collect(config, 4, first_seed=3, actor=_still, num_envs=2)
    half, _ = rollouts.collect(config, 4, first_seed=3, actor=_still, num_envs=2, expert_share=0.5)
    again, _ = rollouts.collect(config, 4, first_seed=3, actor=_still, num_envs=2, expert_share=0.5)
    for other in (expert, alone):
        assert len(half) != len(other) or not np.array_equal(half.observations, other.observations)
    assert np.array_equal(half.observations, again.observations)
    # The labels are always the expert's, whoever drove.
    assert np.array_equal(
        half.actions, rollouts.ScriptedPolicy(config)._native.act(half.observations)
    )
    with pytest.raises(InvalidArgumentError, match="expert_share"):
        rollouts.collect(config, 1, first_seed=0, actor=_still, expert_share=1.5)


def test_each_round_gives_the_expert_beta_to_the_power_of_the_round(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    shares: list[float] = []
    collect = imitation.collect

    def recording(*args: Any, **kwargs: Any) -> Any:
        if kwargs.get("actor") is not None:
            shares.append(kwargs.get("expert_share", 0.0))
        return collect(*args, **kwargs)

    monkeypatch.setattr(imitation, "collect", recording)
    monkeypatch.setattr(imitation, "behaviour_cloning", lambda *a, **k: [0.0])
    model = tiny_bc_model(PUSH)
    short = dict(demo_episodes=2, rounds=3, episodes_per_round=2, epochs=1, epochs_per_round=1)
    short.update(first_seed=0, num_envs=2)
    imitation.dagger(model, env_config(PUSH), **short)
    assert shares == [0.0, 0.0, 0.0]
    shares.clear()
    imitation.dagger(model, env_config(PUSH), beta=0.5, **short)
    assert shares == [0.5, 0.25, 0.125]


def test_train_passes_the_recipe_beta_on(dagger_arguments: Any) -> None:
    assert dagger_arguments({})["beta"] == 0.0
    assert dagger_arguments({"dagger_beta": 0.6})["beta"] == 0.6
