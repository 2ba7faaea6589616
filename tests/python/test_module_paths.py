"""The package's layout of 0.2 (issue 56): the old flat module paths still import, with a
FutureWarning, as the very modules of their new homes; every shipped model file and recipe
file loads through the package's loaders without that warning; and every recipe resolves to
what it did before the layout changed."""

from __future__ import annotations

import importlib
import json
import sys
import warnings
from pathlib import Path
from typing import Any

import pytest

import panda_rapier
from panda_rapier._deprecated import (
    MOVED,
    REMOVED_IN,
    current_imports,
    current_name,
    current_paths,
    quiet_moved,
    same_class,
)
from panda_rapier.errors import ConfigError
from panda_rapier.learning.recipes import (
    ALGORITHMS,
    DEFAULT,
    default_recipe_path,
    load_recipe,
    model_kwargs,
    recipe_callbacks,
    recipe_ids,
    recipe_validation,
)

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
#: Every id's recipe and validation settings per algorithm as the recipe files of 0.1 gave them
#: (``None``: no recipe), loaded before the layout changed.
BEFORE = Path(__file__).with_name("recipes-0.1.json")
#: How the package's recipes import the normaliser in their expressions now.
NEW_IMPORT = "__import__('panda_rapier.learning.normalization').learning.normalization."


def _fresh_import(name: str) -> Any:
    """Imports ``name`` as if for the first time (the alias module runs again)."""
    sys.modules.pop(name, None)
    parent, _, child = name.rpartition(".")
    if hasattr(sys.modules[parent], child):
        delattr(sys.modules[parent], child)
    return importlib.import_module(name)


@pytest.mark.parametrize("old", [m for m in MOVED if m != "panda_rapier.training"])
def test_old_module_paths_warn_and_are_the_new_modules(old: str) -> None:
    new = MOVED[old]
    with pytest.warns(FutureWarning, match=rf"{old} is deprecated .* {REMOVED_IN}: import {new}"):
        module = _fresh_import(old)
    assert module is importlib.import_module(new)
    assert sys.modules[old] is module
    # `import panda_rapier.X` binds the new module too.
    assert getattr(panda_rapier, old.rpartition(".")[2]) is module


def test_old_class_paths_resolve_to_the_same_classes() -> None:
    """What shipped zips and recipes name."""
    from panda_rapier.learning import exploration, finetune, normalization, ppo, student

    with pytest.warns(FutureWarning):
        old_normalization = _fresh_import("panda_rapier.normalization")
    assert old_normalization.NormalizedFlatten is normalization.NormalizedFlatten
    with pytest.warns(FutureWarning):
        assert _fresh_import("panda_rapier.student").PixelEncoder is student.PixelEncoder
    with pytest.warns(FutureWarning):
        assert _fresh_import("panda_rapier.exploration").MinActionStd is exploration.MinActionStd
    with pytest.warns(FutureWarning):
        assert _fresh_import("panda_rapier.finetune").CriticWarmup is finetune.CriticWarmup
    with pytest.warns(FutureWarning):
        assert _fresh_import("panda_rapier.ppo").PPO is ppo.PPO


def test_old_training_module_re_exports_its_names() -> None:
    from panda_rapier.agents import model_file
    from panda_rapier.learning import recipes, runner, runs

    with pytest.warns(FutureWarning, match="panda_rapier.training is deprecated"):
        training = _fresh_import("panda_rapier.training")
    assert training.train is runner.train
    assert training.load_recipe is recipes.load_recipe
    assert training.ALGORITHMS is recipes.ALGORITHMS
    assert training.recipe_validation is recipes.recipe_validation
    assert training.stop_reason is runs.stop_reason
    assert training.read_run_info is model_file.read_run_info
    assert training.TRAIN_FIRST_SEED == 1_000_000_000
    assert training.VALIDATION_FIRST_SEED == 500_000_000
    assert set(training.__all__) <= set(dir(training))


