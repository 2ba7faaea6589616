"""Frames for the environments: the CPU renderer (``rgb_array``), tiling of vector envs, and
the live window of ``render_mode="human"`` (pygame, the ``render`` extra)."""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from . import _native
from .errors import ConfigError, DisplayError

#: The render modes every panda_rapier environment accepts.
RENDER_MODES = ("human", "rgb_array")

#: Default picture size (pixels): the native renderer's (``RenderConfig::default``).
DEFAULT_WIDTH: int = _native.DEFAULT_RENDER_WIDTH
DEFAULT_HEIGHT: int = _native.DEFAULT_RENDER_HEIGHT

_NO_DISPLAY_HINT = (
    "use render_mode='rgb_array' to get frames (for videos) without a display, or run under a "
    "virtual display (xvfb-run python ...)"
)


def check_render_mode(render_mode: str | None) -> None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ConfigError(f"render_mode must be one of {RENDER_MODES} or None, got {render_mode!r}")


def check_render_envs(render_envs: Any, num_envs: int) -> int:
    """``render_envs`` of a vector environment: an int in ``[1, num_envs]``."""
    if (
        isinstance(render_envs, bool)
        or not isinstance(render_envs, int | np.integer)
        or not 1 <= render_envs <= num_envs
    ):
        raise ConfigError(f"render_envs must be an int in [1, num_envs], got {render_envs!r}")
    return int(render_envs)


def make_renderer(width: Any, height: Any, camera: Mapping[str, Any] | None) -> _native.Renderer:
    """A native renderer; bad sizes or camera options raise :class:`ConfigError`."""
    for name, value in (("width", width), ("height", height)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise ConfigError(f"{name} must be an int (pixels), got {value!r}")
    if camera is not None and not isinstance(camera, Mapping):
        raise ConfigError(f"camera must be a dict of camera options or None, got {camera!r}")
    try:
        config = json.dumps(
            {"width": int(width), "height": int(height), "camera": dict(camera or {})},
            allow_nan=False,
            default=lambda v: v.tolist() if isinstance(v, np.ndarray | np.generic) else str(v),
        )
    except ValueError as error:
        raise ConfigError(f"camera options must be finite numbers: {error}") from error
    return _native.Renderer(config)


def tile(frames: list[np.ndarray]) -> np.ndarray:
    """Frames of equal size in a near-square grid, row by row; empty cells are black."""
    if len(frames) == 1:
        return frames[0]
    columns = math.ceil(math.sqrt(len(frames)))
    rows = math.ceil(len(frames) / columns)
    height, width, _ = frames[0].shape
    grid = np.zeros((rows * height, columns * width, 3), dtype=np.uint8)
    for k, frame in enumerate(frames):
        r, c = divmod(k, columns)
        grid[r * height : (r + 1) * height, c * width : (c + 1) * width] = frame
    return grid


class Viewer:
    """A window showing frames at the simulation's pace (one frame per control step)."""

    def __init__(self, width: int, height: int, title: str = "panda_rapier") -> None:
        if sys.platform.startswith("linux") and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        ):
            raise DisplayError(
                "render_mode='human' opens a window, but no display was found (DISPLAY and "
                f"WAYLAND_DISPLAY are not set); {_NO_DISPLAY_HINT}"
            )
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        try:
            import pygame
        except ImportError as error:
            raise DisplayError(
                "render_mode='human' needs pygame: pip install 'panda-rapier[render]' "
                "(render_mode='rgb_array' does not)"
            ) from error
        self._pygame = pygame
        try:
            pygame.display.init()
            self._screen = pygame.display.set_mode((width, height))
        except pygame.error as error:
            pygame.display.quit()
            raise DisplayError(
                f"render_mode='human' could not open a window ({error}); {_NO_DISPLAY_HINT}"
            ) from error
        pygame.display.set_caption(title)
        self._size = (width, height)
        self._due: float | None = None

    def show(self, frame: np.ndarray, period: float) -> None:
        """Shows ``frame`` (HxWx3 uint8), then waits until ``period`` seconds have passed since
        the previous frame was due, so the window follows simulated time in real time."""
        pygame = self._pygame
        pygame.event.pump()
        height, width, _ = frame.shape
        if (width, height) != self._size:
            self._screen = pygame.display.set_mode((width, height))
            self._size = (width, height)
        pygame.surfarray.blit_array(self._screen, np.ascontiguousarray(frame.swapaxes(0, 1)))
        pygame.display.flip()
        now = time.perf_counter()
        # A late frame restarts the clock instead of being followed by a burst of catch-up.
        self._due = now if self._due is None else max(now, self._due + period)
        if self._due > now:
            time.sleep(self._due - now)

    def close(self) -> None:
        self._pygame.display.quit()


class FrameSource:
    """What an environment needs for ``render()``: the renderer and, in human mode, the
    window."""

    def __init__(
        self,
        render_mode: str | None,
        width: Any,
        height: Any,
        camera: Mapping[str, Any] | None,
        period: float,
    ) -> None:
        check_render_mode(render_mode)
        self.render_mode = render_mode
        self.renderer = make_renderer(width, height, camera)
        self.period = period
        self._viewer: Viewer | None = None
        if render_mode == "human":
            self._viewer = Viewer(self.renderer.width, self.renderer.height)

    def output(self, frame: np.ndarray) -> np.ndarray | None:
        """The frame for ``rgb_array``; shown (and ``None``) for ``human``."""
        if self._viewer is None:
            return frame
        self._viewer.show(frame, self.period)
        return None

    def close(self) -> None:
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None
