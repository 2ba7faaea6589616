"""Policies that see: a student acting on camera images, distilled from the scripted expert.

The student observes what ``obs_mode="proprio+rgb"`` gives: camera images, the robot's own
state (``proprioception``) and the commanded goal (``desired_goal``), nothing of the
simulator's object state. The scripted expert reads that state, so it can label any state the
student reaches: DAgger (Ross et al., 2011) with a privileged teacher. The expert first drives
``demo_episodes`` episodes; then, each round, the student drives, every state it visits is
stored as the student's observation (images as uint8, channels first) with the expert's action
in it, and the student is refitted on everything gathered (:func:`distil`).

The student is a stable-baselines3 PPO ``MultiInputPolicy`` whose features extractor is
:class:`PixelEncoder`: per camera a small CNN ending in a spatial soft-argmax (one image
keypoint per channel, Levine et al., 2016: where things are, which is what the expert's labels
depend on), next to the standardised vector entries. Its zip carries the architecture as data in
the run record (``student``), and :func:`load_student` rebuilds the network from that and reads
the weights by data (:func:`~panda_rapier.model_file.read_model_file`: nothing in the file is
unpickled), so ``panda-rapier eval --policy`` evaluates it without ``--trust-model-file``.

Needs the ``train`` extra (stable-baselines3 and torch).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

from . import _common
from .errors import ConfigError, InvalidArgumentError
from .inference import CLIP
from .normalization import MIN_SCALE
from .pixels import observation_spec, split_options
from .policy import ScriptedPolicy
from .rollouts import RolloutStats
from .threads import torch_threads

__all__ = [
    "PixelEncoder",
    "SpatialSoftArgmax",
    "StudentData",
    "StudentModel",
    "collect_student",
    "distil",
    "fit_student",
    "load_student",
    "student_architecture",
]

#: The student's network when a recipe does not say: CNN channels and strides (the first
#: convolution 5x5, the others 3x3) and the actor's and value function's hidden layers.
DEFAULT_ARCHITECTURE: dict[str, Any] = {
    "channels": [16, 32, 32, 16],
    "strides": [2, 2, 1, 1],
    "net_arch": {"pi": [256, 256], "vf": [256, 256]},
}


def _is_image(space: gym.Space[Any]) -> bool:
    return isinstance(space, gym.spaces.Box) and space.dtype == np.uint8 and len(space.shape) == 3


class SpatialSoftArgmax(nn.Module):
    """Per channel of a ``(batch, channels, height, width)`` map, the expected image
    coordinates (x then y, each in [-1, 1]) under a softmax over the channel's activations
    divided by a learned temperature: ``(batch, 2 * channels)`` keypoints."""

    def __init__(self, height: int, width: int) -> None:
        super().__init__()
        self.register_buffer("xs", th.linspace(-1.0, 1.0, width), persistent=False)
        self.register_buffer("ys", th.linspace(-1.0, 1.0, height), persistent=False)
        self.log_temperature = nn.Parameter(th.zeros(1))

    xs: th.Tensor
    ys: th.Tensor

    def forward(self, x: th.Tensor) -> th.Tensor:
        b, c, h, w = x.shape
        p = th.softmax(x.flatten(2) / self.log_temperature.exp(), dim=-1).view(b, c, h, w)
        return th.cat([(p.sum(2) * self.xs).sum(-1), (p.sum(3) * self.ys).sum(-1)], dim=1)


class PixelEncoder(BaseFeaturesExtractor):
    """The features of a ``Dict`` observation with images (uint8 ``(3, height, width)``, as
    stable-baselines3 passes them on, scaled to [0, 1] by it): per image, in key order, a CNN
    (``channels`` and ``strides``; a 5x5 first convolution, 3x3 after it, ReLU between) whose
    last layer's channels become keypoints (:class:`SpatialSoftArgmax`); then the other entries
    flattened in key order and mapped to ``clip((x - mean) / scale, -10, 10)`` (identity until
    :meth:`fit`)."""

    mean: th.Tensor
    scale: th.Tensor

    def __init__(
        self,
        observation_space: gym.spaces.Dict,
        channels: Sequence[int] = (16, 32, 32, 16),
        strides: Sequence[int] = (2, 2, 1, 1),
        clip: float = CLIP,
    ) -> None:
        if not isinstance(observation_space, gym.spaces.Dict):
            raise TypeError(f"PixelEncoder needs a Dict space, got {observation_space}")
        channels, strides = [int(c) for c in channels], [int(s) for s in strides]
        if not channels or len(channels) != len(strides):
            raise ConfigError("PixelEncoder needs as many strides as channels, at least one")
        if any(not 1 <= c <= 512 for c in channels) or any(not 1 <= s <= 4 for s in strides):
            raise ConfigError("PixelEncoder channels must be in [1, 512] and strides in [1, 4]")
        keys = sorted(observation_space.spaces)
        image_keys = [k for k in keys if _is_image(observation_space.spaces[k])]
        vector_keys = [k for k in keys if k not in image_keys]
        if not image_keys:
            raise TypeError("PixelEncoder needs at least one uint8 image in the observation")
        vector_dim = sum(gym.spaces.flatdim(observation_space.spaces[k]) for k in vector_keys)
        cnns = []
        for key in image_keys:
            shape = observation_space.spaces[key].shape
            assert shape is not None
            if shape[0] != 3:
                raise TypeError(f"PixelEncoder needs channels-first images, got {key}: {shape}")
            layers: list[nn.Module] = []
            previous = 3
            for i, (c, s) in enumerate(zip(channels, strides, strict=True)):
                kernel = 5 if i == 0 else 3
                layers += [nn.Conv2d(previous, c, kernel, s, kernel // 2), nn.ReLU()]
                previous = c
            layers.pop()  # the keypoints take the last convolution's raw activations
            with th.no_grad():
                height, width = nn.Sequential(*layers)(th.zeros(1, *shape)).shape[2:]
            cnns.append(nn.Sequential(*layers, SpatialSoftArgmax(int(height), int(width))))
        super().__init__(observation_space, features_dim=2 * channels[-1] * len(cnns) + vector_dim)
        self.image_keys, self.vector_keys = image_keys, vector_keys
        self.cnns = nn.ModuleList(cnns)
        self.clip = float(clip)
        self.register_buffer("mean", th.zeros(vector_dim))
        self.register_buffer("scale", th.ones(vector_dim))

    def fit(self, vectors: np.ndarray, min_scale: float = MIN_SCALE) -> None:
        """Sets the vector entries' mean and scale (standard deviation, at least
        ``min_scale``) from rows of them (the vector keys' values side by side, in key
        order)."""
        vectors = np.asarray(vectors, dtype=np.float64)
        if vectors.ndim != 2 or vectors.shape[1] != self.mean.shape[0] or len(vectors) < 2:
            raise ValueError(
                f"fit needs at least 2 rows of {self.mean.shape[0]} values, got {vectors.shape}"
            )
        self.mean.copy_(th.as_tensor(vectors.mean(axis=0), dtype=th.float32))
        scale = np.maximum(vectors.std(axis=0), min_scale)
        self.scale.copy_(th.as_tensor(scale, dtype=th.float32))

    def forward(self, observations: Mapping[str, th.Tensor]) -> th.Tensor:
        parts = [cnn(observations[k]) for k, cnn in zip(self.image_keys, self.cnns, strict=True)]
        if self.vector_keys:
            flat = th.cat([observations[k].flatten(start_dim=1) for k in self.vector_keys], dim=1)
            parts.append(((flat - self.mean) / self.scale).clamp(-self.clip, self.clip))
        return th.cat(parts, dim=1)


def student_architecture(spec: Any) -> dict[str, Any]:
    """A student's architecture (``channels``, ``strides``, ``net_arch`` with ``pi`` and
    ``vf``) from a recipe's or a run record's ``student`` entry, checked: plain data only, so
    a model file's record can be read without running anything. Missing entries take
    :data:`DEFAULT_ARCHITECTURE`'s."""
    if spec is None:
        spec = {}
    if not isinstance(spec, Mapping):
        raise ConfigError(f"student must be a mapping of channels, strides, net_arch: {spec!r}")
    unknown = set(spec) - set(DEFAULT_ARCHITECTURE)
    if unknown:
        raise ConfigError(f"student: unknown entries {sorted(unknown)}")
    arch = {**DEFAULT_ARCHITECTURE, **dict(spec)}

    def ints(value: Any, what: str, low: int, high: int) -> list[int]:
        if (
            not isinstance(value, list | tuple)
            or not value
            or any(
                isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high for v in value
            )
        ):
            raise ConfigError(f"student {what} must be a non-empty list of ints in [{low}, {high}]")
        return [int(v) for v in value]

    net = arch["net_arch"]
    if not isinstance(net, Mapping) or set(net) != {"pi", "vf"}:
        raise ConfigError("student net_arch must be a mapping with pi and vf")
    channels = ints(arch["channels"], "channels", 1, 512)
    strides = ints(arch["strides"], "strides", 1, 4)
    if len(channels) != len(strides):
        raise ConfigError("student channels and strides must have the same length")
    return {
        "channels": channels,
        "strides": strides,
        "net_arch": {k: ints(net[k], f"net_arch {k}", 1, 4096) for k in ("pi", "vf")},
    }


