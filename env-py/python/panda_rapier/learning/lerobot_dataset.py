"""Expert demonstrations as LeRobot datasets (LeRobotDataset, format v3.0, as lerobot 0.6
reads it): the scripted policy's seeded episodes, recorded in parallel on the native vector env.

:func:`record_lerobot` runs :class:`~panda_rapier.ScriptedPolicy` on ``episodes`` episodes of a
registered id (either action mode, any task), episode ``k`` reset with seed ``first_seed + k``
on the evaluation's refill schedule (:func:`panda_rapier.agents.evaluation.evaluate`, ``num_envs``
environments stepped by the Rust thread pool), and writes them in episode order with LeRobot's
own writer (``LeRobotDataset.create``, ``add_frame``, ``save_episode``, ``finalize``) into
``root``. One frame per step, before the step is taken:

=================================  ==========================================================
key                                value
=================================  ==========================================================
``observation.state``              float32 ``(flat_dim,)``: the flat observation (goals first,
                                   then the ``observation`` entries), each value named by its
                                   slot (``cube_position.0``, ...)
``observation.images.<camera>``    uint8 ``(H, W, 3)`` per camera in ``cameras`` (videos, or
                                   PNG images with ``use_videos=False``)
``action``                         float32 ``(action_dim,)``: the action taken, named by the
                                   action mode (``dx``, ``dy``, ``dz``, ``gripper`` for ``ee``)
=================================  ==========================================================

With ``environment_state=True`` the flat observation is split in two, as LeRobot's own
simulations do (and as ACT and Diffusion Policy need when they see no images):
``observation.state`` holds the goals and the robot's own state, and
``observation.environment_state`` the task's entries (the objects' state: ``cube_position``,
...; the slots the schema marks as the task's); :func:`state_split` says which columns go where.

plus LeRobot's own ``timestamp``, ``frame_index``, ``episode_index``, ``index`` and
``task_index``; the task string of every episode is the task's one-line summary. The frame
rate is the environment's control rate (25 fps).

What LeRobot's format has no place for is written beside it, in ``meta/panda_rapier.json``:
the environment's full configuration, the package version, and per episode its ``seed``,
``env_index`` (the random stream it ran on), ``length``, ``success``, ``placed`` and
``episode_return``. The environment is bit-for-bit reproducible, so an episode is fully
determined by its seed, stream and actions: :func:`replay_lerobot_episode` regenerates every
recorded state exactly.

Needs the ``lerobot`` extra (``pip install "panda-rapier[lerobot]"``, Python >= 3.12).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__, _common
from ..agents.evaluation import evaluate
from ..agents.lerobot_policy import state_split
from ..env import PandaEnv
from ..errors import ConfigError, InvalidArgumentError
from ..pixels import DEFAULT_IMAGE_SIZE, observation_spec
from ..policy import ScriptedPolicy
from ..registration import ENV_IDS, TASKS, env_config, variant
from ..seeds import DEMOS_FIRST_SEED

__all__ = [
    "LEROBOT_META_FILE",
    "LeRobotRecording",
    "action_names",
    "default_repo_id",
    "record_lerobot",
    "replay_lerobot_episode",
    "state_split",
]

#: The file beside LeRobot's metadata with what its format has no place for.
LEROBOT_META_FILE = "meta/panda_rapier.json"


@dataclass
class LeRobotRecording:
    """What :func:`record_lerobot` wrote."""

    repo_id: str
    root: str
    episodes: int
    frames: int
    success_rate: float
    cameras: tuple[str, ...]
    wall_time_s: float


def _lerobot_dataset_class() -> Any:
    try:
        from lerobot.datasets.lerobot_dataset import LeRobotDataset
    except ImportError as error:
        raise ImportError(
            "LeRobot datasets need lerobot (Python >= 3.12): pip install 'panda-rapier[lerobot]'"
        ) from error
    return LeRobotDataset


def default_repo_id(env_id: str) -> str:
    """``panda_rapier/<variant>-expert``, e.g. ``panda_rapier/PickAndPlace-expert``."""
    if env_id not in ENV_IDS:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS")
    return f"panda_rapier/{env_id.split('/', 1)[1].rsplit('-v', 1)[0]}-expert"


def action_names(control_mode: str, action_dim: int) -> list[str]:
    """The name of each action entry in ``control_mode``."""
    names = {
        "ee": ["dx", "dy", "dz", "gripper"],
        "ee_pose": ["dx", "dy", "dz", "rx", "ry", "rz", "gripper"],
    }.get(control_mode, [f"joint{i + 1}" for i in range(action_dim - 1)] + ["gripper"])
    if len(names) != action_dim:
        raise ConfigError(f"control_mode {control_mode!r} has {action_dim} action entries")
    return names


def _state_names(schema: _common.Schema) -> list[str]:
    names = [""] * schema.flat_dim
    for slot in schema.slots:
        for i in range(int(slot["start"]), int(slot["stop"])):
            names[i] = f"{slot['name']}.{i - int(slot['start'])}"
    return names


def _task_summary(task: str) -> str:
    return next(str(t["summary"]) for t in TASKS if t["name"] == task)


def record_lerobot(
    env_id: str,
    episodes: int,
    root: str | Path,
    *,
    repo_id: str | None = None,
    cameras: Mapping[str, Mapping[str, Any]] | None = None,
    image_size: int | tuple[int, int] = DEFAULT_IMAGE_SIZE,
    use_videos: bool = True,
    num_envs: int = 8,
    num_threads: int | None = None,
    first_seed: int = DEMOS_FIRST_SEED,
    env_kwargs: Mapping[str, Any] | None = None,
    environment_state: bool = False,
    progress: Callable[[int], object] | None = None,
) -> LeRobotRecording:
    """Records ``episodes`` episodes of the scripted expert on ``env_id`` (with
    ``env_kwargs``) as a LeRobot dataset in the directory ``root`` (which must not exist yet;
    see the module's documentation). ``cameras`` (as for :class:`~panda_rapier.PandaEnv`,
    e.g. ``{"front": panda_rapier.pixels.DEFAULT_CAMERA}``) adds an image stream per camera
    at ``image_size``; ``None`` records states only. ``environment_state`` splits the flat
    observation into ``observation.state`` and ``observation.environment_state``
    (:func:`state_split`). ``progress`` is called with the number of finished episodes."""
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise InvalidArgumentError(f"episodes must be an int >= 1, got {episodes!r}")
    root = Path(root)
    if root.exists():
        raise InvalidArgumentError(
            f"root {str(root)!r} already exists: LeRobot writes a new dataset into a new "
            "directory (remove it or pass another)"
        )
    dataset_class = _lerobot_dataset_class()
    config = env_config(env_id, **dict(env_kwargs or {}))
    fixed = variant(env_id)
    control_mode = str(config.get("control_mode", fixed["control_mode"]))
    config_json = _common.config_json(config)
    schema = _common.Schema.of(config_json)
    camera_keys = tuple(cameras or ())
    obs_mode = "state+rgb" if camera_keys else "state"

    if not isinstance(environment_state, bool):
        raise InvalidArgumentError(
            f"environment_state must be True or False, got {environment_state!r}"
        )
    names = _state_names(schema)
    state_columns, environment_columns = (
        state_split(schema) if environment_state else (list(range(schema.flat_dim)), [])
    )

    probe = PandaEnv(**config)
    fps = int(probe.metadata["render_fps"])  # the control rate
    probe.close()
    features: dict[str, dict[str, Any]] = {
        "observation.state": {
            "dtype": "float32",
            "shape": (len(state_columns),),
            "names": [names[i] for i in state_columns],
        },
        "action": {
            "dtype": "float32",
            "shape": (schema.action_dim,),
            "names": action_names(control_mode, schema.action_dim),
        },
    }
    if environment_columns:
        features["observation.environment_state"] = {
            "dtype": "float32",
            "shape": (len(environment_columns),),
            "names": [names[i] for i in environment_columns],
        }
    height, width = (image_size, image_size) if isinstance(image_size, int) else image_size
    for key in camera_keys:
        features[f"observation.images.{key}"] = {
            "dtype": "video" if use_videos else "image",
            "shape": (height, width, 3),
            "names": ["height", "width", "channels"],
        }
    repo_id = repo_id or default_repo_id(env_id)
    task = _task_summary(str(fixed["task"]))
    dataset = dataset_class.create(
        repo_id=repo_id,
        fps=fps,
        features=features,
        root=root,
        robot_type="franka_panda",
        use_videos=use_videos,
    )

    # Frames by episode until the episode is written; episodes are written in order, each
    # once it has ended (it ran at the last step and runs no more).
    buffers: dict[int, list[dict[str, Any]]] = {}
    finished: set[int] = set()
    running_before: list[int | None] = []
    written = 0
    frames = 0

    def flush() -> None:
        nonlocal written, frames
        while written in finished:
            for frame in buffers.pop(written, []):
                dataset.add_frame(frame)
                frames += 1
            dataset.save_episode()
            written += 1

    def on_step(
        observations: np.ndarray,
        actions: np.ndarray,
        running: list[int | None],
        images: Any = None,
    ) -> None:
        nonlocal running_before
        finished.update(k for k in running_before if k is not None and k not in running)
        flush()
        running_before = list(running)
        assembled = spec.assemble(observations, images) if camera_keys else None
        for i, episode in enumerate(running):
            if episode is None:
                continue
            frame: dict[str, Any] = {
                "observation.state": np.array(observations[i, state_columns], dtype=np.float32),
                "action": np.array(actions[i], dtype=np.float32),
                "task": task,
            }
            if environment_columns:
                frame["observation.environment_state"] = np.array(
                    observations[i, environment_columns], dtype=np.float32
                )
            if assembled is not None:
                for key in camera_keys:
                    frame[f"observation.images.{key}"] = np.array(assembled[key][i])
            buffers.setdefault(episode, []).append(frame)

    spec = observation_spec(schema, obs_mode, image_size, cameras, None, config_json=config_json)

    started = time.perf_counter()
    # LeRobot's writer maps every saved episode through Hugging Face datasets, each with a
    # progress bar of its own: off while recording (the caller's bar counts the episodes).
    from datasets.utils import logging as datasets_logging

    bars_were_on = datasets_logging.is_progress_bar_enabled()
    datasets_logging.disable_progress_bar()
    try:
        report = evaluate(
            ScriptedPolicy(config), config, episodes, num_envs=num_envs, first_seed=first_seed,
            num_threads=num_threads, progress=progress, on_step=on_step, obs_mode=obs_mode,
            image_size=image_size, cameras=cameras,
        )  # fmt: skip
        finished.update(range(episodes))
        flush()
        dataset.finalize()
    finally:
        if bars_were_on:
            datasets_logging.enable_progress_bar()
    if written != episodes:
        raise RuntimeError(f"wrote {written} of {episodes} episodes")  # a bug, not bad input

    meta = {
        "panda_rapier_version": __version__,
        "env_id": env_id,
        "config": report.config,
        "obs_mode": obs_mode,
        "environment_state": environment_state,
        "cameras": {key: dict(value) for key, value in (cameras or {}).items()},
        "image_size": [height, width],
        "first_seed": first_seed,
        "num_envs": report.num_envs,
        "episodes": [
            {
                "episode_index": k,
                "seed": record.seed,
                "env_index": record.env_index,
                "length": record.length,
                "success": record.success,
                "placed": record.placed,
                "episode_return": record.episode_return,
            }
            for k, record in enumerate(report.episodes)
        ],
    }
    (root / LEROBOT_META_FILE).write_text(json.dumps(meta, indent=1) + "\n")
    return LeRobotRecording(
        repo_id=repo_id,
        root=str(root),
        episodes=episodes,
        frames=frames,
        success_rate=report.success_rate,
        cameras=camera_keys,
        wall_time_s=time.perf_counter() - started,
    )


def replay_lerobot_episode(root: str | Path, episode_index: int) -> dict[str, np.ndarray]:
    """Replays episode ``episode_index`` of the dataset at ``root`` from its seed, stream and
    recorded actions; returns the states the environment produced (``observation.state``,
    and ``observation.environment_state`` where the dataset has it, one row per recorded
    frame) and the actions replayed (``action``), for comparison with the recorded ones."""
    root = Path(root)
    meta = json.loads((root / LEROBOT_META_FILE).read_text())
    episodes = meta["episodes"]
    if not 0 <= episode_index < len(episodes):
        raise InvalidArgumentError(
            f"episode_index must be in [0, {len(episodes)}), got {episode_index!r}"
        )
    entry = episodes[episode_index]
    dataset = _lerobot_dataset_class()(
        f"panda_rapier/replay-{episode_index}", root=root, episodes=[episode_index]
    )
    actions = np.stack([np.asarray(dataset[i]["action"]) for i in range(len(dataset))])
    from ..vector import PandaVectorEnv

    env_index = int(entry["env_index"])
    config = dict(meta["config"])
    config["max_episode_steps"] = None
    vec = PandaVectorEnv(num_envs=env_index + 1, num_threads=1, **config)
    try:
        obs, _ = vec.reset(seed=int(entry["seed"]))
        schema = _common.Schema.of(_common.config_json(config))
        states = []
        for action in actions:
            states.append(_flat_row(obs, schema, env_index))
            batch = np.zeros((env_index + 1, actions.shape[1]), dtype=np.float32)
            batch[env_index] = action
            obs, *_ = vec.step(batch)
    finally:
        vec.close()
    flat = np.stack(states)
    if not meta.get("environment_state", False):
        return {"observation.state": flat, "action": actions.astype(np.float32)}
    state_columns, environment_columns = state_split(schema)
    return {
        "observation.state": flat[:, state_columns],
        "observation.environment_state": flat[:, environment_columns],
        "action": actions.astype(np.float32),
    }


def _flat_row(obs: Mapping[str, np.ndarray], schema: _common.Schema, row: int) -> np.ndarray:
    flat = np.empty(schema.flat_dim, dtype=np.float32)
    for key in ("achieved_goal", "desired_goal", "observation"):
        flat[schema.part(key)] = obs[key][row]
    return flat