def test_quiet_moved_silences_only_the_alias_warnings() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with quiet_moved():
            _fresh_import("panda_rapier.checkpoint")
            with pytest.warns(FutureWarning, match="other"):
                warnings.warn("other", FutureWarning, stacklevel=1)


def test_recipes_naming_old_module_paths_train_alike() -> None:
    """A recipe of 0.1 names NormalizedFlatten and its callbacks by their old modules; it
    trains as the package's recipe that names the new ones (so models-table finds the
    package's recipe for the PPO models trained then)."""
    from panda_rapier.learning.recipes import recipes_train_alike

    old = "__import__('panda_rapier.normalization').normalization.NormalizedFlatten"
    assert current_imports(f"dict(features_extractor_class={old})") == (
        f"dict(features_extractor_class={NEW_IMPORT}NormalizedFlatten)"
    )
    assert current_imports("nn.ReLU") == "nn.ReLU"
    recipe = load_recipe("ppo", "panda_rapier/LiftDense-v0")
    assert NEW_IMPORT in recipe["policy_kwargs"]
    before = {**recipe, "policy_kwargs": recipe["policy_kwargs"].replace(NEW_IMPORT, old[:-17])}
    assert before != recipe and recipes_train_alike(before, recipe)
    # Callbacks named by their old modules, as the shipped PPO models' run records have them.
    callbacks = ["panda_rapier.normalization.FitNormalizerCallback",
                 {"panda_rapier.exploration.MinActionStd": {"min_std": 0.3}}]  # fmt: skip
    assert current_paths(callbacks) == [
        "panda_rapier.learning.normalization.FitNormalizerCallback",
        {"panda_rapier.learning.exploration.MinActionStd": {"min_std": 0.3}},
    ]
    assert recipes_train_alike(
        {**before, "callback": callbacks}, {**recipe, "callback": current_paths(callbacks)}
    )
    assert not recipes_train_alike({**before, "n_steps": 1}, recipe)


def test_class_names_compare_across_old_and_new_paths() -> None:
    assert current_name("panda_rapier.ppo.PPO") == "panda_rapier.learning.ppo.PPO"
    assert current_name("stable_baselines3.ppo.ppo.PPO") == "stable_baselines3.ppo.ppo.PPO"
    assert same_class("panda_rapier.ppo.PPO", "panda_rapier.learning.ppo.PPO")
    assert not same_class("stable_baselines3.ppo.ppo.PPO", "panda_rapier.learning.ppo.PPO")


def test_seed_plan_is_read_from_one_module() -> None:
    from panda_rapier import seeds
    from panda_rapier.learning import demos, normalization
    from panda_rapier.scale import rllib

    assert normalization.FIT_FIRST_SEED is seeds.FIT_FIRST_SEED
    assert rllib.RLLIB_FIRST_SEED is seeds.RLLIB_FIRST_SEED == seeds.FIT_FIRST_SEED
    assert rllib.MAX_RUN_SEED is seeds.MAX_RUN_SEED
    assert demos.DEFAULT_FIRST_SEED == seeds.DEMOS_FIRST_SEED == 3_000_000_000
    # The ranges in order, apart: test < validation < training < fit/RLlib < demonstrations.
    assert (seeds.TEST_FIRST_SEED < seeds.VALIDATION_FIRST_SEED < seeds.TRAIN_FIRST_SEED
            < seeds.FIT_FIRST_SEED < seeds.DEMOS_FIRST_SEED)  # fmt: skip
    top = seeds.RLLIB_FIRST_SEED + seeds.RLLIB_SEED_STRIDE * seeds.MAX_RUN_SEED
    assert top <= seeds.DEMOS_FIRST_SEED


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_every_id_loads_the_recipe_it_had_before_the_layout_changed(algo: str) -> None:
    """Pinned from the recipe files of 0.1 (bc.yml then listed all 28 ids, now its default
    serves them); class paths are compared by their new names. Ids added since have nothing
    to keep. The tqc entries were changed on purpose on 2026-11-30 and pinned again: rl-zoo3's
    panda-gym hyperparameters, unchanged, for every matching id (CHANGELOG)."""
    before = json.loads(BEFORE.read_text())
    pinned = [key.split(" ", 1)[1] for key in before if key.startswith(f"{algo} ")]
    assert set(pinned) <= set(panda_rapier.ENV_IDS), "every id of 0.1 is still registered"
    for env_id in pinned:
        try:
            now: Any = {
                "recipe": load_recipe(algo, env_id),
                "validation": recipe_validation(env_id, None, algo),
            }
        except ConfigError:
            now = None
        assert json.loads(json.dumps(now)) == current_paths(before[f"{algo} {env_id}"]), env_id


