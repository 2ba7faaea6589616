"""Learning from the scripted expert: demonstrations, behaviour cloning and DAgger.

The scripted policy (:class:`~panda_rapier.ScriptedPolicy`) places the cube in 99 % of seeded
episodes and reads nothing but the observation, so it can label any state. This module

- records its episodes as a dataset (:func:`collect`, :class:`Demonstrations`; flat
  observations in Gymnasium's ``spaces.flatten`` order and the expert's actions),
- clones it into a stable-baselines3 policy by regression of the policy's mean action onto the
  expert's (:func:`behaviour_cloning`), and
- runs DAgger (Ross et al., 2011): the cloned policy drives, the expert labels every state it
  visits, the labels join the dataset and the policy is refitted (:func:`dagger`). Plain
  cloning only ever sees the expert's states; the learner's own small errors take it to states
  the expert never visited, and DAgger teaches it what to do there.

The learner is an SB3 PPO ``MultiInputPolicy`` (with :class:`NormalizedFlatten` as its
features extractor), so the result is an ordinary PPO zip: ``panda-rapier eval`` evaluates
it, and PPO can fine-tune it.

Needs the ``train`` extra (stable-baselines3 and torch).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import _common
from .errors import InvalidArgumentError
from .policy import ScriptedPolicy

__all__ = ["Demonstrations", "RolloutStats", "behaviour_cloning", "collect", "dagger"]


@dataclass
class RolloutStats:
    """How the episodes of one :func:`collect` call went (for the policy that drove)."""

    episodes: int
    env_steps: int
    success_rate: float
    placed_rate: float
    wall_time_s: float


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
) -> tuple[Demonstrations, RolloutStats]:
    """Runs ``episodes`` seeded episodes (episode ``k`` reset with seed ``first_seed + k``) of
    the environment ``config``, driven by ``actor`` (anything :func:`~.evaluation.evaluate`
    takes: an SB3 model, or a function from flat observation rows to action rows; ``None``: the
    scripted expert), and records every state visited with the expert's action in it. Returns
    the dataset and how the driving policy did."""
    from .evaluation import evaluate

    expert = ScriptedPolicy(config)._native
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
        expert.act if actor is None else actor,
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
    stats = RolloutStats(
        episodes=episodes,
        env_steps=len(demos),
        success_rate=report.success_rate,
        placed_rate=report.placed_rate,
        wall_time_s=report.wall_time_s,
    )
    return demos, stats


def behaviour_cloning(
    model: Any,
    demos: Demonstrations,
    *,
    epochs: int,
    batch_size: int = 256,
    learning_rate: float = 1e-3,
    final_lr_fraction: float = 0.05,
    seed: int = 0,
    progress: Callable[[int, float], None] | None = None,
) -> list[float]:
    """Fits the mean action of ``model``'s policy (an SB3 actor-critic, e.g. PPO's
    ``MultiInputPolicy``) to the expert's actions in ``demos`` by mean squared error, with Adam,
    for ``epochs`` passes over the data in shuffled mini-batches, the learning rate falling
    linearly to ``final_lr_fraction`` of ``learning_rate``. The observation normaliser
    (:class:`NormalizedFlatten`) must already be fitted. Returns the mean loss of each epoch;
    ``progress(epoch, loss)`` is called after each."""
    import torch as th

    if len(demos) == 0:
        raise InvalidArgumentError("behaviour cloning needs at least one demonstration row")
    policy = model.policy
    policy.set_training_mode(True)
    generator = np.random.default_rng(seed)
    # Split by the layout of the task the rows came from (Stack's goals are 6-D).
    schema = _common.Schema.of(_common.config_json(demos.config))
    rows = _common.split_observation(demos.observations, schema)
    obs = {k: th.as_tensor(v) for k, v in rows.items()}
    target = th.as_tensor(demos.actions)
    parameters = [p for name, p in policy.named_parameters() if not name.startswith("value_net")]
    optimizer = th.optim.Adam(parameters, lr=learning_rate)
    losses = []
    n = len(demos)
    batches = epochs * ((n + batch_size - 1) // batch_size)
    schedule = th.optim.lr_scheduler.LinearLR(
        optimizer, 1.0, final_lr_fraction, total_iters=max(1, batches - 1)
    )
    for epoch in range(epochs):
        order = th.as_tensor(generator.permutation(n))
        total = 0.0
        for start in range(0, n, batch_size):
            index = order[start : start + batch_size]
            batch = {k: v[index] for k, v in obs.items()}
            mean = policy.get_distribution(batch).distribution.mean
            loss = th.nn.functional.mse_loss(mean, target[index])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            schedule.step()
            total += float(loss.detach()) * len(index)
        losses.append(total / n)
        if progress is not None:
            progress(epoch + 1, losses[-1])
    policy.set_training_mode(False)
    return losses


def dagger(
    model: Any,
    config: Mapping[str, Any],
    *,
    demo_episodes: int,
    rounds: int,
    episodes_per_round: int,
    epochs: int,
    epochs_per_round: int,
    first_seed: int,
    final_epochs: int = 0,
    batch_size: int = 256,
    learning_rate: float = 1e-3,
    num_envs: int = 32,
    num_threads: int | None = None,
    on_round: Callable[[int, Demonstrations, RolloutStats | None, list[float]], None] | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> Demonstrations:
    """Behaviour cloning from ``demo_episodes`` expert episodes, then ``rounds`` of DAgger, each
    driving ``episodes_per_round`` episodes with the learner, labelling them with the expert and
    refitting on everything gathered, and finally ``final_epochs`` more passes over all of it
    (a last fit whose learning rate decays over more steps). Episode seeds count up from
    ``first_seed`` without repeats. The normaliser is fitted to the expert's states.
    ``on_round(r, data, stats, losses)`` is called after each fit (``stats``: how the learner
    drove in round ``r``; ``None`` for round 0, the expert's demonstrations, and for the final
    fit). Returns all the data gathered."""
    from .normalization import fit_normalizers

    seed = first_seed

    def tick(what: str, total: int) -> Callable[[int], None] | None:
        if progress is None:
            return None
        return lambda done: progress(what, done, total)

    data, _ = collect(
        config,
        demo_episodes,
        first_seed=seed,
        num_envs=num_envs,
        num_threads=num_threads,
        progress=tick("demonstrations", demo_episodes),
    )
    seed += demo_episodes
    fit_normalizers(model.policy, data.observations)
    losses = behaviour_cloning(
        model, data, epochs=epochs, batch_size=batch_size, learning_rate=learning_rate, seed=0
    )
    if on_round is not None:
        on_round(0, data, None, losses)
    for r in range(1, rounds + 1):
        new, stats = collect(
            config,
            episodes_per_round,
            first_seed=seed,
            actor=model,
            num_envs=num_envs,
            num_threads=num_threads,
            progress=tick(f"dagger round {r}", episodes_per_round),
        )
        seed += episodes_per_round
        data.extend(new)
        losses = behaviour_cloning(
            model,
            data,
            epochs=epochs_per_round,
            batch_size=batch_size,
            learning_rate=learning_rate,
            seed=r,
        )
        if on_round is not None:
            on_round(r, data, stats, losses)
    if final_epochs > 0:
        losses = behaviour_cloning(
            model,
            data,
            epochs=final_epochs,
            batch_size=batch_size,
            learning_rate=learning_rate,
            seed=rounds + 1,
        )
        if on_round is not None:
            on_round(rounds + 1, data, None, losses)
    return data
