"""panda_rapier: Franka Panda pick-and-place on rapier3d, as Gymnasium environments and a
native stable-baselines3 vector environment.

``import panda_rapier`` registers the ids in :data:`ENV_IDS` with Gymnasium::

    import gymnasium as gym
    import panda_rapier

    env = gym.make("panda_rapier/PickAndPlace-v0")
    envs = gym.make_vec("panda_rapier/PickAndPlace-v0", num_envs=16,
                        vectorization_mode="vector_entry_point")

The baselines: :class:`ScriptedPolicy` (the task's expert) and :class:`RandomPolicy`
(``panda-rapier eval --policy scripted|random`` on the command line).
stable-baselines3 users: :func:`panda_rapier.sb3.make_vec_env` (needs the ``sb3`` extra).
Ray (the ``rllib`` extra): :mod:`panda_rapier.scale.rllib` (RLlib configs with the native vector env
in every EnvRunner) and :mod:`panda_rapier.scale.tuning` (Ray Tune sweeps of the SB3 recipes).
"""

from __future__ import annotations

from . import _common
from ._native import __version__
from .env import PandaEnv
from .errors import (
    AssetError,
    ConfigError,
    DisplayError,
    InvalidActionError,
    InvalidArgumentError,
    PandaRapierError,
    ResetNeededError,
)
from .policy import RandomPolicy, ScriptedPolicy
from .registration import ENV_IDS, MAX_EPISODE_STEPS, env_config, register_envs
from .rendering import RENDER_MODES
from .robot import Robot
from .vector import PandaVectorEnv

__all__ = [
    "ENV_IDS",
    "MAX_EPISODE_STEPS",
    "RENDER_MODES",
    "AssetError",
    "ConfigError",
    "DisplayError",
    "InvalidActionError",
    "InvalidArgumentError",
    "PandaEnv",
    "PandaRapierError",
    "PandaVectorEnv",
    "RandomPolicy",
    "ResetNeededError",
    "Robot",
    "ScriptedPolicy",
    "__version__",
    "env_config",
    "register_envs",
]

register_envs()

#: The names before tasks were added, with a ``FutureWarning`` (removed in 0.3.0).
__getattr__ = _common.renamed(
    "panda_rapier", {"PickAndPlaceEnv": PandaEnv, "PickAndPlaceVectorEnv": PandaVectorEnv}
)
