"""Recipes: the hyperparameters ``panda-rapier train`` reads, and how a run validates.

A recipe file is in rl-zoo3's YAML format, a mapping from env id to hyperparameters (the
package's own in ``panda_rapier/learning/hyperparams/ALGO.yml``), so ``python -m
rl_zoo3.train --algo ppo --env ID --gym-packages panda_rapier -conf FILE`` reads the same file.
Two top-level keys are not ids:

- ``default``: the recipe of every id the file does not list (``hyperparams/bc.yml`` has only
  this one, so a new id needs no line of its own; rl-zoo3 reads only the ids' entries);
- ``validation`` (:data:`VALIDATION`): how each id's runs are validated, stopped and finished.

``bc`` (behaviour cloning and DAgger from the scripted expert,
:mod:`panda_rapier.learning.imitation`) is ours; its recipe has its own keys
(:data:`BC_KEYS`, or :data:`STUDENT_KEYS` with a ``student`` entry) and it saves a PPO model.

Reading a recipe needs PyYAML (the ``train`` extra) but no torch: ``panda-rapier models``
reads recipes, and only turning one into an algorithm's arguments (:func:`model_kwargs`)
imports torch and stable-baselines3.

Over 600 lines: reading and checking every recipe key of every algorithm (rl-zoo3's, bc's,
``normalize``, ``train_env_kwargs``), validation settings and the expressions rl-zoo3 writes in
them, kept in one place so that each key has one definition.
"""

from __future__ import annotations

import importlib
import json
import math
from collections.abc import Callable, Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from .._deprecated import current_paths, quiet_moved
from ..errors import ConfigError, InvalidArgumentError

__all__ = [
    "ALGORITHMS",
    "BC_KEYS",
    "BC_LEARNING_RATES",
    "BC_OPTIONAL_KEYS",
    "DEFAULT",
    "FINAL_CHOICES",
    "NORMALIZE_DEFAULTS",
    "STUDENT_KEYS",
    "VALIDATION",
    "VALIDATION_DEFAULTS",
    "algorithm_class",
    "bc_learning_rate",
    "dagger_beta",
    "default_recipe_path",
    "evaluate_expression",
    "load_recipe",
    "model_kwargs",
    "normalize_settings",
    "phase_keep",
    "phase_weights",
    "recipe_callbacks",
    "recipe_ids",
    "recipe_normalization",
    "recipe_validation",
    "recipes_train_alike",
    "resolve_validation",
    "train_env_kwargs",
]

#: Algorithms ``panda-rapier train`` knows.
ALGORITHMS = ("ppo", "sac", "tqc", "bc")
# Recipe keys that configure the run rather than the algorithm (rl-zoo3's names, and
# `train_env_kwargs`, ours: rl-zoo3 does not read it).
# `monitor_kwargs` only matters to rl-zoo3 (its Monitor wrappers); the native VecEnv reports
# `is_success` and `is_placed` in every info, and the periodic evaluations log both.
_RUN_KEYS = (
    "n_timesteps",
    "policy",
    "n_envs",
    "env_kwargs",
    "train_env_kwargs",
    "callback",
    "normalize",
    "monitor_kwargs",
)
_UNSUPPORTED = ("frame_stack", "env_wrapper", "vec_env_wrapper")
# Recipe keys ``panda-rapier train`` does not read at all.
_ZOO_ONLY_KEYS = ("monitor_kwargs",)
#: A bc recipe's keys and what each is when the recipe does not set it.
BC_KEYS = {
    "policy": "MultiInputPolicy",
    "policy_kwargs": None,
    "n_envs": 32,
    "demo_episodes": 200,
    "dagger_rounds": 8,
    "dagger_episodes": 250,
    "epochs": 30,
    "dagger_epochs": 10,
    "final_epochs": 20,
    "batch_size": 256,
    "learning_rate": 1e-3,
}
#: bc recipe keys that have no default: a recipe without them trains as it did before they
#: existed. ``phase_weights`` maps the expert's phases (:meth:`~panda_rapier.ScriptedPolicy.phases`)
#: to the weight of their states in the cloning loss (others weigh 1; :func:`phase_weights`).
#: ``dagger_learning_rate`` and ``final_learning_rate`` are the learning rates the DAgger
#: rounds' fits and the final fit start from (without them, ``learning_rate``, as the first
#: fit's; :func:`bc_learning_rate`). ``dagger_beta`` is p in DAgger's mixed policy: in round
#: r the expert takes each of the learner's steps with probability p**r (without it, 0: the
#: learner drives alone; :func:`dagger_beta`). ``phase_keep`` maps phases to the fraction of
#: their rows the fits use (others: all; :func:`phase_keep`).
BC_OPTIONAL_KEYS = (
    "phase_weights",
    "dagger_learning_rate",
    "final_learning_rate",
    "dagger_beta",
    "phase_keep",
)
#: A bc recipe's learning rates, each checked by :func:`bc_learning_rate`.
BC_LEARNING_RATES = ("learning_rate", "dagger_learning_rate", "final_learning_rate")
#: A bc recipe with a ``student`` entry (DAgger of a policy that sees,
#: :mod:`panda_rapier.learning.student`): its keys and their defaults.
STUDENT_KEYS = {
    "env_kwargs": None,
    "student": None,
    "n_envs": 32,
    "demo_episodes": 200,
    "dagger_rounds": 8,
    "dagger_episodes": 200,
    "first_updates": 3000,
    "round_updates": 1500,
    "final_updates": 4000,
    "batch_size": 128,
    "learning_rate": 3e-4,
}


