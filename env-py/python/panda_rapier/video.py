"""Videos of episodes: frames from the CPU renderer written with imageio-ffmpeg (the
``render`` extra; its wheel bundles an ffmpeg binary, so nothing else is needed)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from . import _native
from .errors import PandaRapierError
from .rendering import DEFAULT_HEIGHT, DEFAULT_WIDTH, make_renderer


def open_video_writer(path: str | Path, fps: float) -> Any:
    """An imageio writer for ``path`` (H.264 for .mp4, any container ffmpeg knows)."""
    try:
        import imageio.v2 as imageio
        import imageio_ffmpeg  # noqa: F401  (imageio needs it for ffmpeg formats)
    except ImportError as error:
        raise PandaRapierError(
            "writing videos needs imageio and imageio-ffmpeg: pip install 'panda-rapier[render]'"
        ) from error
    return imageio.get_writer(
        str(path),
        format="FFMPEG",
        mode="I",
        fps=fps,
        codec="libx264",
        pixelformat="yuv420p",
        # H.264 needs even sizes; imageio pads up to a multiple of this.
        macro_block_size=2,
        ffmpeg_log_level="error",
    )


class VideoRecorder:
    """Records environment 0 of a native vector env, one frame per :meth:`capture`."""

    def __init__(
        self,
        path: str | Path,
        fps: float,
        *,
        width: int = DEFAULT_WIDTH,
        height: int = DEFAULT_HEIGHT,
        camera: Mapping[str, Any] | None = None,
    ) -> None:
        self.path = Path(path)
        self._renderer = make_renderer(width, height, camera)
        self._writer = open_video_writer(self.path, fps)
        self.frames = 0

    def capture(self, envs: _native.PandaVecEnv | _native.Evaluation, index: int = 0) -> np.ndarray:
        """Appends a frame of environment ``index`` of a native vector env or of the vector
        env of a native evaluation (what :func:`~panda_rapier.agents.evaluation.evaluate`
        passes)."""
        if isinstance(envs, _native.Evaluation):
            frame = self._renderer.render_evaluation(envs, index)
        else:
            frame = self._renderer.render_vec_env(envs, index)
        self._writer.append_data(frame)
        self.frames += 1
        return frame

    def close(self) -> None:
        self._writer.close()

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
