"""Expert demonstrations as Minari datasets: the scripted policy's seeded episodes.

:func:`record` runs :class:`~panda_rapier.ScriptedPolicy` on ``gym.make(env_id)`` for
``episodes`` episodes, episode ``k`` reset with seed ``first_seed + k``, and writes them with
Minari (``minari.create_dataset_from_buffers``) under Minari's data path
(``MINARI_DATASETS_PATH``, else ``~/.minari/datasets``). Each episode holds the goal-dict
observations (71 per 70-step episode), the actions taken, rewards, terminations,
truncations and every step info (``is_success``, ``is_placed``, the dense reward terms ...);
its ``seed`` is stored with it. The dataset's metadata carries the environment's spec with
every option (so ``dataset.recover_environment()`` rebuilds it), reference scores (the
expert's and a uniformly random policy's mean return on 100 other seeded episodes, for
``minari.get_normalized_score``) and the package version.

The environment is bit-for-bit reproducible, so an episode is fully determined by its seed and
actions: ``env.reset(seed=episode.id's seed)`` followed by the recorded actions regenerates
every state exactly (the way ManiSkill stores trajectories), which makes per-step state
snapshots unnecessary.

With ``noise > 0`` Gaussian noise of that standard deviation is added to every expert action
(clipped to [-1, 1]; drawn from a generator seeded by ``first_seed``) and the noisy action is
what is executed and recorded: Minari's "medium" quality. Dataset ids default to
``panda_rapier/<variant>/expert-v0`` (``medium-v0`` with noise), ``<variant>`` the id's name,
e.g. ``panda_rapier/PickAndPlaceJoints/expert-v0``.

Needs the ``demos`` extra (``pip install "panda-rapier[demos]"``: minari with HDF5 storage).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from ..errors import ConfigError, InvalidArgumentError
from ..policy import ScriptedPolicy
from ..registration import ENV_IDS, env_config
from ..seeds import DEMOS_FIRST_SEED

__all__ = [
    "DEFAULT_FIRST_SEED",
    "RecordingSummary",
    "default_dataset_id",
    "record",
    "to_demonstrations",
]

#: First seed of recorded episodes (:data:`panda_rapier.seeds.DEMOS_FIRST_SEED`): apart from
#: evaluation, validation, training and the normaliser's expert episodes.
DEFAULT_FIRST_SEED = DEMOS_FIRST_SEED
#: Episodes the reference scores are averaged over (Minari's default), on the seeds after the
#: recorded ones.
REFERENCE_EPISODES = 100


@dataclass
class RecordingSummary:
    """What :func:`record` wrote."""

    dataset_id: str
    path: str
    episodes: int
    steps: int
    success_rate: float
    placed_rate: float
    mean_return: float
    ref_min_score: float
    ref_max_score: float
    wall_time_s: float


def default_dataset_id(env_id: str, noise: float = 0.0) -> str:
    """``panda_rapier/<variant>/expert-v0``, or ``medium-v0`` with action noise."""
    if env_id not in ENV_IDS:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS")
    variant = env_id.split("/", 1)[1].rsplit("-v", 1)[0]
    return f"panda_rapier/{variant}/{'medium' if noise > 0 else 'expert'}-v0"


def _minari() -> Any:
    try:
        import minari
        from minari.data_collector import EpisodeBuffer  # noqa: F401
    except ImportError as error:
        raise ImportError(
            "recording demonstrations needs Minari: pip install 'panda-rapier[demos]'"
        ) from error
    return minari


def _run_episode(
    env: gym.Env,
    policy: Callable[[Mapping[str, np.ndarray]], np.ndarray],
    seed: int,
) -> tuple[dict[str, list[Any]], list[np.ndarray], list[float], list[bool], list[bool], list]:
    obs, info = env.reset(seed=seed)
    observations: dict[str, list[Any]] = {key: [value] for key, value in obs.items()}
    infos = [info]
    actions, rewards, terminations, truncations = [], [], [], []
    while True:
        action = policy(obs)
        obs, reward, terminated, truncated, info = env.step(action)
        for key, value in obs.items():
            observations[key].append(value)
        actions.append(action)
        rewards.append(float(reward))
        terminations.append(bool(terminated))
        truncations.append(bool(truncated))
        infos.append(info)
        if terminated or truncated:
            return observations, actions, rewards, terminations, truncations, infos


def _mean_return(
    env: gym.Env,
    policy: Callable[[Mapping[str, np.ndarray]], np.ndarray],
    first_seed: int,
    episodes: int,
) -> float:
    returns = [sum(_run_episode(env, policy, first_seed + k)[2]) for k in range(episodes)]
    return float(np.mean(returns))


def record(
    env_id: str,
    episodes: int,
    *,
    dataset_id: str | None = None,
    noise: float = 0.0,
    first_seed: int = DEFAULT_FIRST_SEED,
    env_kwargs: Mapping[str, Any] | None = None,
    reference_episodes: int = REFERENCE_EPISODES,
    progress: Callable[[int, int], None] | None = None,
) -> RecordingSummary:
    """Records ``episodes`` episodes of the scripted expert on ``env_id`` (with ``env_kwargs``)
    into the Minari dataset ``dataset_id`` (see the module's documentation) and returns a
    summary. The reference scores average ``reference_episodes`` episodes each.
    ``progress(done, total)`` is called after each episode, the reference ones included."""
    minari = _minari()
    from minari.data_collector import EpisodeBuffer

    from .. import __version__

    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise InvalidArgumentError(f"episodes must be an int >= 1, got {episodes!r}")
    if not (isinstance(noise, int | float) and np.isfinite(noise) and noise >= 0):
        raise InvalidArgumentError(f"noise must be a finite number >= 0, got {noise!r}")
    if (
        isinstance(reference_episodes, bool)
        or not isinstance(reference_episodes, int)
        or reference_episodes < 1
    ):
        raise InvalidArgumentError(
            f"reference_episodes must be an int >= 1, got {reference_episodes!r}"
        )
    if isinstance(first_seed, bool) or not isinstance(first_seed, int) or first_seed < 0:
        raise InvalidArgumentError(f"first_seed must be an int >= 0, got {first_seed!r}")
    env_config(env_id)  # a clear error for ids that are not ours
    dataset_id = dataset_id or default_dataset_id(env_id, noise)
    try:
        minari.dataset.minari_dataset.parse_dataset_id(dataset_id)
    except ValueError as error:
        raise InvalidArgumentError(str(error)) from error
    if dataset_id in minari.list_local_datasets():
        raise InvalidArgumentError(
            f"the Minari dataset {dataset_id} already exists: delete it "
            f"(minari delete {dataset_id}) or pass another dataset id"
        )
    started = time.perf_counter()
    env = gym.make(env_id, **dict(env_kwargs or {}))
    expert = ScriptedPolicy(env)
    generator = np.random.default_rng(first_seed)
    space = env.action_space
    assert isinstance(space, gym.spaces.Box), space  # ScriptedPolicy(env) accepted it
    low, high = space.low, space.high

    def act(obs: Mapping[str, np.ndarray]) -> np.ndarray:
        action = expert.predict(obs)[0]
        if noise > 0:
            action = action + generator.normal(0.0, noise, size=action.shape)
        return np.clip(action, low, high).astype(np.float32)

    total = episodes + 2 * reference_episodes
    buffers, successes, placements, returns, steps = [], [], [], [], 0
    for k in range(episodes):
        observations, actions, rewards, terminations, truncations, infos = _run_episode(
            env, act, first_seed + k
        )
        buffers.append(
            EpisodeBuffer(
                id=k,
                seed=first_seed + k,
                observations={key: np.stack(v) for key, v in observations.items()},
                actions=np.stack(actions),
                rewards=rewards,
                terminations=terminations,
                truncations=truncations,
                infos={key: np.array([i[key] for i in infos]) for key in infos[0]},
            )
        )
        successes.append(bool(infos[-1]["is_success"]))
        # Tasks without a "placed" predicate (no ``is_placed``) place nothing.
        placements.append(bool(infos[-1].get("is_placed", False)))
        returns.append(sum(rewards))
        steps += len(actions)
        if progress is not None:
            progress(k + 1, total)
    # Reference scores on the seeds after the recorded ones: the noiseless expert's and a
    # uniformly random policy's (seeded) mean return.
    reference_seed = first_seed + episodes
    ref_max = _mean_return(
        env, lambda obs: expert.predict(obs)[0], reference_seed, reference_episodes
    )
    if progress is not None:
        progress(episodes + reference_episodes, total)
    random_actions = np.random.default_rng(reference_seed)
    ref_min = _mean_return(
        env,
        lambda obs: random_actions.uniform(low, high).astype(np.float32),
        reference_seed,
        reference_episodes,
    )
    if progress is not None:
        progress(total, total)
    what = "the scripted expert" + (f" with Gaussian action noise (std {noise})" if noise else "")
    dataset = minari.create_dataset_from_buffers(
        dataset_id=dataset_id,
        buffer=buffers,
        env=env.spec,
        eval_env=env.spec,
        algorithm_name=f"panda_rapier.ScriptedPolicy{f' + N(0, {noise}^2) noise' if noise else ''}",
        author="panda_rapier",
        author_email="n/a (generated locally by panda-rapier demos)",
        code_permalink=f"panda_rapier {__version__} (panda-rapier demos)",
        ref_min_score=ref_min,
        ref_max_score=ref_max,
        num_episodes_average_score=reference_episodes,
        description=(
            f"{episodes} episodes of {what} on {env_id} "
            f"(options {dict(env_kwargs or {})}), episode k reset with seed "
            f"{first_seed} + k; success {np.mean(successes):.3f}, placed "
            f"{np.mean(placements):.3f}. Replaying an episode's actions after "
            "env.reset(seed=its seed) reproduces it bit for bit."
        ),
        requirements=[f"panda-rapier=={__version__}"],
    )
    env.close()
    return RecordingSummary(
        dataset_id=dataset_id,
        path=str(dataset.storage.data_path),
        episodes=episodes,
        steps=steps,
        success_rate=float(np.mean(successes)),
        placed_rate=float(np.mean(placements)),
        mean_return=float(np.mean(returns)),
        ref_min_score=ref_min,
        ref_max_score=ref_max,
        wall_time_s=round(time.perf_counter() - started, 3),
    )


def to_demonstrations(dataset: Any) -> Any:
    """A Minari dataset of goal-dict episodes (one :func:`record` wrote, or any with the same
    spaces) as :class:`panda_rapier.learning.imitation.Demonstrations`: every state an action was
    taken in, as a flat row, with that action, for
    :func:`~panda_rapier.learning.imitation.behaviour_cloning`.
    """
    from .rollouts import Demonstrations

    spec = dataset.spec.env_spec
    if spec is None or spec.id not in ENV_IDS:
        raise InvalidArgumentError(
            f"dataset {dataset.spec.dataset_id} was not recorded on a panda_rapier environment"
        )
    config = env_config(spec.id, **dict(spec.kwargs))
    rows, actions, index, seeds, success, placed = [], [], [], [], [], []
    metadata = dataset.storage.get_episode_metadata(dataset.episode_indices)
    for k, (episode, meta) in enumerate(zip(dataset.iterate_episodes(), metadata, strict=True)):
        obs = episode.observations
        steps = len(episode.actions)
        rows.append(
            np.concatenate(
                [
                    obs["achieved_goal"][:steps],
                    obs["desired_goal"][:steps],
                    obs["observation"][:steps],
                ],
                axis=1,
            )
        )
        actions.append(np.asarray(episode.actions, dtype=np.float32))
        index.append(np.full(steps, k, dtype=np.int64))
        seeds.append(int(meta.get("seed", -1)))
        success.append(bool(episode.infos["is_success"][-1]))
        placed.append(
            bool(episode.infos["is_placed"][-1]) if "is_placed" in episode.infos else False
        )
    return Demonstrations(
        config=config,
        observations=np.concatenate(rows).astype(np.float32),
        actions=np.concatenate(actions),
        episode_index=np.concatenate(index),
        episode_seeds=seeds,
        episode_success=success,
        episode_placed=placed,
    )