def _yaml() -> Any:
    try:
        import yaml
    except ImportError as error:  # pragma: no cover - part of the train extra
        raise ImportError("recipes need PyYAML: pip install 'panda-rapier[train]'") from error
    return yaml


def default_recipe_path(algo: str) -> Path:
    """The package's recipe file for ``algo``."""
    return Path(str(resources.files("panda_rapier.learning") / "hyperparams" / f"{algo}.yml"))


def _recipe_file(algo: str, conf: str | Path | None) -> tuple[Path, Any]:
    """The recipe file ``conf`` (else the package's for ``algo``) and its parsed content."""
    path = Path(conf) if conf is not None else default_recipe_path(algo)
    try:
        return path, _yaml().safe_load(path.read_text())
    except OSError as error:
        raise ConfigError(f"cannot read the recipe file {path}: {error}") from error


#: The top-level key of a recipe file whose entry is the recipe of every id the file does not
#: list (rl-zoo3 reads only the ids' entries, so the file stays an rl-zoo3 recipe file).
DEFAULT = "default"


def recipe_ids(algo: str, conf: str | Path | None = None) -> list[str]:
    """The env ids a recipe file (``conf``, else the package's for ``algo``) lists by name:
    its top-level keys but :data:`DEFAULT`, :data:`VALIDATION` and those starting with ``_``
    (entries that only hold a YAML anchor)."""
    _, recipes = _recipe_file(algo, conf)
    if not isinstance(recipes, Mapping):
        return []
    return sorted(
        str(k) for k in recipes if k not in (DEFAULT, VALIDATION) and not str(k).startswith("_")
    )


def load_recipe(algo: str, env_id: str, conf: str | Path | None = None) -> dict[str, Any]:
    """The hyperparameters of ``algo`` on ``env_id`` from a recipe file (rl-zoo3's format:
    a mapping from env id to hyperparameters; default: the package's ``hyperparams/ALGO.yml``).
    An id the file does not list takes its :data:`DEFAULT` entry, if it has one."""
    if algo not in ALGORITHMS:
        raise InvalidArgumentError(f"algo must be one of {ALGORITHMS}, got {algo!r}")
    path, recipes = _recipe_file(algo, conf)
    if env_id in (DEFAULT, VALIDATION):
        raise ConfigError(f"{env_id!r} is not an environment id")
    if isinstance(recipes, Mapping) and env_id not in recipes and DEFAULT in recipes:
        entry = recipes[DEFAULT]
    elif isinstance(recipes, Mapping) and env_id in recipes:
        entry = recipes[env_id]
    else:
        known = sorted(recipes) if isinstance(recipes, Mapping) else []
        raise ConfigError(f"{path} has no recipe for {env_id}; it has {known}")
    recipe = dict(entry or {})
    for key in _UNSUPPORTED:
        if key in recipe:
            raise ConfigError(f"recipe key {key!r} is not supported by panda-rapier train")
    if "train_env_kwargs" in recipe:
        train_env_kwargs(recipe, algo)
    if "normalize" in recipe:
        if algo == "bc":
            raise ConfigError("recipe key 'normalize' is for ppo, sac and tqc, not bc")
        if not isinstance(recipe["normalize"], str):  # a string needs evaluating: on use
            normalize_settings(recipe["normalize"], recipe.get("gamma"))
    if algo == "bc":
        student = "student" in recipe
        keys = STUDENT_KEYS if student else BC_KEYS
        known = list(keys) if student else [*keys, *BC_OPTIONAL_KEYS]
        unknown = set(recipe) - set(known)
        if unknown:
            raise ConfigError(f"unknown bc recipe keys {sorted(unknown)}; known: {known}")
        if "phase_weights" in recipe:
            phase_weights(recipe["phase_weights"])
        for key in BC_LEARNING_RATES:
            if key in recipe:
                bc_learning_rate(key, recipe[key])
        if "dagger_beta" in recipe:
            dagger_beta(recipe["dagger_beta"])
        if "phase_keep" in recipe:
            phase_keep(recipe["phase_keep"])
        return {**keys, **recipe}
    return recipe


