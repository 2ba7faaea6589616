"""Gymnasium registration of the panda_rapier environments."""

from __future__ import annotations

import json
from typing import Any

import gymnasium as gym

from ._native import default_config_json

#: Episode length of every registered id: the core's default, 70 steps at 25 Hz (2.8 s), the
#: length the scripted baseline needs to place the cube in 99 % of episodes in both action
#: modes (see ``help(panda_rapier.PandaEnv)``).
MAX_EPISODE_STEPS: int = json.loads(default_config_json())["max_episode_steps"]

_VARIANTS: dict[str, dict[str, Any]] = {
    "panda_rapier/PickAndPlace-v0": {"control_mode": "ee", "reward_type": "sparse"},
    "panda_rapier/PickAndPlaceDense-v0": {"control_mode": "ee", "reward_type": "dense"},
    "panda_rapier/PickAndPlaceJoints-v0": {"control_mode": "joints", "reward_type": "sparse"},
    "panda_rapier/PickAndPlaceJointsDense-v0": {"control_mode": "joints", "reward_type": "dense"},
}

#: Every registered environment id.
ENV_IDS: tuple[str, ...] = tuple(_VARIANTS)


def env_config(env_id: str, **overrides: Any) -> dict[str, Any]:
    """The configuration options of a registered panda_rapier id (its time limit included),
    with ``overrides`` applied: what the vector environments and the scripted policy take."""
    from .errors import ConfigError

    try:
        spec = gym.spec(env_id)
    except gym.error.Error as error:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS") from error
    if not str(spec.entry_point).startswith("panda_rapier"):
        raise ConfigError(f"{env_id} is not a panda_rapier environment; see panda_rapier.ENV_IDS")
    options = dict(spec.kwargs)
    if spec.max_episode_steps is not None:
        options.setdefault("max_episode_steps", spec.max_episode_steps)
    options.update(overrides)
    options.pop("render_mode", None)
    return options


def register_envs() -> None:
    """Registers every id in :data:`ENV_IDS` (idempotent)."""
    for env_id, kwargs in _VARIANTS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point="panda_rapier.env:PandaEnv",
            vector_entry_point="panda_rapier.vector:PandaVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs=dict(kwargs),
        )
