"""Helpers shared by the single, vector and stable-baselines3 environments: the observation
and info schema, configuration serialisation, action checking, seeds, spaces, observation
splitting and reward contexts."""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from . import _native
from .errors import ConfigError, InvalidActionError, InvalidArgumentError, ResetNeededError

_MAX_SEED = 2**64

#: The goal dict's keys, in the order of the flat native observation (Gymnasium's
#: ``spaces.flatten`` order of the dict: keys sorted).
DICT_KEYS = ("achieved_goal", "desired_goal", "observation")


@dataclass(frozen=True)
class Schema:
    """The observation and info schema of one configuration, as the native core defines it
    (``_native.schema``): every layer reads it from here instead of hard-coding a layout."""

    task: str
    goal_dim: int
    flat_dim: int
    action_dim: int
    #: Every slot of the flat observation: ``name``, ``key`` (the dict entry it belongs to),
    #: ``start``, ``stop``, ``description``.
    slots: tuple[dict[str, Any], ...]
    #: ``(key, numpy dtype)`` of every info entry: every task's, then the task's own.
    info: tuple[tuple[str, str], ...]
    #: The info keys ``compute_reward`` reads, in the order the native side takes them (the
    #: task's; empty when its reward depends on the goals alone).
    context_keys: tuple[str, ...]

    @staticmethod
    @functools.lru_cache(maxsize=64)
    def of(config_json: str) -> Schema:
        """The schema of the environments ``config_json`` builds (cached)."""
        raw = _native.schema(config_json)
        dtypes = {entry["key"]: entry["dtype"] for entry in raw["info"]}
        return Schema(
            task=str(raw["task"]),
            goal_dim=int(raw["goal_dim"]),
            flat_dim=int(raw["flat_dim"]),
            action_dim=int(raw["action_dim"]),
            slots=tuple(dict(slot) for slot in raw["observation"]),
            info=tuple(dtypes.items()),
            context_keys=tuple(raw["reward_context_keys"]),
        )

    @staticmethod
    def default() -> Schema:
        """The schema of the default configuration."""
        return Schema.of("{}")

    def part(self, key: str) -> slice:
        """Where the goal-dict entry ``key`` sits in the flat vector."""
        return self._parts[key]

    @functools.cached_property
    def _parts(self) -> dict[str, slice]:
        """Every dict entry's slice, worked out once (every step splits an observation)."""
        parts: dict[str, slice] = {}
        for key in dict.fromkeys(s["key"] for s in self.slots):
            starts = [s["start"] for s in self.slots if s["key"] == key]
            stops = [s["stop"] for s in self.slots if s["key"] == key]
            parts[key] = slice(min(starts), max(stops))
        return parts

    @property
    def observation_dim(self) -> int:
        """Length of the dict's ``observation`` entry."""
        return self.flat_dim - 2 * self.goal_dim

    def source_part(self, source: str) -> slice:
        """Where the slots reporting ``source``'s state (``goal``, ``robot`` or ``task``, as
        the native schema marks them) sit together in the flat vector: ``robot`` is the
        robot's own state, its proprioception."""
        ranges = [(s["start"], s["stop"]) for s in self.slots if s.get("source") == source]
        if not ranges:
            raise InvalidArgumentError(f"no observation slot reports {source!r} state")
        start, stop = ranges[0][0], ranges[-1][1]
        if sum(b - a for a, b in ranges) != stop - start:  # the native layout keeps them together
            raise InvalidArgumentError(f"the {source!r} slots are not contiguous: {ranges}")
        return slice(start, stop)

    def slot(self, name: str) -> slice:
        """Where the slot ``name`` (``tcp_position``, ``cube_position``, ...) sits in the flat
        vector."""
        for s in self.slots:
            if s["name"] == name:
                return slice(s["start"], s["stop"])
        raise InvalidArgumentError(
            f"no observation slot {name!r}; slots: {[s['name'] for s in self.slots]}"
        )


def _non_finite(value: Any, path: str) -> str | None:
    """The path of the first NaN or infinite number in an option value, if any."""
    if isinstance(value, float | np.floating) and not np.isfinite(value):
        return path
    if isinstance(value, Mapping):
        items: Any = ((f"{path}.{k}", v) for k, v in value.items())
    elif isinstance(value, list | tuple):
        items = ((f"{path}[{i}]", v) for i, v in enumerate(value))
    elif isinstance(value, np.ndarray) and value.dtype.kind == "f":
        bad = np.flatnonzero(~np.isfinite(value))
        return f"{path}[{int(bad[0])}]" if bad.size else None
    else:
        return None
    for where, item in items:
        found = _non_finite(item, where)
        if found is not None:
            return found
    return None


#: Bound of an entry standardised by a policy network's observation normaliser
#: (:class:`~panda_rapier.learning.normalization.NormalizedFlatten`, the students'
#: :class:`~panda_rapier.agents.student_model.PixelEncoder`, the native network); defined here,
#: where no torch is needed, and read by all of them.
CLIP = 10.0
#: Smallest scale a normalised feature is divided by: entries that barely move in the expert's
#: episodes (the cube's tilt) must not turn float noise into large inputs.
MIN_SCALE = 0.01


