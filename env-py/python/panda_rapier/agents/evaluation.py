"""Seeded evaluation of a policy (the scripted baseline or a stable-baselines3 model) on the
native vector environment: what ``panda-rapier eval`` runs.

The schedule and the bookkeeping are native (``panda_rapier_policies::Evaluation``, shared with
the Rust ``evaluate``); this module supplies the policy's actions and builds the report.
Episode ``k`` (``k = 0, 1, ...``) is reset with seed ``first_seed + k`` and episodes are
handed out in order by refill: the first ``num_envs`` start together on environments
``0 .. num_envs - 1``, and whenever episodes end, their environments start the next ones, in
environment order. Environment ``i`` draws from random stream ``(seed, i)``, so an episode
depends on its seed and on ``env_index``; since the environments and policies are
deterministic, the same ``(config, first_seed, num_envs)`` gives the same records, bit for bit,
for any number of threads, and the first ``m`` records of a longer evaluation are those of an
evaluation of ``m`` episodes. Once every episode has been handed out, environments whose
episode ends are idle: the vector env still steps them, unrecorded, until the last episode
ends. ``env_steps`` counts every environment step simulated, idle ones included (what
``env_steps_per_s`` divides), ``idle_env_steps`` the idle ones among them.

What an evaluation reproduces, where: every report records its ``inference`` (how actions were
computed) and its ``environment`` (:func:`evaluation_environment`: package version, CPU
architecture, C library, and for torch inference torch's version and the CPU capability it
uses, stable-baselines3's and numpy's versions). The physics, the scripted experts and
:class:`~panda_rapier.agents.inference.PolicyNetwork` (what ``panda-rapier eval`` acts out a saved
model with) do the same arithmetic on every CPU of an architecture, so their episodes repeat
bit for bit wherever the fields :data:`OUTCOME_FIELDS` names for that inference match. A torch
model's float32 actions depend on the kernels torch picks for the CPU: its episodes repeat only
on the same capability and versions. Elsewhere an evaluation promises the same success and
placed rates within their statistical interval; :func:`check_reproduction` tests a report
against a recorded one either way.
"""

from __future__ import annotations

import json
import math
import platform
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _common, _native
from ..errors import ConfigError, InvalidArgumentError
from ..pixels import DEFAULT_IMAGE_SIZE, ObservationSpec, observation_spec
from ..policy import RandomPolicy, ScriptedPolicy
from .inference import NATIVE, TORCH, PolicyNetwork
from .model_file import load_sb3_model, model_observation, saved_spaces

if TYPE_CHECKING:
    from ..video import VideoRecorder

__all__ = [
    "OUTCOME_FIELDS",
    "EpisodeRecord",
    "EvaluationReport",
    "ReproductionCheck",
    "check_reproduction",
    "evaluate",
    "evaluation_environment",
    "load_sb3_model",
    "model_observation",
    "saved_spaces",
    "wilson_interval",
]


@dataclass
class EpisodeRecord:
    """How one episode went."""

    seed: int
    #: The environment (random stream) it ran on.
    env_index: int
    episode_return: float
    length: int
    #: ``is_success`` at the last step (Gymnasium-Robotics' success criterion).
    success: bool
    #: Whether ``is_placed`` (cube released, at rest on the platform at the goal) ever held.
    placed: bool
    #: First step at which ``is_success`` held, if it did.
    steps_to_success: int | None
    #: First step at which ``is_placed`` held, if it did.
    steps_to_placed: int | None
    #: Whether the episode ended because the physics blew up.
    physics_unstable: bool


