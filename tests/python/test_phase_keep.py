"""A bc recipe's ``phase_keep``: of the states in a listed phase of the expert's, the fits use
that fraction (:func:`panda_rapier.learning.imitation.phase_row_keep`), the same rows in every
fit; checked when the recipe loads and when the expert's demonstrations are in. Without the key
every row is fitted, as before."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")

import torch as th  # noqa: E402
from conftest import tiny_bc_model  # noqa: E402

from panda_rapier import ConfigError, InvalidArgumentError, ScriptedPolicy  # noqa: E402
from panda_rapier.learning import imitation  # noqa: E402
from panda_rapier.learning.recipes import BC_KEYS, load_recipe, phase_keep  # noqa: E402
from panda_rapier.learning.rollouts import collect  # noqa: E402
from panda_rapier.registration import env_config  # noqa: E402

th.set_num_threads(1)

SLIDE = "panda_rapier/Slide-v0"


@pytest.fixture(scope="module")
def slide_rows() -> Any:
    data, _ = collect(env_config(SLIDE), 8, first_seed=100, num_envs=8)
    return data


def test_a_recipe_without_the_key_loads_as_before(bc_recipe: Any) -> None:
    assert set(load_recipe("bc", SLIDE, bc_recipe({"epochs": 3}))) == set(BC_KEYS)
    recipe = load_recipe("bc", SLIDE, bc_recipe({"phase_keep": {"wait": 0.25}}))
    assert recipe["phase_keep"] == {"wait": 0.25}
    assert phase_keep({"wait": 1}) == {"wait": 1.0}


@pytest.mark.parametrize(
    "value",
    [{}, [0.5], 0.5, None, {"wait": 0}, {"wait": 1.5}, {"wait": -0.1}, {"wait": math.nan},
     {"wait": True}, {"wait": "half"}, {3: 0.5}],
)  # fmt: skip
def test_bad_values_name_the_key(bc_recipe: Any, value: object) -> None:
    with pytest.raises(ConfigError, match="'phase_keep'"):
        load_recipe("bc", SLIDE, bc_recipe({"phase_keep": value}))


def test_rows_of_a_listed_phase_are_thinned_by_the_row_alone(slide_rows: Any) -> None:
    config = env_config(SLIDE)
    phases = np.array(ScriptedPolicy(config).phases(slide_rows.observations))
    wait = phases == "wait"
    assert 0.5 < wait.mean() < 0.9, "the hand waits above the sliding cube in most rows"
    keep, seen = imitation.phase_row_keep(config, slide_rows.observations, {"wait": 0.25})
    assert "wait" in seen and keep.dtype == bool and keep.shape == (len(slide_rows),)
    assert keep[~wait].all(), "rows of unlisted phases are all kept"
    assert 0.15 < keep[wait].mean() < 0.35
    # A function of each row alone: the same for any split, and for the rows reversed.
    halves = [
        imitation.phase_row_keep(config, part, {"wait": 0.25})[0]
        for part in np.array_split(slide_rows.observations, 3)
    ]
    assert np.array_equal(np.concatenate(halves), keep)
    assert imitation.phase_row_keep(config, slide_rows.observations, {"wait": 1.0})[0].all()


def test_dataset_rows_by_mask(slide_rows: Any) -> None:
    mask = np.arange(len(slide_rows)) % 3 == 0
    part = slide_rows.rows(mask)
    assert len(part) == mask.sum()
    assert np.array_equal(part.actions, slide_rows.actions[mask])
    assert np.array_equal(part.episode_index, slide_rows.episode_index[mask])
    assert part.episode_seeds == slide_rows.episode_seeds
    with pytest.raises(InvalidArgumentError, match="mask"):
        slide_rows.rows(mask[:-1])


def test_every_fit_uses_the_kept_rows_and_their_weights(monkeypatch: pytest.MonkeyPatch) -> None:
    """With ``phase_keep`` each fit gets the kept rows (and the weights of those rows); the
    dataset returned holds every row."""
    fits: list[tuple[int, int, float | None]] = []

    def fit(model: Any, demos: Any, *, weights: Any = None, **_: Any) -> list[float]:
        waits = np.array(ScriptedPolicy(demos.config).phases(demos.observations)) == "wait"
        assert weights is None or len(weights) == len(demos)
        heavy = None if weights is None else float(np.max(weights))
        fits.append((len(demos), int(waits.sum()), heavy))
        return [0.0]

    monkeypatch.setattr(imitation, "behaviour_cloning", fit)
    short = dict(demo_episodes=4, rounds=2, episodes_per_round=4, epochs=1, epochs_per_round=1)
    short.update(final_epochs=1, first_seed=0, num_envs=4)
    data = imitation.dagger(tiny_bc_model(SLIDE), env_config(SLIDE), **short)
    n = len(data) // 3  # 4 episodes of the same length a fit
    assert [n for n, _, _ in fits] == [n, 2 * n, 3 * n, 3 * n]
    full = fits.copy()
    fits.clear()
    imitation.dagger(
        tiny_bc_model(SLIDE), env_config(SLIDE), phase_keep={"wait": 0.25},
        phase_weights={"slide": 5.0}, **short,
    )  # fmt: skip
    for (n, waits, heavy), (n_all, waits_all, _) in zip(fits, full, strict=True):
        assert waits < 0.45 * waits_all, "about a quarter of the waiting rows are fitted"
        assert n - waits == n_all - waits_all, "every other row is fitted"
        assert heavy == 5.0
    with pytest.raises(ConfigError, match=r"'phase_keep' names \['wiat'\]"):
        imitation.dagger(tiny_bc_model(SLIDE), env_config(SLIDE), phase_keep={"wiat": 0.5}, **short)


def test_train_passes_the_recipe_key_on(dagger_arguments: Any) -> None:
    assert dagger_arguments({})["phase_keep"] is None
    assert dagger_arguments({"phase_keep": {"wait": 0.5}})["phase_keep"] == {"wait": 0.5}
