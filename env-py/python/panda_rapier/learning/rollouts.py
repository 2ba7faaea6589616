"""The scripted expert's episodes, and any policy's episodes labelled by the expert, as a
dataset: :func:`collect` and :class:`Demonstrations` (flat observations in Gymnasium's
``spaces.flatten`` order with the expert's actions), and :class:`RolloutStats` (how the
driving policy did).

What behaviour cloning and DAgger (:mod:`panda_rapier.learning.imitation`, which re-exports these)
learn from, and what :mod:`panda_rapier.learning.normalization` fits the observation scaler to.
Needs numpy only.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import _common
from ..agents.evaluation import _actor, evaluate
from ..errors import InvalidArgumentError
from ..pixels import observation_spec
from ..policy import ScriptedPolicy

__all__ = ["Demonstrations", "RolloutStats", "collect", "expert_steps", "row_uniforms"]

_MASK = (1 << 64) - 1


def _mix(z: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser on every element (uint64 arithmetic wraps)."""
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def row_uniforms(observations: np.ndarray, salt: int) -> np.ndarray:
    """One number in [0, 1) per flat observation row, from a hash of the row's float32 bits and
    ``salt`` (splitmix64 over its words): random-looking, but a function of the row alone, so
    a choice made with it is the same for any batching of the rows, any number of
    environments or threads, and a run repeats bit for bit."""
    rows = np.ascontiguousarray(observations, dtype=np.float32)
    if rows.ndim != 2:
        raise InvalidArgumentError(f"observations must be (n, d) rows, got shape {rows.shape}")
    bits = rows.view(np.uint32).astype(np.uint64)
    start = (int(salt) * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & _MASK
    h = _mix(np.full(rows.shape[0], start, dtype=np.uint64))
    for column in bits.T:
        h = _mix(h ^ column)
    return (h >> np.uint64(11)).astype(np.float64) * 2.0**-53


def expert_steps(observations: np.ndarray, share: float, salt: int) -> np.ndarray:
    """Which of the flat observation rows the expert acts in when it takes each step with
    probability ``share`` (DAgger's mixed policy, :func:`collect`): a boolean per row,
    :func:`row_uniforms` below ``share``."""
    return row_uniforms(observations, salt) < share


@dataclass
class RolloutStats:
    """How the episodes of one :func:`collect` call went (for the policy that drove)."""

    episodes: int
    env_steps: int
    success_rate: float
    placed_rate: float
    wall_time_s: float

    @classmethod
    def of(cls, report: Any, env_steps: int) -> RolloutStats:
        """How the driver of an :class:`~panda_rapier.agents.evaluation.EvaluationReport` did."""
        return cls(
            episodes=len(report.episodes),
            env_steps=env_steps,
            success_rate=report.success_rate,
            placed_rate=report.placed_rate,
            wall_time_s=report.wall_time_s,
        )


@dataclass
class Demonstrations:
    """States and the expert's actions in them, with the environment they came from.

    ``observations`` are flat rows (``achieved_goal``, ``desired_goal``, ``observation``, as
    Gymnasium's ``spaces.flatten`` orders the dict); :func:`panda_rapier._common.split_observation`
    gives the dict back. ``episode_index`` says which recorded episode each row belongs to;
    ``episode_seeds`` the seed each episode was reset with.
    """

    config: dict[str, Any]
    observations: np.ndarray
    actions: np.ndarray
    episode_index: np.ndarray
    episode_seeds: list[int] = field(default_factory=list)
    episode_success: list[bool] = field(default_factory=list)
    episode_placed: list[bool] = field(default_factory=list)

    def __len__(self) -> int:
        return int(self.observations.shape[0])

    @property
    def num_episodes(self) -> int:
        return len(self.episode_seeds)

    def extend(self, other: Demonstrations) -> None:
        """Appends ``other``'s rows and episodes (their episode indices shifted after ours)."""
        offset = self.num_episodes
        self.observations = np.concatenate([self.observations, other.observations])
        self.actions = np.concatenate([self.actions, other.actions])
        self.episode_index = np.concatenate([self.episode_index, other.episode_index + offset])
        self.episode_seeds += other.episode_seeds
        self.episode_success += other.episode_success
        self.episode_placed += other.episode_placed

    def rows(self, mask: np.ndarray) -> Demonstrations:
        """The rows where ``mask`` (one boolean per row) is true, as a dataset of their own (the
        episode lists, which rows refer to by index, whole)."""
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != (len(self),):
            raise InvalidArgumentError(
                f"mask must be {len(self)} booleans, one per row; got shape {mask.shape}"
            )
        return Demonstrations(
            config=self.config,
            observations=self.observations[mask],
            actions=self.actions[mask],
            episode_index=self.episode_index[mask],
            episode_seeds=list(self.episode_seeds),
            episode_success=list(self.episode_success),
            episode_placed=list(self.episode_placed),
        )

    def save(self, path: str | Path) -> None:
        """Writes the dataset as a compressed ``.npz`` (the configuration as JSON inside)."""
        np.savez_compressed(
            path,
            observations=self.observations,
            actions=self.actions,
            episode_index=self.episode_index,
            episode_seeds=np.asarray(self.episode_seeds, dtype=np.int64),
            episode_success=np.asarray(self.episode_success, dtype=bool),
            episode_placed=np.asarray(self.episode_placed, dtype=bool),
            config=np.asarray(json.dumps(self.config)),
        )

    @classmethod
    def load(cls, path: str | Path) -> Demonstrations:
        """Reads a dataset written by :meth:`save`."""
        with np.load(path) as data:
            return cls(
                config=json.loads(str(data["config"])),
                observations=data["observations"],
                actions=data["actions"],
                episode_index=data["episode_index"],
                episode_seeds=data["episode_seeds"].tolist(),
                episode_success=data["episode_success"].tolist(),
                episode_placed=data["episode_placed"].tolist(),
            )


def collect(
    config: Mapping[str, Any],
    episodes: int,
    *,
    first_seed: int,
    actor: Any = None,
    num_envs: int = 32,
    num_threads: int | None = None,
    progress: Callable[[int], None] | None = None,
    expert_share: float = 0.0,
) -> tuple[Demonstrations, RolloutStats]:
    """Runs ``episodes`` seeded episodes (episode ``k`` reset with seed ``first_seed + k``) of
    the environment ``config``, driven by ``actor`` (an SB3 model, or a function from flat
    observation rows to action rows; ``None``: the scripted expert), and records every state
    visited with the expert's action in it. With ``expert_share`` > 0 the expert takes each of
    the actor's steps with that probability (DAgger's mixed policy; which steps,
    :func:`expert_steps`, salted with ``first_seed``). Returns the dataset and how the driving
    policy (the mix, where there is one) did."""
    share = float(expert_share)
    if not 0.0 <= share <= 1.0:
        raise InvalidArgumentError(f"expert_share must be in [0, 1], got {expert_share!r}")
    expert = ScriptedPolicy(config)._native
    driver: Any = expert.act if actor is None else actor
    if actor is not None and share > 0.0:
        # The learner acts as evaluate would call it (its own adapter, on state observations).
        config_json = _common.config_json(dict(config))
        spec = observation_spec(_common.Schema.of(config_json), config_json=config_json)
        learner, _, _ = _actor(actor, spec, lambda: [])

        def driver(flat: np.ndarray) -> np.ndarray:
            actions = np.array(learner(flat, None), dtype=np.float32)
            take = expert_steps(flat, share, first_seed)
            if take.any():
                actions[take] = expert.act(flat[take])
            return actions

    rows_obs: list[np.ndarray] = []
    rows_act: list[np.ndarray] = []
    rows_episode: list[np.ndarray] = []

    def record(observations: np.ndarray, actions: np.ndarray, running: list[int | None]) -> None:
        active = np.array([r is not None for r in running])
        labels = actions if actor is None else expert.act(observations)
        rows_obs.append(observations[active].copy())
        rows_act.append(labels[active].copy())
        rows_episode.append(np.array([r for r in running if r is not None], dtype=np.int64))

    report = evaluate(
        driver,
        config,
        episodes,
        num_envs=num_envs,
        first_seed=first_seed,
        num_threads=num_threads,
        progress=progress,
        on_step=record,
    )
    demos = Demonstrations(
        config=report.config,
        observations=np.concatenate(rows_obs),
        actions=np.concatenate(rows_act),
        episode_index=np.concatenate(rows_episode),
        episode_seeds=[e.seed for e in report.episodes],
        episode_success=[e.success for e in report.episodes],
        episode_placed=[e.placed for e in report.episodes],
    )
    return demos, RolloutStats.of(report, len(demos))