def bc_learning_rate(key: str, value: Any) -> float:
    """A bc recipe's learning rate ``key`` (``learning_rate``, ``dagger_learning_rate`` or
    ``final_learning_rate``), checked: a finite number > 0. Raises
    :class:`~panda_rapier.errors.ConfigError` naming the key. A string that reads as a number
    is one (YAML 1.1 reads ``1e-3`` without a dot as a string; rl-zoo3's files write
    ``!!float 1e-3``)."""
    rate = math.nan
    if isinstance(value, (int, float, str)) and not isinstance(value, bool):
        try:
            rate = float(value)
        except ValueError:
            pass
    if not math.isfinite(rate) or rate <= 0.0:
        raise ConfigError(
            f"recipe key {key!r} must be a finite number > 0, e.g. !!float 3e-4; got {value!r}"
        )
    return rate


def dagger_beta(value: Any) -> float:
    """A bc recipe's ``dagger_beta``, checked: a number in [0, 1). It is p in DAgger's mixed
    policy (Ross et al., 2011, beta_i = p^i): in round r the expert takes each step of the
    learner's rollouts with probability p**r, so the early rounds, when the learner is
    weakest, gather states nearer the expert's. 0: the learner drives alone (DAgger as before
    the key). Raises :class:`~panda_rapier.errors.ConfigError` naming the key."""
    beta = math.nan
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        beta = float(value)
    if not 0.0 <= beta < 1.0:  # NaN fails both
        raise ConfigError(
            "recipe key 'dagger_beta' must be a number in [0, 1) (in round r the expert takes "
            f"each of the learner's steps with probability dagger_beta**r), e.g. 0.5; got {value!r}"
        )
    return beta


def _phase_map(
    key: str, value: Any, ok: Callable[[float], bool], texts: tuple[str, str, str, str]
) -> dict[str, float]:
    """A bc recipe's mapping ``key`` from the scripted expert's phase names to numbers, each
    ``ok``: checked, as floats. ``texts`` word the
    :class:`~panda_rapier.errors.ConfigError` that names the key: what the numbers are
    (``weights``), what one is (``the weight``), what it must be, and an example mapping."""
    values, what, expects, example = texts
    if not isinstance(value, Mapping) or not value:
        raise ConfigError(
            f"recipe key {key!r} must map the expert's phase names to {values}, e.g. {example}; "
            f"got {value!r}"
        )
    numbers: dict[str, float] = {}
    for name, number in value.items():
        if not isinstance(name, str) or not name:
            raise ConfigError(f"recipe key {key!r} needs phase names as keys; got {name!r}")
        valid = isinstance(number, (int, float)) and not isinstance(number, bool)
        if not valid or not ok(float(number)):  # NaN fails every check
            raise ConfigError(
                f"recipe key {key!r}: {what} of phase {name!r} must be {expects}; got {number!r}"
            )
        numbers[name] = float(number)
    return numbers


def phase_keep(value: Any) -> dict[str, float]:
    """A bc recipe's ``phase_keep``, checked: a mapping from the scripted expert's phase names
    to fractions in (0, 1]. Of the states the expert labels with a listed phase, each fit uses
    that fraction (the same rows in every fit, drawn from the rows themselves), the others
    all: a phase that fills most rows but asks little (Slide's wait, 72 % of them) then
    costs the fits less time. Raises :class:`~panda_rapier.errors.ConfigError` naming the
    key."""
    texts = ("the fraction of their rows the fits use", "the fraction", "a number in (0, 1]",
             "{wait: 0.2}")  # fmt: skip
    return _phase_map("phase_keep", value, lambda f: 0.0 < f <= 1.0, texts)


