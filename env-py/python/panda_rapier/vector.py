"""The native Gymnasium vector environment: N environments stepped in parallel in Rust."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from . import _common, _native
from .errors import ConfigError, InvalidArgumentError
from .pixels import DEFAULT_IMAGE_SIZE, observation_spec
from .rendering import (
    DEFAULT_HEIGHT,
    DEFAULT_WIDTH,
    RENDER_MODES,
    FrameSource,
    check_render_envs,
    check_render_mode,
    tile,
)

_NATIVE_MODES = {
    AutoresetMode.NEXT_STEP: "next_step",
    AutoresetMode.SAME_STEP: "same_step",
    AutoresetMode.DISABLED: "disabled",
}


def as_autoreset_mode(value: str | AutoresetMode) -> AutoresetMode:
    """Gymnasium's enum, from itself, its value (``"NextStep"``) or ``"next_step"``."""
    for mode, name in _NATIVE_MODES.items():
        if value in (mode, mode.value, name):
            return mode
    raise ConfigError(
        f"autoreset_mode must be one of {list(_NATIVE_MODES.values())} or a "
        f"gymnasium.vector.AutoresetMode, got {value!r}"
    )


class PandaVectorEnv(_common.NativeBacked, VectorEnv):
    """``num_envs`` pick-and-place environments stepped by a Rust thread pool
    (``num_threads``, default: the machine's cores), the GIL released meanwhile.

    Created by ``gym.make_vec(env_id, num_envs, vectorization_mode="vector_entry_point")`` or
    directly; every keyword argument of :class:`~panda_rapier.PandaEnv` applies.
    Environment ``i`` draws from the random stream ``(seed, i)``, so results do not depend on
    ``num_threads`` and environment ``i`` behaves the same whatever ``num_envs`` is.

    ``autoreset_mode`` is Gymnasium's ``next_step`` (default: the step after an episode ends
    resets that environment and ignores its action), ``same_step`` (the ending step already
    returns the new episode's first observation; the last one is in ``info["final_obs"]``, its
    info in ``info["final_info"]``) or ``disabled`` (reset ended environments with
    ``reset(options={"reset_mask": mask})``). Infos are dicts of arrays with ``_key`` masks.

    ``obs_mode``, ``image_size`` and ``cameras`` as for :class:`~panda_rapier.PandaEnv`: the
    images are drawn by the pool's threads right after each step (and before a same-step
    reset, for ``final_obs``), batched as ``(num_envs, height, width, 3)`` uint8 arrays.

    ``render()`` draws environment 0, or with ``render_envs=k`` the first ``k`` environments
    tiled in a near-square grid; ``render_mode``, ``width``, ``height`` and ``camera`` as for
    :class:`~panda_rapier.PandaEnv` (in ``human`` mode the window is updated by
    ``render()`` calls only).
    """

    def __init__(
        self,
        num_envs: int = 1,
        *,
        num_threads: int | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
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
        if num_threads is not None and (
            isinstance(num_threads, bool)
            or not isinstance(num_threads, int | np.integer)
            or num_threads < 1
        ):
            raise ConfigError(f"num_threads must be an int >= 1 or None, got {num_threads!r}")
        render_envs = check_render_envs(render_envs, int(num_envs))
        check_render_mode(render_mode)
        mode = as_autoreset_mode(autoreset_mode)
        self._bind_native(
            _native.PandaVecEnv(
                _common.config_json(config),
                int(num_envs),
                None if num_threads is None else int(num_threads),
                _NATIVE_MODES[mode],
            )
        )
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.metadata = {
            "autoreset_mode": mode,
            "render_modes": list(RENDER_MODES),
            "render_fps": round(1.0 / self._native.dt),
        }
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
        self.single_observation_space = self._obs.space()
        self.single_action_space = _common.action_space(self._native.action_dim)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._actions_shape = (self.num_envs, int(self._native.action_dim))
        self._masks_all = np.ones(self.num_envs, dtype=np.bool_)
        self._masks_all.flags.writeable = False
        self._render_envs = int(render_envs)
        self._frames = FrameSource(render_mode, width, height, camera, float(self._native.dt))

    @property
    def num_threads(self) -> int:
        """Threads of the pool stepping the environments."""
        return int(self._native.num_threads)

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Resets all environments, or those in ``options["reset_mask"]``.

        ``seed``: an int seeds environment ``i`` from ``(seed, i)``; a list gives one seed (or
        None) per environment.
        """
        if seed is None or isinstance(seed, int | np.integer):
            seeds = [_common.as_seed(seed)] * self.num_envs
            super().reset(seed=seeds[0])
        elif isinstance(seed, Sequence | np.ndarray) and len(seed) == self.num_envs:
            seeds = [_common.as_seed(s) for s in seed]
        else:
            raise InvalidArgumentError(
                f"seed must be an int, None or a list of {self.num_envs} seeds, got {seed!r}"
            )
        mask = None
        if options:
            unknown = set(options) - {"reset_mask"}
            if unknown:
                raise InvalidArgumentError(
                    f"vector reset options support only 'reset_mask', got {sorted(unknown)}"
                )
            mask = np.asarray(options["reset_mask"])
            if mask.dtype != np.bool_ or mask.shape != (self.num_envs,):
                raise InvalidArgumentError(
                    f"reset_mask must be a bool array of shape ({self.num_envs},), got "
                    f"{mask.dtype} {mask.shape}"
                )
            mask = np.ascontiguousarray(mask)
        flat = self._native.reset(seeds, mask)
        return self._observation(flat), self._with_masks(self._native.infos("step"))

    def step(
        self, actions: Any
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        flat, rewards, terminated, truncated = self._native.step(
            _common.as_actions(actions, self._actions_shape, "actions")
        )
        infos = self._native.infos("step")
        if self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP:
            ended = self._native.has_final_observation()
            if ended.any():
                infos = self._same_step_infos(infos, ended)
        return (
            self._observation(flat),
            rewards,
            terminated,
            truncated,
            self._with_masks(infos),
        )

    def _same_step_infos(
        self, step_infos: dict[str, np.ndarray], ended: np.ndarray
    ) -> dict[str, Any]:
        """Gymnasium's same-step layout: rows that ended report the new episode's reset info,
        with the ending step's observation and info under ``final_obs`` / ``final_info``."""
        reset_infos = self._native.infos("reset")
        infos: dict[str, Any] = {
            key: np.where(ended, reset_infos[key], column) for key, column in step_infos.items()
        }
        final_obs = np.full(self.num_envs, None, dtype=object)
        finals = self._observation(self._native.final_observations(), "final")
        for i in np.flatnonzero(ended):
            final_obs[i] = self._obs.row(finals, i)
        final_info: dict[str, Any] = {}
        for key, column in step_infos.items():
            final_info[key] = column
            final_info[f"_{key}"] = ended
        infos["final_obs"] = final_obs
        infos["_final_obs"] = ended
        infos["final_info"] = final_info
        infos["_final_info"] = ended
        return infos

    def _observation(self, flat: np.ndarray, which: str = "current") -> dict[str, np.ndarray]:
        images = self._native.images(which) if self._obs.has_sensors else None
        return self._obs.assemble(flat, images)

    def _with_masks(self, infos: dict[str, Any]) -> dict[str, Any]:
        missing = [k for k in infos if k[0] != "_" and "_" + k not in infos]
        infos.update(dict.fromkeys(["_" + k for k in missing], self._masks_all))
        return infos

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """Environment 0 (or the first ``render_envs`` tiled) as an HxWx3 uint8 frame, or shown
        in the window in ``human`` mode (returns None)."""
        if self.render_mode is None or self._frames is None:
            gym.logger.warn("render() called without a render_mode.")
            return None
        if isinstance(self._native, _common.Closed):
            self._native.check()
        renderer = self._frames.renderer
        frames = [renderer.render_vec_env(self._native, i) for i in range(self._render_envs)]
        return self._frames.output(tile(frames))

    def close_extras(self, **kwargs: Any) -> None:
        frames = getattr(self, "_frames", None)  # None, or absent if __init__ raised early
        if frames is not None:
            frames.close()
        self._native = _common.Closed("vector environment")


#: The name before tasks were added (``PickAndPlaceVectorEnv``), with a ``FutureWarning``.
__getattr__ = _common.renamed("panda_rapier.vector", {"PickAndPlaceVectorEnv": PandaVectorEnv})