def policy_kwargs(arch: Mapping[str, Any]) -> dict[str, Any]:
    """stable-baselines3 ``policy_kwargs`` of a student of architecture ``arch``."""
    return {
        "features_extractor_class": PixelEncoder,
        "features_extractor_kwargs": {"channels": arch["channels"], "strides": arch["strides"]},
        "net_arch": {"pi": arch["net_arch"]["pi"], "vf": arch["net_arch"]["vf"]},
        "activation_fn": nn.ReLU,
    }


@dataclass
class StudentData:
    """The student's observations (image keys: uint8 ``(n, 3, height, width)``; the others
    float32 rows) with the expert's actions in those states."""

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
    from .evaluation import evaluate

    spec = observation_spec(_common.Schema.of(_common.config_json(config)), **observation)
    if not spec.has_images:
        raise InvalidArgumentError("a student observes images: obs_mode must have rgb")
    expert = ScriptedPolicy(config)
    chunks: dict[str, list[np.ndarray]] = {key: [] for key in spec.space().spaces}
    labels: list[np.ndarray] = []
    episode_rows: list[np.ndarray] = []

    def record(
        flat: np.ndarray, actions: np.ndarray, running: list[int | None], images: np.ndarray
    ) -> None:
        active = np.array([r is not None for r in running])
        obs = spec.assemble(flat[active], images[active])
        for key, value in obs.items():
            chunks[key].append(value.transpose(0, 3, 1, 2).copy() if value.ndim == 4 else value)
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
    stats = RolloutStats(
        episodes=episodes,
        env_steps=len(data),
        success_rate=report.success_rate,
        placed_rate=report.placed_rate,
        wall_time_s=report.wall_time_s,
    )
    return data, stats


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
    entries' scaler is fitted to the expert's states. torch fits on ``fit_threads`` threads
    (no environment steps during a fit). ``on_round(r, data, stats, loss)`` is called after
    each fit (``stats``: how the student drove in round ``r``; ``None`` for round 0 and the
    final fit)."""
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


@dataclass
class StudentModel:
    """A student read from its model file: the stable-baselines3 policy (``policy``), with
    ``predict`` as stable-baselines3 models have it and the observation options the
    environment must be made with (``observation``: ``obs_mode``, ``image_size``,
    ``cameras``)."""

    policy: Any
    observation: dict[str, Any]
    run: dict[str, Any]
    device: th.device = field(default_factory=lambda: th.device("cpu"))

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """As stable-baselines3's ``predict``: actions for a (batched) observation dict."""
        return self.policy.predict(observation, state, episode_start, deterministic)


