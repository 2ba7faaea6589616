"""The package's old module paths, kept as deprecated aliases until 0.4.0.

Version 0.2 put the training lab in subpackages (:mod:`panda_rapier.agents`,
:mod:`panda_rapier.learning`, :mod:`panda_rapier.scale`, :mod:`panda_rapier.tools`). The old
flat modules (``panda_rapier.normalization``, ``panda_rapier.training``, ...) still import:
each emits a :class:`FutureWarning` naming its new home and then *is* that module (it replaces
itself in ``sys.modules``), so ``panda_rapier.normalization.NormalizedFlatten is
panda_rapier.learning.normalization.NormalizedFlatten``: model zips and recipes that name the
old class paths keep loading. :func:`quiet_moved` silences exactly these warnings where the
package itself loads such a file.

No imports of the subpackages here: they are named by string and imported on use.
"""

from __future__ import annotations

import importlib
import sys
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from types import ModuleType
from typing import Any

__all__ = [
    "MOVED",
    "REMOVED_IN",
    "alias",
    "current_imports",
    "current_name",
    "current_paths",
    "quiet_moved",
    "same_class",
    "warn",
]

#: The version that removes the old paths.
REMOVED_IN = "0.4.0"

#: Old module path -> new module path (``panda_rapier.training`` became three modules; it
#: re-exports their public names, :mod:`panda_rapier.training`).
MOVED: dict[str, str] = {
    "panda_rapier.model_file": "panda_rapier.agents.model_file",
    "panda_rapier.inference": "panda_rapier.agents.inference",
    "panda_rapier.student_model": "panda_rapier.agents.student_model",
    "panda_rapier.evaluation": "panda_rapier.agents.evaluation",
    "panda_rapier.training": "panda_rapier.learning.runner",
    "panda_rapier.imitation": "panda_rapier.learning.imitation",
    "panda_rapier.ppo": "panda_rapier.learning.ppo",
    "panda_rapier.overlap": "panda_rapier.learning.overlap",
    "panda_rapier.student": "panda_rapier.learning.student",
    "panda_rapier.demos": "panda_rapier.learning.demos",
    "panda_rapier.rollouts": "panda_rapier.learning.rollouts",
    "panda_rapier.normalization": "panda_rapier.learning.normalization",
    "panda_rapier.exploration": "panda_rapier.learning.exploration",
    "panda_rapier.finetune": "panda_rapier.learning.finetune",
    "panda_rapier.checkpoint": "panda_rapier.learning.checkpoint",
    "panda_rapier.phases": "panda_rapier.learning.phases",
    "panda_rapier.threads": "panda_rapier.learning.threads",
    "panda_rapier.rllib": "panda_rapier.scale.rllib",
    "panda_rapier.rllib_recipe": "panda_rapier.scale.rllib_recipe",
    "panda_rapier.rllib_training": "panda_rapier.scale.rllib_training",
    "panda_rapier.tuning": "panda_rapier.scale.tuning",
    "panda_rapier.bench": "panda_rapier.tools.bench",
    "panda_rapier.train_bench": "panda_rapier.tools.train_bench",
    "panda_rapier.reporting": "panda_rapier.tools.reporting",
}

# The text every alias warning starts with (what quiet_moved filters on).
_MESSAGE = "{old} is deprecated and will be removed in {removed}: import {new}"
_PATTERN = r"panda_rapier\.\w+ is deprecated and will be removed in "


def alias(old: str, new: str | None = None) -> ModuleType:
    """Makes the module ``old`` (an old path, being imported) the module ``new`` (default:
    :data:`MOVED`'s), after a :class:`FutureWarning` that names both; returns it."""
    new = new or MOVED[old]
    warnings.warn(
        _MESSAGE.format(old=old, new=new, removed=REMOVED_IN), FutureWarning, stacklevel=3
    )
    module = importlib.import_module(new)
    sys.modules[old] = module
    return module


def warn(old: str, new: str) -> None:
    """The :class:`FutureWarning` of an old path that re-exports from ``new`` (a text)."""
    warnings.warn(
        _MESSAGE.format(old=old, new=new, removed=REMOVED_IN), FutureWarning, stacklevel=3
    )


@contextmanager
def quiet_moved() -> Iterator[None]:
    """Silences the old paths' :class:`FutureWarning` (and only it) inside the block: the
    package's own loaders use it on model files and recipes that name old class paths."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=_PATTERN, category=FutureWarning)
        yield


def current_name(path: str) -> str:
    """A dotted name (``panda_rapier.ppo.PPO``) with an old module path replaced by its new
    one (``panda_rapier.learning.ppo.PPO``); other names unchanged."""
    module, _, name = path.rpartition(".")
    if module in MOVED and module != "panda_rapier.training":
        return f"{MOVED[module]}.{name}"
    return path


def current_imports(text: str) -> str:
    """A recipe's expression (a ``policy_kwargs`` string) with every old module it imports by
    name, ``__import__('panda_rapier.normalization').normalization.``, made its new one,
    ``__import__('panda_rapier.learning.normalization').learning.normalization.``: the
    two name the same class, so recipes that differ only so train alike."""
    for old, new in MOVED.items():
        before = f"__import__('{old}'){old.removeprefix('panda_rapier')}."
        text = text.replace(before, f"__import__('{new}'){new.removeprefix('panda_rapier')}.")
    return text


def current_paths(value: Any) -> Any:
    """``value`` (a recipe's entry: strings, lists and mappings of them) with every old module
    path in it made its new one: dotted class names (:func:`current_name`; a callback
    ``panda_rapier.normalization.FitNormalizerCallback``), mapping keys likewise, and modules
    imported by name in expressions (:func:`current_imports`)."""
    if isinstance(value, Mapping):
        return {current_name(str(k)): current_paths(v) for k, v in value.items()}
    if isinstance(value, list):
        return [current_paths(v) for v in value]
    if isinstance(value, str):
        return current_name(current_imports(value))
    return value


def same_class(first: str, second: str) -> bool:
    """Whether two recorded class paths name the same class, old paths and new alike."""
    return current_name(first) == current_name(second)
