"""Policies that see: a student acting on camera images, distilled from the scripted expert.

The student observes what ``obs_mode="proprio+rgb"`` gives: camera images, the robot's own
state (``proprioception``) and the commanded goal (``desired_goal``), nothing of the
simulator's object state; or depth images instead of colour (``"proprio+depth"``), or both
(``"proprio+rgbd"``). The scripted expert reads that state, so it can label any state the
student reaches: DAgger (Ross et al., 2011) with a privileged teacher. The expert first drives
``demo_episodes`` episodes; then, each round, the student drives, every state it visits is
stored as the student's observation (colour images as uint8, channels first; depth as
float32, as observed) with the expert's action
in it, and the student is refitted on everything gathered (:func:`distil`).

The student is a stable-baselines3 PPO ``MultiInputPolicy`` whose features extractor is
:class:`~panda_rapier.agents.student_model.PixelEncoder` (per camera a small CNN ending in image
keypoints, next to the standardised vector entries), so PPO can fine-tune it. Its zip carries
the architecture as data, and :func:`~panda_rapier.agents.student_model.load_student` rebuilds it
and reads the weights by data, so ``panda-rapier eval --policy`` evaluates it without
``--trust-model-file``.

Needs the ``train`` extra (stable-baselines3 and torch).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.logger import configure
from torch import nn
from tqdm import tqdm

from .. import _common
from ..agents.evaluation import evaluate
from ..agents.model_file import save_model
from ..agents.student_model import PixelEncoder, policy_kwargs, student_architecture
from ..errors import InvalidArgumentError
from ..pixels import observation_spec
from ..policy import ScriptedPolicy
from ..sb3 import make_vec_env
from .rollouts import RolloutStats
from .threads import torch_threads

__all__ = ["StudentData", "collect_student", "distil", "fit_student", "train_student"]


@dataclass
class StudentData:
    """The student's observations (colour image keys: uint8 ``(n, 3, height, width)``; depth
    keys: float32 ``(n, height, width, 1)``; the others float32 rows) with the expert's
    actions in those states."""

    observations: dict[str, np.ndarray]
    actions: np.ndarray
    episode_index: np.ndarray
    episode_seeds: list[int] = field(default_factory=list)

    def __len__(self) -> int:
        return int(self.actions.shape[0])

    @property
    def num_episodes(self) -> int:
        return len(self.episode_seeds)

    @property
    def nbytes(self) -> int:
        return sum(v.nbytes for v in self.observations.values()) + self.actions.nbytes

    def extend(self, other: StudentData) -> None:
        """Appends ``other``'s rows and episodes."""
        offset = self.num_episodes
        self.observations = {
            k: np.concatenate([v, other.observations[k]]) for k, v in self.observations.items()
        }
        self.actions = np.concatenate([self.actions, other.actions])
        self.episode_index = np.concatenate([self.episode_index, other.episode_index + offset])
        self.episode_seeds += other.episode_seeds