@dataclass
class EvaluationReport:
    """Summary and per-episode records of an evaluation."""

    policy: str
    config: dict[str, Any]
    first_seed: int
    num_envs: int
    num_threads: int
    env_steps: int
    wall_time_s: float
    episodes: list[EpisodeRecord] = field(default_factory=list)
    #: Steps of idle environments (no episode left to run) among ``env_steps``.
    idle_env_steps: int = 0
    #: How the actions were computed: ``scripted``, ``native-f64``
    #: (:class:`~panda_rapier.agents.inference.PolicyNetwork`), ``torch-f32`` (a stable-baselines3
    #: model's ``predict``), ``lerobot-torch-f32`` (a LeRobot policy,
    #: :class:`~panda_rapier.agents.lerobot_policy.LeRobotPolicy`) or ``python`` (any other
    #: function).
    inference: str = "python"
    #: What the episodes' outcomes depend on (:func:`evaluation_environment`).
    environment: dict[str, str] = field(default_factory=dict)

    @property
    def num_episodes(self) -> int:
        return len(self.episodes)

    def statistics(self) -> dict[str, Any]:
        """The episodes' statistics, computed where the Rust evaluator computes them
        (``panda_rapier_policies::evaluation::summarize``): ``success_rate``,
        ``success_ci95``, ``success_once_rate`` and ``success_once_ci95`` (``is_success`` at
        some step, not only the last: how ManiSkill's ``success_once`` and ``lerobot-eval``
        count), ``placed_rate``, ``mean_return``, ``std_return``, ``mean_length``,
        ``mean_steps_to_success``, ``median_steps_to_success``, ``mean_steps_to_placed`` and
        ``physics_unstable_episodes``."""
        return dict(_native.summarize([asdict(e) for e in self.episodes]))

    @property
    def success_rate(self) -> float:
        return float(self.statistics()["success_rate"])

    @property
    def success_ci95(self) -> tuple[float, float]:
        """95 % Wilson score interval of the success rate."""
        low, high = self.statistics()["success_ci95"]
        return (float(low), float(high))

    @property
    def success_once_rate(self) -> float:
        """Fraction of episodes in which ``is_success`` held at some step (``lerobot-eval``'s
        and ManiSkill's ``success_once`` count; :attr:`success_rate` is at the last step)."""
        return float(self.statistics()["success_once_rate"])

    @property
    def placed_rate(self) -> float:
        return float(self.statistics()["placed_rate"])

    @property
    def mean_return(self) -> float:
        return float(self.statistics()["mean_return"])

    @property
    def std_return(self) -> float:
        return float(self.statistics()["std_return"])

    @property
    def mean_length(self) -> float:
        return float(self.statistics()["mean_length"])

    @property
    def mean_steps_to_success(self) -> float | None:
        """Mean first step of success, over the episodes that succeeded at some step."""
        value = self.statistics()["mean_steps_to_success"]
        return None if value is None else float(value)

    @property
    def median_steps_to_success(self) -> float | None:
        value = self.statistics()["median_steps_to_success"]
        return None if value is None else float(value)

    @property
    def env_steps_per_s(self) -> float:
        return self.env_steps / self.wall_time_s if self.wall_time_s > 0 else math.inf

    def summary(self) -> dict[str, Any]:
        """The headline figures."""
        stats = self.statistics()
        return {
            "policy": self.policy,
            "episodes": self.num_episodes,
            "first_seed": self.first_seed,
            "num_envs": self.num_envs,
            "num_threads": self.num_threads,
            "arm": self.config.get("arm"),
            "control_mode": self.config.get("control_mode"),
            "reward_type": self.config.get("reward_type"),
            "max_episode_steps": self.config.get("max_episode_steps"),
            "success_rate": stats["success_rate"],
            "success_ci95": list(stats["success_ci95"]),
            "success_once_rate": stats["success_once_rate"],
            "success_once_ci95": list(stats["success_once_ci95"]),
            "placed_rate": stats["placed_rate"],
            "mean_return": stats["mean_return"],
            "std_return": stats["std_return"],
            "mean_length": stats["mean_length"],
            "mean_steps_to_success": stats["mean_steps_to_success"],
            "median_steps_to_success": stats["median_steps_to_success"],
            "physics_unstable_episodes": stats["physics_unstable_episodes"],
            "env_steps": self.env_steps,
            "idle_env_steps": self.idle_env_steps,
            "wall_time_s": self.wall_time_s,
            "env_steps_per_s": self.env_steps_per_s,
            "inference": self.inference,
            "environment": self.environment,
        }

    def to_json(self) -> str:
        """Summary, configuration and every episode, as JSON."""
        return json.dumps(
            {
                **self.summary(),
                "config": self.config,
                "failed_episodes": [
                    {"seed": e.seed, "env_index": e.env_index}
                    for e in self.episodes
                    if not e.success
                ],
                "episode_records": [asdict(e) for e in self.episodes],
            },
            indent=2,
        )


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval of a binomial rate (95 % for the default ``z``), as the Rust
    evaluator computes it."""
    if successes < 0 or n < 0 or successes > n:
        raise InvalidArgumentError(f"need 0 <= successes <= n, got {successes} of {n}")
    low, high = _native.wilson_interval(int(successes), int(n), float(z))
    return (float(low), float(high))


#: What :func:`evaluate` steps with: a function from flat observation rows (and, with image
#: observations, the image rows) to action rows.
Actor = Callable[[np.ndarray, np.ndarray | None], np.ndarray]
#: Called by :func:`evaluate` before every step with the flat observations, the actions about
#: to be taken and, per environment, the episode it runs (``None`` once it has no more); with
#: image observations, also with the image rows (the native bytes, ``(n, bytes)``) as a fourth
#: argument.
StepHook = Callable[..., None]


def _actor(
    policy: Any, spec: ObservationSpec, running_seeds: Callable[[], list[int | None]]
) -> tuple[Actor, str, str]:
    """The policy as an :data:`Actor`, a name for it and its inference. ``running_seeds``
    gives the seed of the episode each environment runs (``None``: idle), for a policy that
    acts by episode (:class:`RandomPolicy`, or anything with an ``act_by_episode(flat,
    observation, seeds)``: :class:`~panda_rapier.agents.lerobot_policy.LeRobotPolicy`)."""
    if isinstance(policy, ScriptedPolicy):
        native = policy._native
        return (lambda flat, _images: native.act(flat)), "scripted", "scripted"
    if isinstance(policy, RandomPolicy):
        return (lambda _flat, _images: policy.act_for_episodes(running_seeds())), "random", "random"
    if isinstance(policy, PolicyNetwork):
        if spec.has_sensors:
            raise InvalidArgumentError("a PolicyNetwork acts on state observations only")
        return (lambda flat, _images: policy.act(flat)), repr(policy), NATIVE
    act_by_episode = getattr(policy, "act_by_episode", None)
    if callable(act_by_episode):  # a policy with state across steps (a LeRobot policy)
        inference = str(getattr(policy, "inference", "python"))

        def by_episode(flat: np.ndarray, images: np.ndarray | None) -> np.ndarray:
            return act_by_episode(flat, spec.assemble(flat, images), running_seeds())

        return by_episode, repr(policy), inference
    predict = getattr(policy, "predict", None)
    if not callable(predict):
        if callable(policy):  # already a function of flat observation rows
            name = getattr(policy, "__name__", type(policy).__name__)
            return (lambda flat, _images: policy(flat)), name, "python"
        raise InvalidArgumentError(
            f"policy must have an SB3-style predict(obs, deterministic=True) or be a function "
            f"of flat observation rows, got {type(policy).__name__}"
        )

    def act(flat: np.ndarray, images: np.ndarray | None) -> np.ndarray:
        actions, _ = predict(spec.assemble(flat, images), deterministic=True)
        return np.asarray(actions, dtype=np.float32).reshape(flat.shape[0], -1)

    inference = TORCH if hasattr(policy, "policy") and hasattr(policy, "device") else "python"
    return act, type(policy).__name__, inference


def evaluate(
    policy: Any,
    config: Mapping[str, Any],
    episodes: int,
    *,
    num_envs: int = 32,
    first_seed: int = 0,
    num_threads: int | None = None,
    progress: Callable[[int], object] | None = None,
    recorder: VideoRecorder | None = None,
    on_step: StepHook | None = None,
    obs_mode: str = "state",
    image_size: int | tuple[int, int] = DEFAULT_IMAGE_SIZE,
    cameras: Mapping[str, Mapping[str, Any]] | None = None,
    visual_randomization: bool | Mapping[str, Any] | None = None,
) -> EvaluationReport:
    """Runs ``episodes`` seeded episodes of the environment ``config`` (its
    ``max_episode_steps`` must be set) with ``policy`` (a :class:`ScriptedPolicy`, anything
    with an SB3-style ``predict`` taking dict observations, or a function from flat observation
    rows to action rows) on ``num_envs`` environments, scheduled by the native evaluation (see
    the module docstring); ``on_step`` (a :data:`StepHook`) sees every step before it is taken;
    ``progress`` is called with the number of finished episodes after every step that ends
    some. ``recorder`` (a :class:`~panda_rapier.video.VideoRecorder`) gets every frame of the
    episodes environment 0 runs: the first state and one frame per step. ``obs_mode``,
    ``image_size``, ``cameras`` and ``visual_randomization`` (as for
    :class:`~panda_rapier.PandaEnv`) give an SB3-style
    policy the image observations it was trained on."""
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise InvalidArgumentError(f"episodes must be an int >= 1, got {episodes!r}")
    if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
        raise InvalidArgumentError(f"num_envs must be an int >= 1, got {num_envs!r}")
    seed = _common.as_seed(first_seed)
    assert seed is not None
    if seed + episodes > 2**64:
        raise InvalidArgumentError(
            f"first_seed + episodes must not pass 2**64 (one seed per episode), got {seed} + "
            f"{episodes}"
        )
    config = dict(config)
    if config.get("max_episode_steps", 0) is None:
        raise ConfigError("evaluation needs a time limit: max_episode_steps must not be None")
    config_json = _common.config_json(config)
    spec = observation_spec(
        _common.Schema.of(config_json),
        obs_mode,
        image_size,
        cameras,
        visual_randomization,
        config_json=config_json,
    )
    evaluation = _native.Evaluation(
        config_json, episodes, min(num_envs, episodes), num_threads, seed
    )
    act, name, inference = _actor(
        policy, spec, lambda: [None if k is None else seed + k for k in evaluation.running()]
    )
    if spec.has_sensors:
        evaluation.set_cameras(spec.cameras_json, spec.touch)
    full_config = json.loads(evaluation.config_json())

    started = time.perf_counter()
    if recorder is not None:
        recorder.capture(evaluation)
    while not evaluation.done:
        observations = evaluation.observations()
        images = evaluation.images() if spec.has_sensors else None
        actions = np.ascontiguousarray(act(observations, images), dtype=np.float32)
        running = evaluation.running()
        if on_step is not None:
            if images is None:
                on_step(observations, actions, running)
            else:
                on_step(observations, actions, running, images)
        ended = evaluation.step(actions)
        # Environment 0's state after the step: the last frame of an episode that just ended.
        if recorder is not None and running[0] is not None:
            recorder.capture(evaluation)
        new_episode = evaluation.refill()
        if recorder is not None and new_episode[0]:
            recorder.capture(evaluation)
        if progress is not None and ended:
            progress(evaluation.finished)
    native = evaluation.report()
    return EvaluationReport(
        policy=name,
        config=full_config,
        first_seed=seed,
        num_envs=evaluation.num_envs,
        num_threads=evaluation.num_threads,
        env_steps=native["env_steps"],
        wall_time_s=time.perf_counter() - started,
        episodes=[EpisodeRecord(**record) for record in native["episodes"]],
        idle_env_steps=native["idle_env_steps"],
        inference=inference,
        environment=evaluation_environment(inference),
    )


#: The fields of :func:`evaluation_environment` an inference's outcomes depend on: where they
#: all match, the same evaluation gives the same episodes, bit for bit.
OUTCOME_FIELDS: dict[str, tuple[str, ...]] = {
    "scripted": ("inference", "panda_rapier", "machine", "libc"),
    # numpy draws the actions (PCG64; numpy does not promise its streams across versions).
    "random": ("inference", "panda_rapier", "machine", "libc", "numpy"),
    NATIVE: ("inference", "panda_rapier", "machine", "libc"),
    TORCH: (
        "inference", "panda_rapier", "machine", "libc", "cpu", "cpu_flags", "torch",
        "torch_cpu_capability", "stable_baselines3", "numpy",
    ),
    # A LeRobot policy (panda_rapier.agents.lerobot_policy): torch under LeRobot's code.
    "lerobot-torch-f32": (
        "inference", "panda_rapier", "machine", "libc", "cpu", "cpu_flags", "torch",
        "torch_cpu_capability", "lerobot", "numpy",
    ),
}  # fmt: skip


def evaluation_environment(inference: str) -> dict[str, str]:
    """What an evaluation's outcomes can depend on, as strings: the ``inference``, the package
    version, the CPU architecture (``machine``) and C library (``libc``: the physics calls its
    maths routines), numpy's version and, where torch is imported, its version, the CPU
    capability its kernels use (``ATEN_CPU_CAPABILITY`` can lower it) and stable-baselines3's
    version, lerobot's where it is imported, and the CPU's model and vector extensions
    (``cpu``, ``cpu_flags``: the BLAS under torch picks its matrix kernels by them, whatever
    ``ATEN_CPU_CAPABILITY`` says).
    :data:`OUTCOME_FIELDS` says which of them matter for which inference."""
    import sys

    libc = "-".join(x for x in platform.libc_ver() if x) or "unknown"
    cpu, flags = _cpu()
    environment = {
        "inference": inference,
        "panda_rapier": _native.__version__,
        "machine": platform.machine(),
        "libc": libc,
        "cpu": cpu,
        "cpu_flags": flags,
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    torch = sys.modules.get("torch")
    if torch is not None:
        environment["torch"] = str(torch.__version__)
        environment["torch_cpu_capability"] = str(torch.backends.cpu.get_cpu_capability())
    sb3 = sys.modules.get("stable_baselines3")
    if sb3 is not None:
        environment["stable_baselines3"] = str(sb3.__version__)
    if "lerobot" in sys.modules:
        from importlib.metadata import version

        environment["lerobot"] = version("lerobot")
    return environment


#: Vector extensions that change which kernels a BLAS runs.
_VECTOR_FLAGS = ("avx", "avx2", "fma", "avx512f", "avx512_bf16", "avx512_vnni", "amx_tile",
                 "asimd", "sve", "sve2")  # fmt: skip


def _cpu() -> tuple[str, str]:
    """The CPU's model name and its vector extensions among :data:`_VECTOR_FLAGS`, from
    ``/proc/cpuinfo`` (``platform.processor()`` elsewhere)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return platform.processor() or "unknown", ""
    model, flags = "unknown", set[str]()
    for line in text.splitlines():
        key, _, value = line.partition(":")
        key = key.strip().lower()
        if key in ("model name", "cpu model") and model == "unknown":
            model = value.strip()
        elif key in ("flags", "features") and not flags:
            flags = set(value.split())
    return model, " ".join(f for f in _VECTOR_FLAGS if f in flags)


