"""The LeRobot benchmark entry: panda_rapier's environments as LeRobot's env type
``panda_rapier``, for ``lerobot-eval`` and the periodic evaluation of ``lerobot-train``.

Importing this module (lerobot must be installed) registers :class:`PandaRapierEnv`, an
``lerobot.envs.configs.EnvConfig`` subclass, under the type name ``panda_rapier``. LeRobot's
command-line tools import third-party plugins by distribution name (``lerobot_env_*``), so the
repository carries a one-module plugin that imports this one:
``pip install ./integrations/lerobot_env_panda_rapier`` (after ``panda-rapier[lerobot]``).
Then, for a policy trained on a dataset from ``panda-rapier demos --format lerobot``::

    lerobot-eval --policy.path=outputs/train/act/checkpoints/last/pretrained_model \\
        --env.type=panda_rapier --env.task=PickAndPlace-v0 --env.cameras='[front]' \\
        --eval.n_episodes=50 --eval.batch_size=8 --policy.device=cpu

``task`` is a registered id without its ``panda_rapier/`` prefix; ``cameras`` name image streams
from the observation camera (:data:`panda_rapier.pixels.DEFAULT_CAMERA`) at ``image_size``, as
the dataset recorded them. Each environment is :class:`LeRobotObservation`: a
:class:`~panda_rapier.PandaEnv` whose observations carry LeRobot's keys, ``agent_pos`` (the
flat observation, what the datasets hold as ``observation.state``) and ``pixels`` (a dict of
``(H, W, 3)`` uint8 images by camera, ``observation.images.<camera>``), with the task's summary
as ``task_description`` and ``info["is_success"]`` as every panda_rapier env reports it. With
``environment_state=true`` (for a dataset recorded with ``--environment-state``), ``agent_pos``
is the goals and the robot's state and ``environment_state`` the objects'
(``observation.environment_state``), split as
:func:`panda_rapier.learning.lerobot_dataset.state_split` says.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig

from .. import _common
from ..errors import ConfigError
from ..pixels import DEFAULT_CAMERA, DEFAULT_IMAGE_SIZE
from ..registration import ENV_IDS, TASKS, env_config, variant
from .lerobot_dataset import state_split

__all__ = ["LeRobotObservation", "PandaRapierEnv"]

_GOAL_KEYS = ("achieved_goal", "desired_goal", "observation")


class LeRobotObservation(gym.Wrapper):
    """``gym.make("panda_rapier/<task>")`` with LeRobot's observation keys (see the module
    documentation): ``agent_pos``, with ``environment_state`` ``environment_state``, and with
    ``cameras`` ``pixels``."""

    def __init__(
        self,
        task: str,
        cameras: Sequence[str] = (),
        image_size: int = DEFAULT_IMAGE_SIZE,
        environment_state: bool = False,
        **env_kwargs: Any,
    ) -> None:
        env_id = f"panda_rapier/{task}"
        if env_id not in ENV_IDS:
            raise ConfigError(
                f"env.task must be a panda_rapier id without its prefix (e.g. "
                f"'PickAndPlace-v0'), got {task!r}"
            )
        self._cameras = tuple(cameras)
        options: dict[str, Any] = dict(env_kwargs)
        if self._cameras:
            options.update(
                obs_mode="state+rgb",
                cameras={key: dict(DEFAULT_CAMERA) for key in self._cameras},
                image_size=image_size,
            )
        super().__init__(gym.make(env_id, **options))
        self._schema = _common.Schema.of(_common.config_json(env_config(env_id, **env_kwargs)))
        self._split = state_split(self._schema) if environment_state else None
        state_dim = self._schema.flat_dim if self._split is None else len(self._split[0])
        spaces: dict[str, gym.Space[Any]] = {
            "agent_pos": gym.spaces.Box(-np.inf, np.inf, (state_dim,), dtype=np.float32)
        }
        if self._split is not None:
            spaces["environment_state"] = gym.spaces.Box(
                -np.inf, np.inf, (len(self._split[1]),), dtype=np.float32
            )
        if self._cameras:
            spaces["pixels"] = gym.spaces.Dict(
                {key: self.env.observation_space[key] for key in self._cameras}  # type: ignore[index]
            )
        self.observation_space = gym.spaces.Dict(spaces)
        summary = next(str(t["summary"]) for t in TASKS if t["name"] == variant(env_id)["task"])
        #: The task string LeRobot's evaluation hands language-conditioned policies.
        self.task_description = summary
        #: The same, under the other name LeRobot looks for.
        self.task = summary
        #: The episode length, which LeRobot's evaluation reads.
        self._max_episode_steps = self.env.spec.max_episode_steps if self.env.spec else None

    def _convert(self, obs: Mapping[str, np.ndarray]) -> dict[str, Any]:
        flat = np.empty(self._schema.flat_dim, dtype=np.float32)
        for key in _GOAL_KEYS:
            flat[self._schema.part(key)] = obs[key]
        converted: dict[str, Any] = {"agent_pos": flat}
        if self._split is not None:
            converted["agent_pos"] = flat[self._split[0]]
            converted["environment_state"] = flat[self._split[1]]
        if self._cameras:
            converted["pixels"] = {key: obs[key] for key in self._cameras}
        return converted

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        # LeRobot's rollout marks its resets with options of its own (`lerobot_new_rollout`);
        # the environment's reset options are the rest.
        ours = {k: v for k, v in (options or {}).items() if not k.startswith("lerobot_")}
        obs, info = self.env.reset(seed=seed, options=ours or None)
        return self._convert(obs), info

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self._convert(obs), float(reward), terminated, truncated, info


@EnvConfig.register_subclass("panda_rapier")
@dataclass
class PandaRapierEnv(EnvConfig):
    """LeRobot's configuration of a panda_rapier environment (``--env.type=panda_rapier``)."""

    task: str | None = "PickAndPlace-v0"
    fps: int = 25
    #: Image streams (keys), each the observation camera at ``image_size``.
    cameras: list[str] = field(default_factory=list)
    image_size: int = DEFAULT_IMAGE_SIZE
    #: The objects' state apart from the robot's, as ``observation.environment_state`` (for
    #: datasets recorded with ``environment_state=True``).
    environment_state: bool = False
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        env_id = f"panda_rapier/{self.task}"
        if env_id not in ENV_IDS:
            raise ConfigError(
                f"env.task must be a panda_rapier id without its prefix (e.g. "
                f"'PickAndPlace-v0'), got {self.task!r}"
            )
        schema = _common.Schema.of(_common.config_json(env_config(env_id)))
        split = state_split(schema) if self.environment_state else None
        state_dim = schema.flat_dim if split is None else len(split[0])
        self.features = {
            "action": PolicyFeature(type=FeatureType.ACTION, shape=(schema.action_dim,)),
            "agent_pos": PolicyFeature(type=FeatureType.STATE, shape=(state_dim,)),
        }
        self.features_map = {"action": "action", "agent_pos": "observation.state"}
        if split is not None:
            self.features["environment_state"] = PolicyFeature(
                type=FeatureType.ENV, shape=(len(split[1]),)
            )
            self.features_map["environment_state"] = "observation.environment_state"
        for key in self.cameras:
            self.features[f"pixels/{key}"] = PolicyFeature(
                type=FeatureType.VISUAL, shape=(self.image_size, self.image_size, 3)
            )
            self.features_map[f"pixels/{key}"] = f"observation.images.{key}"

    @property
    def gym_kwargs(self) -> dict[str, Any]:
        """What every environment is built with (besides ``task``)."""
        return {
            "cameras": list(self.cameras),
            "image_size": self.image_size,
            "environment_state": self.environment_state,
        }

    def create_envs(
        self, n_envs: int, use_async_envs: bool = False
    ) -> dict[str, dict[int, gym.vector.VectorEnv]]:
        """``{"panda_rapier": {0: vector env}}`` of ``n_envs`` :class:`LeRobotObservation`
        environments (in this process: each steps in microseconds, so worker processes would
        cost more than they save)."""
        task = str(self.task)
        kwargs = self.gym_kwargs

        def make() -> gym.Env:
            return LeRobotObservation(task, **kwargs)

        vec = gym.vector.SyncVectorEnv(
            [make for _ in range(n_envs)],
            autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
        )
        return {self.type: {0: vec}}
