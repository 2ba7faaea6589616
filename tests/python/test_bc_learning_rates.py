"""A bc recipe's ``dagger_learning_rate`` and ``final_learning_rate``: the learning rates the
DAgger rounds' fits and the final fit start from (:func:`panda_rapier.learning.imitation.dagger`),
checked when the recipe loads; without them every fit starts from ``learning_rate``, as before."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")

import torch as th  # noqa: E402
from conftest import tiny_bc_model  # noqa: E402

from panda_rapier import ConfigError  # noqa: E402
from panda_rapier.learning import imitation  # noqa: E402
from panda_rapier.learning.recipes import BC_KEYS, bc_learning_rate, load_recipe  # noqa: E402
from panda_rapier.registration import env_config  # noqa: E402

th.set_num_threads(1)

REACH = "panda_rapier/Reach-v0"
SLIDE = "panda_rapier/Slide-v0"


def test_a_recipe_without_the_keys_loads_as_before(bc_recipe: Any) -> None:
    recipe = load_recipe("bc", SLIDE, bc_recipe({"epochs": 3}))
    assert set(recipe) == set(BC_KEYS)
    rates = {"dagger_learning_rate": 3e-4, "final_learning_rate": 1e-4}
    recipe = load_recipe("bc", SLIDE, bc_recipe(rates))
    assert recipe["dagger_learning_rate"] == 3e-4 and recipe["final_learning_rate"] == 1e-4
    assert recipe["learning_rate"] == BC_KEYS["learning_rate"]


def test_yaml_numbers_read_as_strings_are_numbers(tmp_path: Path) -> None:
    """YAML 1.1 reads ``1e-3`` (no dot) as a string; recipes written so trained before the
    check and still do."""
    path = tmp_path / "bc.yml"
    path.write_text(f"{SLIDE}:\n  learning_rate: 1e-3\n  dagger_learning_rate: 3e-4\n")
    recipe = load_recipe("bc", SLIDE, path)
    assert recipe["dagger_learning_rate"] == "3e-4"
    assert bc_learning_rate("dagger_learning_rate", recipe["dagger_learning_rate"]) == 3e-4


@pytest.mark.parametrize("key", ["learning_rate", "dagger_learning_rate", "final_learning_rate"])
@pytest.mark.parametrize("value", [0, -1e-3, math.nan, math.inf, True, "fast", None, [1e-3]])
def test_bad_learning_rates_name_the_key(bc_recipe: Any, key: str, value: object) -> None:
    with pytest.raises(ConfigError, match=f"'{key}' must be a finite number > 0"):
        load_recipe("bc", SLIDE, bc_recipe({key: value}))


def test_each_fit_starts_from_its_learning_rate(monkeypatch: pytest.MonkeyPatch) -> None:
    """The first fit starts from ``learning_rate``, each round's from ``dagger_learning_rate``
    and the final fit from ``final_learning_rate``; either left out is ``learning_rate``."""
    calls: list[float] = []

    def fit(model: Any, demos: Any, *, learning_rate: float, **_: Any) -> list[float]:
        calls.append(learning_rate)
        return [0.0]

    monkeypatch.setattr(imitation, "behaviour_cloning", fit)
    model = tiny_bc_model(REACH)
    short = dict(demo_episodes=2, rounds=2, episodes_per_round=2, epochs=1, epochs_per_round=1)
    short.update(final_epochs=1, first_seed=0, num_envs=2)
    config = env_config(REACH)
    imitation.dagger(model, config, learning_rate=1e-3, **short)
    assert calls == [1e-3, 1e-3, 1e-3, 1e-3]
    calls.clear()
    imitation.dagger(model, config, learning_rate=1e-3, dagger_learning_rate=3e-4, **short)
    assert calls == [1e-3, 3e-4, 3e-4, 1e-3]
    calls.clear()
    imitation.dagger(
        model, config, learning_rate=1e-3, dagger_learning_rate=3e-4, final_learning_rate=1e-4,
        **short,
    )  # fmt: skip
    assert calls == [1e-3, 3e-4, 3e-4, 1e-4]


def test_train_passes_the_recipe_rates_on(dagger_arguments: Any) -> None:
    """``panda-rapier train --algo bc`` hands the recipe's rates to :func:`dagger`."""
    seen = dagger_arguments({"learning_rate": "2e-3", "final_learning_rate": 1e-4})
    assert seen["learning_rate"] == 2e-3
    assert seen["dagger_learning_rate"] is None and seen["final_learning_rate"] == 1e-4
