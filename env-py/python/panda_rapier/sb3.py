"""stable-baselines3 support: a ``VecEnv`` backed by the native vector environment.

Needs the ``sb3`` extra (``pip install "panda-rapier[sb3]"``)::

    from stable_baselines3 import PPO
    from panda_rapier.sb3 import make_vec_env

    env = make_vec_env("panda_rapier/PickAndPlaceDense-v0", n_envs=16, seed=0)
    PPO("MultiInputPolicy", env).learn(100_000)
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

try:
    from stable_baselines3.common.vec_env import VecEnv
    from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices
except ImportError as error:  # pragma: no cover - exercised only without the extra
    raise ImportError(
        "panda_rapier.sb3 needs stable-baselines3: pip install 'panda-rapier[sb3]'"
    ) from error

from . import _common, _native
from .errors import ConfigError, InvalidArgumentError
from .pixels import DEFAULT_IMAGE_SIZE, observation_spec
from .registration import env_config
from .rendering import (
    DEFAULT_HEIGHT,
    DEFAULT_WIDTH,
    FrameSource,
    check_render_envs,
    check_render_mode,
    tile,
)

__all__ = ["PandaVecEnv", "make_vec_env"]


class _SubEnv:
    """What ``get_attr`` / ``set_attr`` / ``env_method`` see as environment ``i``: the
    attributes every environment shares, plus any set with ``set_attr``."""

    def __init__(self, owner: PandaVecEnv, render_mode: str | None) -> None:
        self._owner = owner
        self.render_mode = render_mode

    @property
    def dt(self) -> float:
        return self._owner.dt

    @property
    def config(self) -> dict[str, Any]:
        return self._owner.config

    @property
    def spec(self) -> gym.envs.registration.EnvSpec | None:
        return self._owner.spec

    def compute_reward(self, achieved_goal: Any, desired_goal: Any, info: Any) -> Any:
        return self._owner.compute_reward(achieved_goal, desired_goal, info)


class PandaVecEnv(_common.NativeBacked, VecEnv):
    """``num_envs`` pick-and-place environments stepped in Rust, with stable-baselines3's
    conventions: same-step reset with ``infos[i]["terminal_observation"]``,
    ``infos[i]["TimeLimit.truncated"]``, ``infos[i]["is_success"]`` and, when an episode ends,
    ``infos[i]["episode"]`` (return, length, time: what ``VecMonitor`` adds, so no wrapper is
    needed for ``ep_rew_mean`` and success-rate logging). ``env_method("compute_reward", ...)``
    is batched, so ``HerReplayBuffer`` works. Every info carries the step info of
    :class:`~panda_rapier.PandaEnv`.

    With ``render_mode="rgb_array"``, ``get_images()`` draws every environment and
    ``render()`` environment 0 (or the first ``render_envs`` tiled), so SB3's
    ``VecVideoRecorder`` works; ``"human"`` shows the same in a window. ``width``, ``height``
    and ``camera`` as for :class:`~panda_rapier.PandaEnv`.

    ``obs_mode``, ``image_size`` and ``cameras`` as for :class:`~panda_rapier.PandaEnv`: image
    observations for ``MultiInputPolicy`` (SB3 transposes them for its CNN), drawn by the
    native threads, with the images of ``terminal_observation`` drawn before the reset.
    """

    def __init__(
        self,
        num_envs: int,
        *,
        num_threads: int | None = None,
        spec: gym.envs.registration.EnvSpec | None = None,
        render_mode: str | None = None,
        width: int = DEFAULT_WIDTH,
        height: int = DEFAULT_HEIGHT,
        camera: dict[str, Any] | None = None,
        render_envs: int = 1,
        obs_mode: str = "state",
        image_size: int | tuple[int, int] = DEFAULT_IMAGE_SIZE,
        cameras: dict[str, dict[str, Any]] | None = None,
        visual_randomization: bool | dict[str, Any] | None = None,
        **config: Any,
    ) -> None:
        self._frames: FrameSource | None = None
        if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
            raise ConfigError(f"num_envs must be an int >= 1, got {num_envs!r}")
        self._render_envs = check_render_envs(render_envs, int(num_envs))
        check_render_mode(render_mode)
        self._bind_native(
            _native.PandaVecEnv(
                _common.config_json(config),
                int(num_envs),
                None if num_threads is None else int(num_threads),
                "same_step",
            )
        )
        self._obs = observation_spec(
            self._schema,
            obs_mode,
            image_size,
            cameras,
            visual_randomization,
            config_json=self._native.config_json(),
        )
        if self._obs.has_sensors:
            self._native.set_cameras(self._obs.cameras_json, self._obs.touch)
        self.spec = spec
        self._sub_envs = [_SubEnv(self, render_mode) for _ in range(int(num_envs))]
        super().__init__(
            int(num_envs),
            self._obs.space(),
            _common.action_space(self._native.action_dim),
        )
        self._actions: np.ndarray | None = None
        self._actions_shape = (self.num_envs, int(self._native.action_dim))
        self._episode_returns = np.zeros(self.num_envs, dtype=np.float64)
        self._episode_lengths = np.zeros(self.num_envs, dtype=np.int64)
        self._start_time = time.time()
        #: Wall-clock seconds spent in :meth:`step_wait` so far (stepping, observations,
        #: infos): what :class:`~panda_rapier.learning.phases.PhaseClock` reports as env stepping.
        self.step_seconds = 0.0
        self._frames = FrameSource(render_mode, width, height, camera, float(self._native.dt))

    @property
    def num_threads(self) -> int:
        """Threads of the pool stepping the environments."""
        return int(self._native.num_threads)

    def reset(self) -> dict[str, np.ndarray]:
        seeds = [_common.as_seed(s) for s in self._seeds]
        if any(self._options):
            raise InvalidArgumentError("PandaVecEnv does not support reset options")
        flat = self._native.reset(seeds, None)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = self._native.info_rows("step")
        self._episode_returns[:] = 0.0
        self._episode_lengths[:] = 0
        return self._observation(flat)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = _common.as_actions(actions, self._actions_shape, "actions")

    def step_wait(
        self,
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, list[dict[str, Any]]]:
        if self._actions is None:
            raise InvalidArgumentError("step_wait() called without step_async()")
        began = time.perf_counter()
        try:
            return self._step_wait(self._actions)
        finally:
            self.step_seconds += time.perf_counter() - began

    def _step_wait(
        self, actions: np.ndarray
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, list[dict[str, Any]]]:
        flat, rewards, terminated, truncated = self._native.step(actions)
        self._actions = None
        dones = terminated | truncated
        infos = self._native.info_rows("step")
        self._episode_returns += rewards
        self._episode_lengths += 1
        if dones.any():
            finals = self._observation(self._native.final_observations(), "final")
            reset_infos = self._native.info_rows("reset")
            elapsed = round(time.time() - self._start_time, 6)
            for i in np.flatnonzero(dones):
                info = infos[i]
                info["terminal_observation"] = self._obs.row(finals, i)
                info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                info["episode"] = {
                    "r": float(self._episode_returns[i]),
                    "l": int(self._episode_lengths[i]),
                    "t": elapsed,
                }
                self.reset_infos[i] = reset_infos[i]
            self._episode_returns[dones] = 0.0
            self._episode_lengths[dones] = 0
        return self._observation(flat), rewards, dones, infos

    def _observation(self, flat: np.ndarray, which: str = "current") -> dict[str, np.ndarray]:
        images = self._native.images(which) if self._obs.has_sensors else None
        return self._obs.assemble(flat, images)

    def close(self) -> None:
        if self._frames is not None:
            self._frames.close()
            self._frames = None
        self._native = _common.Closed("vector environment")

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(self._sub_envs[i], attr_name) for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        for i in self._get_indices(indices):
            setattr(self._sub_envs[i], attr_name, value)

    def env_method(
        self,
        method_name: str,
        *method_args: Any,
        indices: VecEnvIndices = None,
        **method_kwargs: Any,
    ) -> list[Any]:
        return [
            getattr(self._sub_envs[i], method_name)(*method_args, **method_kwargs)
            for i in self._get_indices(indices)
        ]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def _frame(self, index: int) -> np.ndarray:
        if isinstance(self._native, _common.Closed) or self._frames is None:
            _common.Closed("vector environment").check()
        assert self._frames is not None
        return self._frames.renderer.render_vec_env(self._native, index)

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One HxWx3 uint8 frame per environment (``None`` each without a render mode)."""
        if self.render_mode is None:
            return [None for _ in range(self.num_envs)]
        return [self._frame(i) for i in range(self.num_envs)]

    def render(self, mode: str | None = None) -> np.ndarray | None:
        """Environment 0 (or the first ``render_envs`` tiled) as an HxWx3 uint8 frame, or shown
        in the window in ``human`` mode (returns None). ``mode``, if given, must be the
        environment's render mode (Gymnasium's rule, as SB3's own ``render``)."""
        if mode is not None and mode != self.render_mode:
            raise InvalidArgumentError(
                f"render(mode={mode!r}): this environment was made with "
                f"render_mode={self.render_mode!r}; pass render_mode to make_vec_env"
            )
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode.")
            return None
        frame = tile([self._frame(i) for i in range(self._render_envs)])
        assert self._frames is not None
        return self._frames.output(frame)