def phase_weights(value: Any) -> dict[str, float]:
    """A bc recipe's ``phase_weights``, checked: a mapping from the scripted expert's phase
    names (``slide``, ``let_go``, ...) to finite weights >= 0. The states the expert labels
    with a listed phase weigh that much in the cloning loss, every other state 1, so a phase
    that decides the outcome but fills few rows (Slide's speed-up, about 6 % of them) is
    fitted more closely. Raises :class:`~panda_rapier.errors.ConfigError` naming the key."""
    texts = ("weights", "the weight", "a finite number >= 0", "{slide: 4.0, let_go: 4.0}")
    return _phase_map("phase_weights", value, lambda w: math.isfinite(w) and w >= 0.0, texts)


#: What a recipe's ``normalize`` may set (``VecNormalize``'s arguments, rl-zoo3's meaning) and
#: what each is when it does not; ``gamma`` is the recipe's own when it has one, as rl-zoo3
#: makes it.
NORMALIZE_DEFAULTS: dict[str, Any] = {
    "norm_obs": True,
    "norm_reward": True,
    "clip_obs": 10.0,
    "clip_reward": 10.0,
    "gamma": 0.99,
    "epsilon": 1e-8,
}


def normalize_settings(value: Any, gamma: Any = None) -> dict[str, Any] | None:
    """A recipe's ``normalize`` (rl-zoo3's forms: ``true``/``false``, a mapping of
    ``VecNormalize``'s arguments, or that mapping as a string once :func:`evaluate_expression`
    has read it) as :data:`NORMALIZE_DEFAULTS`' keys, or ``None`` when it normalises nothing.
    A bad value is a :class:`~panda_rapier.errors.ConfigError` naming the key."""
    if value is None or value is False:
        return None
    given: Mapping[str, Any] = {} if value is True else value
    if not isinstance(given, Mapping):
        raise ConfigError(
            "recipe key 'normalize' must be true, false or a mapping of VecNormalize's "
            f"arguments {sorted(NORMALIZE_DEFAULTS)}, got {value!r}"
        )
    unknown = set(given) - set(NORMALIZE_DEFAULTS)
    if unknown:
        raise ConfigError(
            f"recipe key 'normalize' has unknown arguments {sorted(unknown)}; known: "
            f"{sorted(NORMALIZE_DEFAULTS)}"
        )
    settings = dict(NORMALIZE_DEFAULTS)
    if gamma is not None:
        settings["gamma"] = gamma
    settings.update(given)
    for key in ("norm_obs", "norm_reward"):
        if not isinstance(settings[key], bool):
            raise ConfigError(f"recipe key 'normalize': {key} must be true or false")
    for key in ("clip_obs", "clip_reward", "gamma", "epsilon"):
        number = settings[key]
        if isinstance(number, bool) or not isinstance(number, int | float):
            raise ConfigError(f"recipe key 'normalize': {key} must be a number, got {number!r}")
        if not math.isfinite(number) or number <= 0 or (key == "gamma" and number > 1):
            raise ConfigError(
                f"recipe key 'normalize': {key} must be "
                + ("in (0, 1]" if key == "gamma" else "a positive finite number")
                + f", got {number!r}"
            )
        settings[key] = float(number)
    if not settings["norm_obs"] and not settings["norm_reward"]:
        return None
    return settings


def train_env_kwargs(recipe: Mapping[str, Any], algo: str = "ppo") -> dict[str, Any]:
    """A recipe's ``train_env_kwargs``: environment options for the training environments
    only, on top of ``env_kwargs`` (a start-state curriculum, such as Stack's
    ``task.cube1_on_goal_probability``; merged into them by :func:`merge_options`, so a
    section such as ``task`` keeps the ``env_kwargs`` entries it does not set). The periodic
    evaluations, the run record's
    ``env_kwargs`` and so the saved model's environment (what ``panda-rapier eval`` acts in)
    are ``env_kwargs``' alone; the record keeps these under ``train_env_kwargs``. ``{}`` when
    the recipe has none; anything but a mapping, or the key in a bc recipe, is a
    :class:`~panda_rapier.errors.ConfigError` naming it."""
    value = recipe.get("train_env_kwargs")
    if value is None:
        return {}
    if algo == "bc":
        raise ConfigError("recipe key 'train_env_kwargs' is for ppo, sac and tqc, not bc")
    if not isinstance(value, Mapping):
        raise ConfigError(
            "recipe key 'train_env_kwargs' must be a mapping of environment options (as "
            f"env_kwargs), got {value!r}"
        )
    return dict(value)