def standardisation(
    rows: Any, width: int, min_scale: float = MIN_SCALE
) -> tuple[np.ndarray, np.ndarray]:
    """The mean and scale (standard deviation, at least ``min_scale``) of ``rows`` of
    ``width`` values each, as the observation normalisers store them (float32); fewer than 2
    rows or another width is a ``ValueError``."""
    rows = np.asarray(rows, dtype=np.float64)
    if rows.ndim != 2 or rows.shape[1] != width or rows.shape[0] < 2:
        raise ValueError(f"fit needs at least 2 rows of {width} values, got {rows.shape}")
    scale = np.maximum(rows.std(axis=0), min_scale)
    return rows.mean(axis=0).astype(np.float32), scale.astype(np.float32)


def config_json(config: Mapping[str, Any]) -> str:
    """Serialises keyword options for the native side (which validates them); NaN and infinite
    numbers are refused here, with the option's name, since JSON cannot carry them."""
    for key, value in dict(config).items():
        where = _non_finite(value, str(key))
        if where is not None:
            raise ConfigError(f"option {where} must be a finite number, got {value!r}")

    def builtin(value: Any) -> Any:
        if isinstance(value, np.ndarray | np.generic):
            return value.tolist()
        raise ConfigError(f"option value {value!r} of type {type(value).__name__} is not supported")

    try:
        return json.dumps(dict(config), default=builtin, allow_nan=False)
    except (TypeError, ValueError) as error:
        raise ConfigError(f"options cannot be encoded: {error}") from error


def as_seed(seed: Any) -> int | None:
    """A seed for the native side: ``None`` or an int in ``[0, 2**64)``."""
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise InvalidArgumentError(f"seed must be a non-negative int or None, got {seed!r}")
    if not 0 <= int(seed) < _MAX_SEED:
        raise InvalidArgumentError(f"seed must be in [0, 2**64), got {seed}")
    return int(seed)


def as_actions(action: Any, shape: tuple[int, ...], what: str = "action") -> np.ndarray:
    """Checks an action's shape and dtype and returns it as a C-contiguous float32 array.

    Real dtypes are accepted (float32 without a copy); values outside [-1, 1] are clipped here
    (so float64 values beyond float32's range do not become infinite); NaN and infinite values
    are passed on and rejected by the native side with :class:`InvalidActionError`.
    """
    try:
        array = np.asarray(action)
    except (TypeError, ValueError) as error:
        raise InvalidActionError(
            f"{what} must be an array of shape {shape}, got {type(action).__name__}: {error}"
        ) from error
    if array.dtype.kind not in "fiu":
        raise InvalidActionError(
            f"{what} must hold real numbers (float32), got dtype {array.dtype} "
            f"(expected shape {shape})"
        )
    if array.shape != shape:
        raise InvalidActionError(f"{what} must have shape {shape}, got {array.shape}")
    if array.dtype == np.float32:
        return np.ascontiguousarray(array)
    wide = array.astype(np.float64)
    np.clip(wide, -1.0, 1.0, out=wide, where=np.isfinite(wide))
    return wide.astype(np.float32)


#: Bound of every observation entry. Finite observations stay far inside it: the blow-up
#: detector ends the episode (keeping the last valid observation) once any body moves faster
#: than 20 m/s or spins faster than 200 rad/s, and positions stay within metres of the robot.
OBSERVATION_BOUND = 1000.0


def observation_space(schema: Schema) -> spaces.Dict:
    """The goal-conditioned dict space (keys sorted as Gymnasium sorts them)."""

    def box(n: int) -> spaces.Box:
        return spaces.Box(-OBSERVATION_BOUND, OBSERVATION_BOUND, shape=(n,), dtype=np.float32)

    return spaces.Dict(
        {key: box(schema.part(key).stop - schema.part(key).start) for key in DICT_KEYS}
    )


def action_space(action_dim: int) -> spaces.Box:
    """Actions in [-1, 1]."""
    return spaces.Box(-1.0, 1.0, shape=(action_dim,), dtype=np.float32)


def split_observation(flat: np.ndarray, schema: Schema | None = None) -> dict[str, np.ndarray]:
    """The dict observation from a flat one (``(d,)`` or ``(n, d)``), as contiguous arrays,
    laid out as ``schema`` says (the default configuration's when not given)."""
    schema = schema or Schema.default()
    return {key: np.ascontiguousarray(flat[..., schema.part(key)]) for key in DICT_KEYS}


def compute_reward(
    native: Any, schema: Schema, achieved_goal: Any, desired_goal: Any, info: Any, dense: bool
) -> Any:
    """Batched reward over any leading shape; a float for a single transition."""
    achieved = np.asarray(achieved_goal, dtype=np.float32)
    desired = np.asarray(desired_goal, dtype=np.float32)
    goal_dim = schema.goal_dim
    if achieved.shape != desired.shape or achieved.ndim == 0 or achieved.shape[-1] != goal_dim:
        raise InvalidArgumentError(
            f"achieved_goal and desired_goal must have the same shape (..., {goal_dim}), got "
            f"{achieved.shape} and {desired.shape}"
        )
    lead = achieved.shape[:-1]
    n = int(np.prod(lead, dtype=np.int64))
    context = context_columns(info, n, schema) if dense and schema.context_keys else None
    rewards = native.compute_reward(
        np.ascontiguousarray(achieved.reshape(n, goal_dim)),
        np.ascontiguousarray(desired.reshape(n, goal_dim)),
        context,
    )
    if not lead:
        return float(rewards[0])
    return rewards.reshape(lead)