def make_vec_env(
    env_id: str,
    n_envs: int = 1,
    seed: int | None = None,
    num_threads: int | None = None,
    *,
    render_mode: str | None = None,
    width: int = DEFAULT_WIDTH,
    height: int = DEFAULT_HEIGHT,
    camera: dict[str, Any] | None = None,
    render_envs: int = 1,
    obs_mode: str = "state",
    image_size: int | tuple[int, int] = DEFAULT_IMAGE_SIZE,
    cameras: dict[str, dict[str, Any]] | None = None,
    visual_randomization: bool | dict[str, Any] | None = None,
    **config: Any,
) -> PandaVecEnv:
    """A :class:`PandaVecEnv` for a registered id (``panda_rapier.ENV_IDS``), with the
    id's options (and its time limit, 70 steps) overridden by ``config``; ``render_mode``,
    ``width``, ``height``, ``camera``, ``render_envs``, ``obs_mode``, ``image_size``,
    ``cameras`` and ``visual_randomization`` pass through to it.

    With ``seed``, environment ``i``'s first episode is seeded with ``seed + i`` (as
    stable-baselines3's own ``make_vec_env``); the same seed gives the same rollouts.
    """
    options = env_config(env_id, **config)
    venv = PandaVecEnv(
        n_envs,
        num_threads=num_threads,
        spec=gym.spec(env_id),
        render_mode=render_mode,
        width=width,
        height=height,
        camera=camera,
        render_envs=render_envs,
        obs_mode=obs_mode,
        image_size=image_size,
        cameras=cameras,
        visual_randomization=visual_randomization,
        **options,
    )
    if seed is not None:
        venv.seed(_common.as_seed(seed))
    return venv


#: The name before tasks were added (``PandaRapierVecEnv``), with a ``FutureWarning``.
__getattr__ = _common.renamed("panda_rapier.sb3", {"PandaRapierVecEnv": PandaVecEnv})