@dataclass
class ReproductionCheck:
    """The verdict of :func:`check_reproduction`."""

    #: ``per-episode`` (the environments match: every episode must repeat) or ``statistical``.
    kind: str
    passed: bool
    #: What was compared and what differed.
    details: str
    #: The fields of the environment that differ (empty for ``per-episode``).
    differing: dict[str, tuple[str | None, str | None]] = field(default_factory=dict)


#: One-sided z of :func:`check_reproduction`'s statistical test (false alarm rate 0.1 %).
REPRODUCTION_Z = 3.09


def check_reproduction(
    recorded: Mapping[str, Any], report: EvaluationReport, z: float = REPRODUCTION_Z
) -> ReproductionCheck:
    """Compares a new evaluation with a recorded one of the same policy, environment and
    seeds (``recorded`` as ``panda-rapier models-table`` writes it to ``evaluations.json``:
    a summary with ``environment``, ``success_by_episode`` and ``placed_by_episode``; the
    report may cover fewer episodes, the first ones).

    Where every field :data:`OUTCOME_FIELDS` names for the recorded inference matches, the
    episodes must repeat exactly. Elsewhere, a one-sided two-proportion z-test (pooled) of the
    success rate and of the placed rate: the check fails when the new rate is below the
    recorded one by more than ``z`` standard errors (``z = 3.09``: one false alarm in 1,000 per
    rate). With 1,000 recorded and 300 new episodes at a rate of 0.95, a true drop to 0.85
    fails it 98 % of the time."""
    recorded_env = dict(recorded.get("environment") or {})
    inference = str(recorded_env.get("inference", "python"))
    fields = OUTCOME_FIELDS.get(inference, tuple(sorted(set(recorded_env) | {"inference"})))
    current = {**report.environment, "inference": report.inference}
    differing = {
        k: (recorded_env.get(k), current.get(k))
        for k in fields
        if recorded_env.get(k) != current.get(k)
    }
    success = "".join("1" if e.success else "0" for e in report.episodes)
    placed = "".join("1" if e.placed else "0" for e in report.episodes)
    n = len(success)
    if not differing:
        want_success = str(recorded["success_by_episode"])[:n]
        want_placed = str(recorded["placed_by_episode"])[:n]
        bad = [i for i in range(n) if success[i] != want_success[i] or placed[i] != want_placed[i]]
        return ReproductionCheck(
            "per-episode",
            not bad and len(want_success) == n,
            f"{n} episodes compared, {len(bad)} differ"
            + (f" (first: episode {bad[0]})" if bad else ""),
        )
    lines = []
    passed = True
    for what, now in (("success", success), ("placed", placed)):
        was = str(recorded[f"{what}_by_episode"])
        x1, n1, x2, n2 = was.count("1"), len(was), now.count("1"), n
        pooled = (x1 + x2) / (n1 + n2)
        se = math.sqrt(pooled * (1 - pooled) * (1 / n1 + 1 / n2))
        score = 0.0 if se == 0 else (x1 / n1 - x2 / n2) / se
        ok = score <= z
        passed &= ok
        lines.append(
            f"{what} {x2 / n2:.3f} on {n2} episodes vs recorded {x1 / n1:.3f} on {n1}: "
            f"z = {score:.2f} ({'ok' if ok else f'a drop beyond {z} standard errors'})"
        )
    return ReproductionCheck("statistical", passed, "; ".join(lines), differing)