def is_student(run: Mapping[str, Any] | None) -> bool:
    """Whether a run record is a student's (it carries the ``student`` architecture)."""
    return isinstance(run, Mapping) and isinstance(run.get("student"), Mapping)


def load_student(path: str | Path) -> StudentModel:
    """A student saved by ``panda-rapier train --algo bc`` with image observations, rebuilt
    from its run record's architecture and environment options and filled with its weights,
    all read by data: nothing in the file is unpickled or run."""
    from stable_baselines3.common.policies import MultiInputActorCriticPolicy
    from stable_baselines3.common.vec_env import VecTransposeImage

    from .model_file import read_model_file, read_run_info
    from .registration import ENV_IDS
    from .sb3 import make_vec_env

    path = Path(path)
    run = read_run_info(path)
    if run is None or not is_student(run):
        raise InvalidArgumentError(f"{path} is not a student's model file (no student record)")
    arch = student_architecture(run["student"])
    env_id, options = run.get("env_id"), run.get("env_kwargs")
    if env_id not in ENV_IDS or not isinstance(options, Mapping):
        raise InvalidArgumentError(f"{path}: its run record names no panda_rapier environment")
    _, state = read_model_file(path)
    env = make_vec_env(str(env_id), n_envs=1, **options)
    try:
        assert isinstance(env.observation_space, gym.spaces.Dict)
        spaces = {
            k: VecTransposeImage.transpose_space(v)
            if isinstance(v, gym.spaces.Box) and _is_image(v)
            else v
            for k, v in env.observation_space.spaces.items()
        }
        policy = MultiInputActorCriticPolicy(
            gym.spaces.Dict(spaces), env.action_space, lambda _: 0.0, **policy_kwargs(arch)
        )
    finally:
        env.close()
    try:
        policy.load_state_dict({k: th.as_tensor(np.array(v)) for k, v in state.items()})
    except (RuntimeError, TypeError) as error:
        raise InvalidArgumentError(f"{path}: weights unfit for the student: {error}") from None
    policy.set_training_mode(False)
    return StudentModel(policy, split_options(options)[1], dict(run))