def merge_options(base: Mapping[str, Any], extra: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``extra`` on top, section by section: where both give a mapping under the
    same key (``task``, ``reward_weights``) the two are merged the same way, ``extra``'s entries
    winning; any other value of ``extra`` replaces ``base``'s."""
    merged = dict(base)
    for key, value in extra.items():
        below = merged.get(key)
        if isinstance(value, Mapping) and isinstance(below, Mapping):
            merged[key] = merge_options(below, value)
        else:
            merged[key] = value
    return merged


def recipe_normalization(recipe: Mapping[str, Any]) -> dict[str, Any] | None:
    """The recipe's ``normalize`` as :func:`normalize_settings` reads it (a string evaluated
    as rl-zoo3 does), checked against its ``policy_kwargs``: observations are standardised
    once, so a recipe that also names a ``features_extractor_class`` is refused."""
    value = recipe.get("normalize")
    if isinstance(value, str):
        try:
            value = evaluate_expression(value)
        except ConfigError as error:
            raise ConfigError(
                "recipe key 'normalize' must be true, false or a mapping of VecNormalize's "
                f"arguments {sorted(NORMALIZE_DEFAULTS)} (or such a dict as a string): {error}"
            ) from error
    settings = normalize_settings(value, recipe.get("gamma"))
    if settings is not None and settings["norm_obs"]:
        kwargs = recipe.get("policy_kwargs") or {}
        if isinstance(kwargs, str):
            kwargs = evaluate_expression(kwargs)
        if isinstance(kwargs, Mapping) and "features_extractor_class" in kwargs:
            raise ConfigError(
                "recipe key 'normalize' standardises the observations inside the network "
                "(a NormalizedFlatten with running statistics), so policy_kwargs must not "
                "name a features_extractor_class as well; drop one of the two"
            )
    return settings


def recipes_train_alike(first: Mapping[str, Any], second: Mapping[str, Any]) -> bool:
    """Whether ``panda-rapier train`` trains the same way with either recipe: equal but for
    the keys only rl-zoo3 reads (``monitor_kwargs``), and for old module paths that name the
    same classes as the new ones (a recipe of 0.1 names
    ``panda_rapier.normalization.FitNormalizerCallback``;
    :func:`~panda_rapier._deprecated.current_paths`)."""

    def used(recipe: Mapping[str, Any]) -> dict[str, Any]:
        return {k: current_paths(v) for k, v in recipe.items() if k not in _ZOO_ONLY_KEYS}

    return used(first) == used(second)


def _schedule(value: Any) -> Any:
    """rl-zoo3's ``lin_X`` strings: a linear decay from X to 0."""
    if isinstance(value, str) and value.startswith("lin_"):
        start = float(value[4:])
        return lambda progress_remaining: progress_remaining * start
    return value


def evaluate_expression(text: str) -> Any:
    """rl-zoo3 evaluates string-valued ``policy_kwargs`` / ``replay_buffer_kwargs`` as Python;
    the same names are available here (``nn``, ``th``), plus ``NormalizedFlatten`` and
    ``CubeOrientationFeatures``."""
    # torch only here and in algorithm_class / model_kwargs: reading recipes needs none.
    import torch as th
    from torch import nn

    from .normalization import CubeOrientationFeatures, NormalizedFlatten

    names = {"nn": nn, "th": th, "torch": th, "NormalizedFlatten": NormalizedFlatten,
             "CubeOrientationFeatures": CubeOrientationFeatures}  # fmt: skip
    try:
        with quiet_moved():  # recipes of 0.1 import panda_rapier.normalization by name
            return eval(text, names)
    except Exception as error:
        raise ConfigError(f"cannot evaluate recipe expression {text!r}: {error}") from error


def recipe_callbacks(spec: Any) -> list[Any]:
    """Callbacks named in a recipe (rl-zoo3: a class path, or a mapping of it to kwargs, or a
    list of either). Recipes written before 0.2 name old class paths
    (``panda_rapier.normalization.FitNormalizerCallback``): they load without a warning."""
    items = spec if isinstance(spec, list) else [spec] if spec else []
    built = []
    for item in items:
        path, kwargs = next(iter(item.items())) if isinstance(item, Mapping) else (item, {})
        module, _, name = str(path).rpartition(".")
        try:
            with quiet_moved():
                found = getattr(importlib.import_module(module), name)
            built.append(found(**(kwargs or {})))
        except (ImportError, AttributeError, TypeError) as error:
            raise ConfigError(f"cannot build the recipe callback {path!r}: {error}") from error
    return built


def algorithm_class(algo: str, stock: bool = False) -> Any:
    """The class that trains ``algo``: :class:`panda_rapier.learning.ppo.PPO` for ppo (SB3's
    own with ``stock``), else stable-baselines3's or sb3-contrib's."""
    # Imported on use, as in evaluate_expression: reading recipes needs no torch.
    if algo == "tqc":
        from sb3_contrib import TQC

        return TQC
    if algo == "ppo" and not stock:
        from .ppo import PPO

        return PPO
    import stable_baselines3

    return getattr(stable_baselines3, "PPO" if algo == "bc" else algo.upper())


def model_kwargs(algo: str, recipe: Mapping[str, Any]) -> dict[str, Any]:
    """The algorithm's constructor arguments from a recipe (rl-zoo3's conventions: string
    ``policy_kwargs`` / ``replay_buffer_kwargs`` evaluated, ``lin_X`` schedules,
    ``HerReplayBuffer`` by name), without the keys that configure the run. A ``normalize``
    recipe's policy standardises its observations in a :class:`NormalizedFlatten`
    (:class:`~panda_rapier.learning.normalization.RunningNormalizer` keeps it up to date)."""
    kwargs = {k: v for k, v in recipe.items() if k not in _RUN_KEYS}
    for key in ("policy_kwargs", "replay_buffer_kwargs"):
        if isinstance(kwargs.get(key), str):
            kwargs[key] = evaluate_expression(kwargs[key])
    normalization = recipe_normalization(recipe)
    if normalization is not None and normalization["norm_obs"]:
        from .normalization import NormalizedFlatten

        kwargs["policy_kwargs"] = {
            **(kwargs.get("policy_kwargs") or {}),
            "features_extractor_class": NormalizedFlatten,
            "features_extractor_kwargs": {"clip": normalization["clip_obs"]},
        }
    for key in ("learning_rate", "clip_range"):
        if key in kwargs:
            kwargs[key] = _schedule(kwargs[key])
    if isinstance(kwargs.get("replay_buffer_class"), str):
        from stable_baselines3 import HerReplayBuffer

        if kwargs["replay_buffer_class"] != "HerReplayBuffer":
            raise ConfigError(f"unknown replay_buffer_class {kwargs['replay_buffer_class']!r}")
        kwargs["replay_buffer_class"] = HerReplayBuffer
    return kwargs


#: What ``model.zip`` can hold: the weights training ended with, or the best evaluation's.
FINAL_CHOICES = ("last", "best")

#: The top-level key of a recipe file under which ``panda-rapier train`` finds how each id's
#: runs are validated, stopped and finished (rl-zoo3 reads only the ids' own entries, so the
#: file stays an rl-zoo3 recipe file):
#:
#: .. code-block:: yaml
#:
#:     validation:
#:       panda_rapier/StackJointsDense-v0: {every: 262144, episodes: 200, patience: 4, final: best}
VALIDATION = "validation"

#: What a recipe's validation entry may set, and what each is when nothing sets it:
#: ``every`` env steps between evaluations on the validation seeds (``None``: no periodic
#: evaluation; ``panda-rapier train`` makes it 250,000), ``episodes`` per evaluation,
#: ``patience`` (stop after that many evaluations in a row without a new best; ``None`` or 0:
#: never) and ``final`` (what ``model.zip`` holds: ``"last"`` or ``"best"``).
VALIDATION_DEFAULTS: dict[str, Any] = {"every": None, "episodes": 100, "patience": None,
                                       "final": "last"}  # fmt: skip


def recipe_validation(env_id: str, conf: str | Path | None, algo: str) -> dict[str, Any]:
    """The validation settings the recipe file (``conf``, else the package's for ``algo``)
    gives ``env_id`` under its top-level :data:`VALIDATION` key; ``{}`` if none. Checked:
    unknown keys or values of the wrong kind are a :class:`ConfigError`."""
    path, recipes = _recipe_file(algo, conf)
    table = recipes.get(VALIDATION) if isinstance(recipes, Mapping) else None
    if table is None:
        return {}
    if not isinstance(table, Mapping):
        raise ConfigError(f"{path}: {VALIDATION} must map environment ids to settings")
    entry = table.get(env_id)
    if entry is None:
        return {}
    if not isinstance(entry, Mapping) or set(entry) - set(VALIDATION_DEFAULTS):
        raise ConfigError(
            f"{path}: {VALIDATION} of {env_id} must be a mapping of "
            f"{sorted(VALIDATION_DEFAULTS)}, got {entry!r}"
        )
    for key in ("every", "episodes", "patience"):
        value = entry.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                                  or value < (1 if key == "episodes" else 0)):  # fmt: skip
            raise ConfigError(f"{path}: {VALIDATION} {key} of {env_id} must be a whole number")
    if "final" in entry and entry["final"] not in FINAL_CHOICES:
        raise ConfigError(f"{path}: {VALIDATION} final of {env_id} must be one of {FINAL_CHOICES}")
    return dict(entry)