def test_a_recipe_file_default_serves_every_id_it_does_not_list(tmp_path: Path) -> None:
    conf = tmp_path / "bc.yml"
    conf.write_text(
        "default: {epochs: 3}\n"
        "panda_rapier/Reach-v0: {epochs: 5}\n"
        "validation: {panda_rapier/Reach-v0: {every: 100}}\n"
    )
    assert load_recipe("bc", "panda_rapier/Reach-v0", conf)["epochs"] == 5
    assert load_recipe("bc", "panda_rapier/Lift-v0", conf)["epochs"] == 3
    assert recipe_ids("bc", conf) == ["panda_rapier/Reach-v0"]
    with pytest.raises(ConfigError, match="not an environment id"):
        load_recipe("bc", DEFAULT, conf)
    # Without a default an unlisted id still has no recipe.
    conf.write_text("panda_rapier/Reach-v0: {epochs: 5}\n")
    with pytest.raises(ConfigError, match="no recipe for panda_rapier/Lift-v0"):
        load_recipe("bc", "panda_rapier/Lift-v0", conf)
    assert recipe_ids("bc") == []  # the package's bc.yml: the default only


def _recipe_files() -> list[tuple[str, Path | None]]:
    files: list[tuple[str, Path | None]] = [
        (algo, None) for algo in ALGORITHMS if default_recipe_path(algo).is_file()
    ]
    files += [(path.stem.split("-")[0], path) for path in sorted(MODELS.glob("recipes/*.yml"))]
    return files


@pytest.mark.parametrize(
    ("algo", "conf"), _recipe_files(), ids=lambda x: Path(x).name if x is not None else "package"
)
def test_every_recipe_file_loads_and_builds(algo: str, conf: Path | None) -> None:
    """Every recipe of the package's files and of models/recipes loads, and its arguments
    (expressions evaluated) and callbacks build, without an old path's warning
    (models/recipes name old class paths)."""
    pytest.importorskip("stable_baselines3")
    ids = recipe_ids(algo, conf) or list(panda_rapier.ENV_IDS)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FutureWarning)
        for env_id in ids:
            recipe = load_recipe(algo, env_id, conf)
            if algo == "bc":
                continue
            model_kwargs(algo, recipe)
            recipe_callbacks(recipe.get("callback"))


@pytest.mark.parametrize("name", sorted(p.name for p in MODELS.glob("*.zip")))
def test_every_shipped_model_loads_through_the_package(name: str) -> None:
    """Shipped zips name the old class paths in their pickled data: the package's loader
    reads them as the new classes, and says nothing about it."""
    pytest.importorskip("stable_baselines3")
    from panda_rapier.agents.model_file import load_sb3_model, read_run_info

    path = MODELS / name
    run = read_run_info(path) or {}
    for old in MOVED:  # the old paths not imported yet: their aliases would warn
        sys.modules.pop(old, None)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FutureWarning)
        model = load_sb3_model(path, algo=str(run.get("saved_algo") or "") or None, trust=True)
    extractor = type(model.policy.features_extractor)
    assert extractor.__module__ not in MOVED  # the class itself, of its new module