def context_columns(info: Any, n: int, schema: Schema) -> np.ndarray:
    """The dense reward's goal-free inputs for ``n`` transitions as an ``(n, k)`` float32 array
    of the task's context keys (flags as 0 or 1), from an info dict (scalars or arrays), or a
    sequence / object array of info dicts (what ``HerReplayBuffer`` passes)."""
    keys = schema.context_keys
    try:
        if isinstance(info, Mapping):
            columns = [
                np.broadcast_to(np.asarray(info[key], dtype=np.float32).reshape(-1), (n,))
                for key in keys
            ]
        elif isinstance(info, Sequence | np.ndarray):
            infos = np.asarray(info, dtype=object).reshape(-1)
            if len(infos) != n:
                raise InvalidArgumentError(
                    f"info must hold one dict per transition: {n} transitions, {len(infos)} infos"
                )
            columns = [
                np.fromiter((entry[key] for entry in infos), dtype=np.float32, count=n)
                for key in keys
            ]
        else:
            raise InvalidArgumentError(
                f"the dense reward needs the step info (a dict or a sequence of dicts), got "
                f"{type(info).__name__}"
            )
    except KeyError as error:
        raise InvalidArgumentError(
            f"info lacks {error.args[0]!r}: the dense reward needs the keys {list(keys)} "
            "that every step's info carries (stable-baselines3: create the HerReplayBuffer "
            "with replay_buffer_kwargs={'copy_info_dict': True}, or use the sparse reward)"
        ) from error
    except ValueError as error:
        raise InvalidArgumentError(f"info does not match {n} transitions: {error}") from error
    return np.ascontiguousarray(np.stack(columns, axis=1), dtype=np.float32)


class NativeBacked:
    """What every environment class shares about its native object: ``dt``, ``config`` and the
    batched ``compute_reward``. Subclasses call :meth:`_bind_native` in ``__init__``."""

    _native: Any
    _config: dict[str, Any]
    _dense: bool
    _schema: Schema
    _obs: Any

    def _bind_native(self, native: Any) -> None:
        self._native = native
        config_json = native.config_json()
        self._config = json.loads(config_json)
        self._dense = self._config["reward_type"] == "dense"
        self._schema = Schema.of(config_json)

    @property
    def dt(self) -> float:
        """Control period in seconds (one ``step``)."""
        return float(self._native.dt)

    @property
    def segmentation_ids(self) -> dict[int, str]:
        """What each segmentation id stands for (``background``, ``floor``, ``platform``,
        ``goal``, ``object:<name>``, ``link:<name>``): every id the segmentation images can
        hold; empty when the ``obs_mode`` has no segmentation."""
        return dict(self._obs.segmentation_ids)

    @property
    def config(self) -> dict[str, Any]:
        """The full configuration, defaults filled in (a copy)."""
        return json.loads(json.dumps(self._config))

    def compute_reward(self, achieved_goal: Any, desired_goal: Any, info: Any) -> Any:
        """The reward the environment gives, recomputed from goals, batched over any leading
        shape (a float for single goals), for hindsight experience replay.

        ``info`` is a step's info dict, a dict of arrays, or a sequence / array of info dicts
        (what ``HerReplayBuffer`` passes); the sparse reward does not read it.
        """
        return compute_reward(
            self._native, self._schema, achieved_goal, desired_goal, info, self._dense
        )

    @property
    def schema(self) -> Schema:
        """The observation and info schema (slots with their flat ranges, info keys)."""
        return self._schema


#: The version that removes the names from before 0.2 (each warns with a ``FutureWarning``).
OLD_NAMES_REMOVED_IN = "0.3.0"


def renamed(module: str, old_names: Mapping[str, Any]) -> Any:
    """A module ``__getattr__`` (PEP 562) that serves ``old_names`` (old name -> object) with a
    ``FutureWarning`` naming the new one."""
    import warnings

    def __getattr__(name: str) -> Any:
        if name in old_names:
            new = old_names[name]
            warnings.warn(
                f"{module}.{name} is renamed {module}.{new.__name__} and will be removed in "
                f"{OLD_NAMES_REMOVED_IN}",
                FutureWarning,
                stacklevel=2,
            )
            return new
        raise AttributeError(f"module {module!r} has no attribute {name!r}")

    return __getattr__


class Closed:
    """Stands in for the native object after ``close()``: any use raises."""

    def check(self) -> None:
        raise ResetNeededError(f"the {self._what} is closed")

    def __init__(self, what: str) -> None:
        self._what = what

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        raise ResetNeededError(f"the {self._what} is closed")