def train_student(
    run: dict[str, Any],
    recipe: Mapping[str, Any],
    config: Mapping[str, Any],
    observation: Mapping[str, Any],
    out: Path,
    n_envs: int | None,
    num_threads: int | None,
    eval_episodes: int,
    say: Callable[[str], None],
    on_evaluation: Callable[[dict[str, Any]], None] | None = None,
    show_progress: bool = True,
    fit_threads: int | None = None,
) -> dict[str, Any]:
    """``panda-rapier train --algo bc`` with image observations: :func:`distil` with the
    recipe's counts, a validation after every fit (``evaluations.jsonl``, ``best.zip``), the
    run record and ``model.zip`` (the final fit's weights)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.logger import configure
    from tqdm import tqdm

    from .model_file import save_model
    from .sb3 import make_vec_env
    from .training import _Recorder

    arch = student_architecture(recipe.get("student"))
    n = int(n_envs if n_envs is not None else recipe.get("n_envs", 32))
    run.update(n_envs=n, student=arch)
    env = make_vec_env(run["env_id"], n_envs=1, **run["env_kwargs"])
    model = PPO("MultiInputPolicy", env, policy_kwargs=policy_kwargs(arch), seed=run["seed"],
                device="cpu")  # fmt: skip
    logger = configure(str(out / "tensorboard" / "bc_1"), ["tensorboard"])
    recorder = _Recorder(
        out, config, run, eval_episodes, num_threads, 0.0, say, on_evaluation, observation
    )
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
