"""The exceptions panda_rapier raises, one hierarchy under :class:`PandaRapierError`.

Bad arguments (wrong shapes, dtypes, non-finite numbers, unknown names, invalid configuration)
raise :class:`InvalidArgumentError` subclasses, which are also :class:`ValueError`, so code that
already catches ``ValueError`` keeps working.
"""

from __future__ import annotations

__all__ = [
    "AssetError",
    "ConfigError",
    "DisplayError",
    "InvalidActionError",
    "InvalidArgumentError",
    "PandaRapierError",
    "ResetNeededError",
]


class PandaRapierError(Exception):
    """Base class of every error raised by panda_rapier."""


class InvalidArgumentError(PandaRapierError, ValueError):
    """An argument has the wrong shape, dtype or value, or names an unknown joint or link."""


class InvalidActionError(InvalidArgumentError):
    """An action has the wrong shape or dtype, or holds NaN or infinite values."""


class ConfigError(InvalidArgumentError):
    """An environment option is unknown or outside its valid range."""


class AssetError(PandaRapierError, OSError):
    """A robot description or mesh is missing or malformed."""


class ResetNeededError(PandaRapierError, RuntimeError):
    """The environment must be reset first: before the first reset, after a physics blow-up,
    after an episode ended with autoreset disabled, or after ``close()``."""


class DisplayError(PandaRapierError, RuntimeError):
    """``render_mode="human"`` cannot open a window: no display, or pygame is missing.
    ``render_mode="rgb_array"`` needs neither."""
