"""The exceptions panda_rapier raises, one hierarchy under :class:`PandaRapierError`.

Bad arguments (wrong shapes, dtypes, non-finite numbers, unknown names, invalid configuration)
raise :class:`InvalidArgumentError` subclasses, which are also :class:`ValueError`, so code that
already catches ``ValueError`` keeps working.

The classes are created by the native module (so its errors are raised as them directly) and
re-exported here, where they say they live (``__module__``, pickling)::

    PandaRapierError(Exception)
    ├── InvalidArgumentError(PandaRapierError, ValueError)
    │   ├── InvalidActionError
    │   └── ConfigError
    ├── AssetError(PandaRapierError, OSError)
    ├── ResetNeededError(PandaRapierError, RuntimeError)
    └── DisplayError(PandaRapierError, RuntimeError)
"""

from __future__ import annotations

from ._native import (
    AssetError,
    ConfigError,
    DisplayError,
    InvalidActionError,
    InvalidArgumentError,
    PandaRapierError,
    ResetNeededError,
)

__all__ = [
    "AssetError",
    "ConfigError",
    "DisplayError",
    "InvalidActionError",
    "InvalidArgumentError",
    "PandaRapierError",
    "ResetNeededError",
]
