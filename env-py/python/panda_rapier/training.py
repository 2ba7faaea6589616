"""Deprecated: split into :mod:`panda_rapier.learning.recipes` (recipes and validation
settings), :mod:`panda_rapier.learning.runs` (run directories, records, the recorder) and
:mod:`panda_rapier.learning.runner` (:func:`~panda_rapier.learning.runner.train`); this path
is removed in 0.4.0.

Importing it emits a :class:`FutureWarning`; it re-exports the public names it had (the same
objects as in their new homes).
"""

import importlib

from ._deprecated import warn

warn(
    __name__,
    "panda_rapier.learning.recipes, panda_rapier.learning.runs or panda_rapier.learning.runner",
)

# What this module had, by its new home (named by string: the environment layer imports no
# subpackage).
_NAMES = {
    "panda_rapier.seeds": ("TRAIN_FIRST_SEED", "VALIDATION_FIRST_SEED"),
    "panda_rapier.agents.model_file": ("RUN_MEMBER", "read_run_info", "save_model"),
    "panda_rapier.learning.recipes": (
        "ALGORITHMS",
        "FINAL_CHOICES",
        "VALIDATION",
        "VALIDATION_DEFAULTS",
        "default_recipe_path",
        "load_recipe",
        "model_kwargs",
        "recipe_validation",
        "recipes_train_alike",
        "resolve_validation",
    ),
    "panda_rapier.learning.runs": (
        "UNTRAINED_BY_CLONING",
        "VALUE_PREFIXES",
        "actor_frozen",
        "due",
        "finish_run",
        "open_run",
        "run_record",
        "stop_reason",
        "versions",
    ),
    "panda_rapier.learning.runner": ("STUDENT_FINETUNE_POLICY_KWARGS", "train"),
}
for _module, _names in _NAMES.items():
    for _name in _names:
        globals()[_name] = getattr(importlib.import_module(_module), _name)
__all__ = sorted(name for names in _NAMES.values() for name in names)