def collect_student(
    config: Mapping[str, Any],
    observation: Mapping[str, Any],
    episodes: int,
    *,
    first_seed: int,
    actor: Any = None,
    num_envs: int = 32,
    num_threads: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> tuple[StudentData, RolloutStats]:
    """Runs ``episodes`` seeded episodes of the environment ``config`` with the observation
    options ``observation`` (``obs_mode``, ``image_size``, ``cameras``), driven by ``actor``
    (a student, or ``None``: the scripted expert), and records every state visited as the
    student observes it, with the expert's action. Returns the data and how the driver did."""
    spec = observation_spec(_common.Schema.of(_common.config_json(config)), **observation)
    if not spec.has_images:
        raise InvalidArgumentError("a student observes images: obs_mode must have rgb or depth")
    expert = ScriptedPolicy(config)
    space = spec.space()
    assert isinstance(space, spaces.Dict)  # obs_mode has images
    chunks: dict[str, list[np.ndarray]] = {key: [] for key in space.spaces}
    labels: list[np.ndarray] = []
    episode_rows: list[np.ndarray] = []

    def record(
        flat: np.ndarray, actions: np.ndarray, running: list[int | None], images: np.ndarray
    ) -> None:
        active = np.array([r is not None for r in running])
        obs = spec.assemble(flat[active], images[active])
        for key, value in obs.items():
            colour = value.ndim == 4 and value.dtype == np.uint8  # as SB3 transposes them
            chunks[key].append(value.transpose(0, 3, 1, 2).copy() if colour else value)
        labels.append((actions if actor is None else expert._native.act(flat))[active].copy())
        episode_rows.append(np.array([r for r in running if r is not None], dtype=np.int64))

    report = evaluate(
        expert if actor is None else actor,
        config,
        episodes,
        num_envs=num_envs,
        first_seed=first_seed,
        num_threads=num_threads,
        progress=progress,
        on_step=record,
        **observation,
    )
    data = StudentData(
        observations={k: np.concatenate(v) for k, v in chunks.items()},
        actions=np.concatenate(labels).astype(np.float32),
        episode_index=np.concatenate(episode_rows),
        episode_seeds=[e.seed for e in report.episodes],
    )
    return data, RolloutStats.of(report, len(data))


def _encoder(policy: nn.Module) -> PixelEncoder:
    encoders = [m for m in policy.modules() if isinstance(m, PixelEncoder)]
    if not encoders:
        raise InvalidArgumentError("the model has no PixelEncoder: not a student")
    return encoders[0]


def fit_student(
    model: Any,
    data: StudentData,
    *,
    updates: int,
    batch_size: int = 128,
    learning_rate: float = 3e-4,
    final_lr_fraction: float = 1.0,
    seed: int = 0,
    progress: Callable[[int], None] | None = None,
) -> float:
    """Fits the mean action of ``model``'s policy to the expert's actions in ``data`` by mean
    squared error with Adam, for ``updates`` mini-batches drawn uniformly (seeded) from all
    rows, the learning rate falling linearly to ``final_lr_fraction`` of ``learning_rate``.
    Returns the mean loss of the last tenth of the updates."""
    if len(data) == 0 or updates < 1:
        raise InvalidArgumentError("a fit needs data and at least one update")
    policy = model.policy
    policy.set_training_mode(True)
    generator = np.random.default_rng(seed)
    parameters = [p for name, p in policy.named_parameters() if not name.startswith("value_net")]
    optimizer = th.optim.Adam(parameters, lr=learning_rate)
    schedule = th.optim.lr_scheduler.LinearLR(
        optimizer, 1.0, final_lr_fraction, total_iters=max(1, updates - 1)
    )
    target = th.as_tensor(data.actions)
    tail: list[float] = []
    for update in range(updates):
        index = np.sort(generator.integers(0, len(data), batch_size))
        batch = {k: th.as_tensor(v[index]) for k, v in data.observations.items()}
        mean = policy.get_distribution(batch).distribution.mean
        loss = nn.functional.mse_loss(mean, target[index])
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        schedule.step()
        if update >= updates - max(1, updates // 10):
            tail.append(float(loss.detach()))
        if progress is not None:
            progress(update + 1)
    policy.set_training_mode(False)
    return float(np.mean(tail))


def distil(
    model: Any,
    config: Mapping[str, Any],
    observation: Mapping[str, Any],
    *,
    demo_episodes: int,
    rounds: int,
    episodes_per_round: int,
    first_updates: int,
    round_updates: int,
    final_updates: int,
    first_seed: int,
    batch_size: int = 128,
    learning_rate: float = 3e-4,
    num_envs: int = 32,
    num_threads: int | None = None,
    fit_threads: int | None = None,
    on_round: Callable[[int, StudentData, RolloutStats | None, float], None] | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> StudentData:
    """DAgger with a privileged teacher: ``demo_episodes`` driven by the scripted expert, a
    fit of ``first_updates`` mini-batches, then ``rounds`` rounds in which the student drives
    ``episodes_per_round`` episodes, the expert labels every state, and the student is refitted
    on all data for ``round_updates`` mini-batches; finally ``final_updates`` more with the
    learning rate decaying to 5 %. Episode seeds count up from ``first_seed``. The vector
    entries' scaler and the depth images' are fitted to the expert's states. torch fits on
    ``fit_threads`` threads (no environment steps during a fit). ``on_round(r, data, stats,
    loss)`` is called after each fit (``stats``: how the student drove in round ``r``;
    ``None`` for round 0 and the final fit)."""
    seed = first_seed

    def tick(what: str, total: int) -> Callable[[int], None] | None:
        if progress is None:
            return None
        return lambda done: progress(what, done, total)

    def fit(data: StudentData, what: str, updates: int, r: int, decay: float = 1.0) -> float:
        with torch_threads(fit_threads):
            return fit_student(
                model, data, updates=updates, batch_size=batch_size, seed=r,
                learning_rate=learning_rate, final_lr_fraction=decay,
                progress=tick(what, updates),
            )  # fmt: skip

    data, _ = collect_student(
        config, observation, demo_episodes, first_seed=seed, num_envs=num_envs,
        num_threads=num_threads, progress=tick("demonstrations", demo_episodes),
    )  # fmt: skip
    seed += demo_episodes
    encoder = _encoder(model.policy)
    encoder.fit(np.concatenate([data.observations[k] for k in encoder.vector_keys], axis=1))
    if encoder.depth_keys:
        encoder.fit_depth([data.observations[k] for k in encoder.depth_keys])
    loss = fit(data, "fit 0", first_updates, 0)
    if on_round is not None:
        on_round(0, data, None, loss)
    for r in range(1, rounds + 1):
        new, stats = collect_student(
            config, observation, episodes_per_round, first_seed=seed, actor=model,
            num_envs=num_envs, num_threads=num_threads,
            progress=tick(f"round {r}: student drives", episodes_per_round),
        )  # fmt: skip
        seed += episodes_per_round
        data.extend(new)
        loss = fit(data, f"fit {r}", round_updates, r)
        if on_round is not None:
            on_round(r, data, stats, loss)
    if final_updates > 0:
        loss = fit(data, "final fit", final_updates, rounds + 1, decay=0.05)
        if on_round is not None:
            on_round(rounds + 1, data, None, loss)
    return data


def train_student(
    run: dict[str, Any],
    recipe: Mapping[str, Any],
    config: Mapping[str, Any],
    observation: Mapping[str, Any],
    out: Path,
    n_envs: int | None,
    num_threads: int | None,
    recorder: Any,
    say: Callable[[str], None],
    show_progress: bool = True,
    fit_threads: int | None = None,
) -> dict[str, Any]:
    """``panda-rapier train --algo bc`` with image observations: :func:`distil` with the
    recipe's counts, a validation after every fit by ``recorder``
    (:class:`~panda_rapier.learning.runs.Recorder`, which writes ``evaluations.jsonl`` and
    ``best.zip`` and keeps the wall time), the run record and ``model.zip`` (the final fit's
    weights)."""
    arch = student_architecture(recipe.get("student"))
    n = int(n_envs if n_envs is not None else recipe.get("n_envs", 32))
    run.update(n_envs=n, student=arch)
    env = make_vec_env(run["env_id"], n_envs=1, **run["env_kwargs"])
    model = PPO("MultiInputPolicy", env, policy_kwargs=policy_kwargs(arch), seed=run["seed"],
                device="cpu")  # fmt: skip
    logger = configure(str(out / "tensorboard" / "bc_1"), ["tensorboard"])
    (out / "run.json").write_text(json.dumps(run, indent=2, default=str))
    bars: dict[str, Any] = {}
    started = time.perf_counter()

    def progress(what: str, done: int, total: int) -> None:
        bar = bars.get(what)
        if bar is None:
            unit = "update" if what.startswith(("fit", "final")) else "ep"
            bar = bars[what] = tqdm(total=total, desc=what, unit=unit, leave=False)
        bar.update(done - bar.n)
        if done >= total:
            bar.close()

    def on_round(r: int, data: StudentData, stats: RolloutStats | None, loss: float) -> None:
        drove = (
            "expert demonstrations" if r == 0 else "final fit" if stats is None
            else f"student drove: success {stats.success_rate:.3f}, placed {stats.placed_rate:.3f}"
        )  # fmt: skip
        say(
            f"round {r}: {len(data):,} labelled states ({data.nbytes / 2**30:.2f} GiB; {drove});"
            f" loss {loss:.4f}; {(time.perf_counter() - started) / 60:.1f} min"
        )
        logger.record("bc/loss", loss)
        logger.record("bc/labelled_states", len(data))
        if stats is not None:
            logger.record("rollout/success_rate", stats.success_rate)
            logger.record("rollout/placed_rate", stats.placed_rate)
        recorder.evaluate(model, len(data), logger)
        logger.dump(len(data))

    data = distil(
        model,
        config,
        observation,
        demo_episodes=int(recipe["demo_episodes"]),
        rounds=int(recipe["dagger_rounds"]),
        episodes_per_round=int(recipe["dagger_episodes"]),
        first_updates=int(recipe["first_updates"]),
        round_updates=int(recipe["round_updates"]),
        final_updates=int(recipe["final_updates"]),
        first_seed=run["train_first_seed"],
        batch_size=int(recipe.get("batch_size", 128)),
        learning_rate=float(recipe.get("learning_rate", 3e-4)),
        num_envs=n,
        num_threads=num_threads,
        fit_threads=fit_threads,
        on_round=on_round,
        progress=progress if show_progress else None,
    )
    run["env_steps"] = len(data)
    run["demonstration_episodes"] = data.num_episodes
    run["wall_time_s"] = round(recorder.wall_time(), 3)
    run["final_weights"] = run.get("last_evaluation")
    save_model(model, out / "model.zip", run)
    (out / "run.json").write_text(json.dumps(run, indent=2, default=str))
    return run