def resolve_validation(
    algo: str,
    env_id: str,
    conf: str | Path | None,
    out: Path,
    resume: bool,
    given: Mapping[str, Any],
    stop_at: float | None = None,
    default_every: int | None = None,
) -> dict[str, Any]:
    """A run's validation settings (:data:`VALIDATION_DEFAULTS`' keys), checked with
    ``stop_at`` (:func:`_check_stopping`): each one ``given`` (not ``None``) wins; then, for a
    run resumed in ``out``, the one it recorded; then the recipe file's
    (:func:`recipe_validation`); then ``default_every`` for ``every`` and
    :data:`VALIDATION_DEFAULTS`. A ``patience`` or ``every`` of 0 is none; a run without
    periodic evaluations keeps only the ``patience`` and ``final`` it was given (which
    :func:`_check_stopping` then refuses)."""
    run_file = Path(out) / "run.json"
    previous = json.loads(run_file.read_text()) if resume and run_file.is_file() else {}
    recorded = previous.get(VALIDATION) or {}
    # A resumed run goes on as it started; one recorded before runs kept these reads the file.
    recipe = {} if algo == "bc" or recorded else recipe_validation(env_id, conf, algo)
    fallback = {**VALIDATION_DEFAULTS, "every": default_every}
    settings = {}
    for key, value in fallback.items():
        for source in (given, recorded, recipe):
            if source.get(key) is not None:
                value = source[key]
                break
        settings[key] = value
    if settings["patience"] == 0:
        settings["patience"] = None
    if settings["every"] == 0:
        settings["every"] = None
    if settings["every"] is None:  # nothing to judge on: only what was asked for stays
        settings["patience"] = given.get("patience") or None
        settings["final"] = given.get("final") or "last"
    _check_stopping(algo, settings["every"], settings["patience"], stop_at, settings["final"])
    return settings


def _check_stopping(
    algo: str, eval_every: int | None, patience: int | None, stop_at: float | None, final: str
) -> None:
    if final not in FINAL_CHOICES:
        raise InvalidArgumentError(f"final must be one of {FINAL_CHOICES}, got {final!r}")
    if patience is not None and (
        isinstance(patience, bool) or not isinstance(patience, int) or patience < 1
    ):
        raise InvalidArgumentError(f"patience must be an int >= 1, got {patience!r}")
    if stop_at is not None and not 0.0 < float(stop_at) <= 1.0:
        raise InvalidArgumentError(f"stop_at must be a success rate in (0, 1], got {stop_at!r}")
    wanted = patience is not None or stop_at is not None or final != "last"
    if wanted and algo == "bc":
        raise InvalidArgumentError(
            "bc runs have a fixed length (demo_episodes, dagger_rounds); their best round is "
            "best.zip: --patience, --stop-at and --final are for ppo, sac and tqc"
        )
    if wanted and not eval_every:
        raise InvalidArgumentError(
            "--patience, --stop-at and --final best are judged on the periodic evaluations: "
            "give --eval-every a number of env steps"
        )
