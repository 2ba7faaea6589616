"""Throughput benchmark: what ``panda-rapier bench`` runs.

Measures env-steps per second (and simulated seconds per wall-clock second) of the
``gym.make`` single environment, the native Gymnasium vector environment and the
stable-baselines3 ``VecEnv`` at several batch sizes, with random actions and with the scripted
policy, and, when they are installed, of the peers (panda-gym's PandaPickAndPlace-v3,
Gymnasium-Robotics' FetchPickAndPlace, envpool's tasks) in the same process. Every round
measures every case once, in a fixed interleaved order, so drift on a busy machine spreads over
all of them; the report gives the median of the rounds. The accuracy side (the tutorial grasp's
slip and tracking error, the scripted policy's placed rate during the runs) is printed next to
the speed, so speed is never bought with a sloppier simulation.
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import importlib.util
import json
import os
import platform
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import gymnasium as gym
import numpy as np

from .. import __version__, _common
from .._native import tutorial_fidelity
from ..policy import ScriptedPolicy
from ..registration import env_config
from ..vector import PandaVectorEnv

__all__ = ["PEER_IDS", "BenchCase", "run_benchmark"]

#: Peer environments measured when their packages are installed: (label, package to import,
#: how to make it).
PEER_IDS: tuple[tuple[str, str, str], ...] = (
    ("panda-gym PandaPickAndPlace-v3", "panda_gym", "gym:PandaPickAndPlace-v3"),
    ("Gymnasium-Robotics FetchPickAndPlace-v4", "gymnasium_robotics", "gym:FetchPickAndPlace-v4"),
    ("envpool PandaPickCube-v1", "envpool", "envpool:PandaPickCube-v1"),
    ("envpool FetchPickAndPlace-v4", "envpool", "envpool:FetchPickAndPlace-v4"),
)


@dataclass
class BenchCase:
    """One thing measured: a target (``gym.make``, ``vector``, ``sb3`` or a peer), a policy
    (``random`` or ``scripted``) and a batch size."""

    target: str
    policy: str
    num_envs: int
    #: Control period (s) of one step, to turn env-steps/s into simulated seconds per second.
    dt: float
    runner: Callable[[int], float] = field(repr=False)
    rates: list[float] = field(default_factory=list)
    peer: bool = False
    #: Episode counts of the scripted runs (vector env): ended, placed.
    episodes: dict[str, int] = field(default_factory=lambda: {"ended": 0, "placed": 0})
    #: Releases the environments (each case lives for one measurement only, so a whole
    #: benchmark never holds more than one batch of environments: MuJoCo peers at N = 256
    #: take gigabytes).
    close: Callable[[], None] = field(default=lambda: None, repr=False)

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.target, self.policy, self.num_envs)

    @property
    def median(self) -> float:
        return float(np.median(self.rates)) if self.rates else float("nan")

    def row(self) -> dict[str, Any]:
        return {
            "target": self.target,
            "policy": self.policy,
            "num_envs": self.num_envs,
            "peer": self.peer,
            "env_steps_per_s": self.median,
            "sim_s_per_s": self.median * self.dt,
            "runs": self.rates,
        }


def _closed(_: int) -> float:
    raise RuntimeError("this benchmark case was closed")


def _timed(step: Callable[[int], None], steps: int) -> float:
    """Env-steps per second of ``steps`` calls of ``step`` (argument: the call's index)."""
    start = time.perf_counter()
    for k in range(steps):
        step(k)
    return steps / (time.perf_counter() - start)


def _measure_once(case: BenchCase, steps: int) -> float:
    """Measures ``case`` once (``steps`` calls), closes its environments and drops every
    reference to them, so they are freed before the next case is built: ``close``
    alone does not free envpool's batches (its MuJoCo peers hold 2-3 GB at N = 256 until
    garbage-collected), and a full run kept one batch per case alive until it was OOM-killed
    at 24 GB."""
    rate = case.runner(steps)
    case.close()
    case.runner, case.close = _closed, _noop
    gc.collect()
    return rate


def _noop() -> None:
    pass


def _shape(space: gym.Space[Any]) -> tuple[int, ...]:
    """The shape of a Box action space."""
    if space.shape is None:
        raise TypeError(f"expected a Box action space, got {space}")
    return space.shape


def _images(image_size: int | None, mode: str = "rgb") -> tuple[str, dict[str, Any]]:
    """The target's label suffix and the options of image observations (``state+<mode>``, one
    camera of ``image_size`` pixels, so the scripted policy still reads the state)."""
    if image_size is None:
        return "", {}
    return f" +{mode} {image_size}px", {"obs_mode": f"state+{mode}", "image_size": image_size}


def _single_env_case(
    env_id: str,
    policy: str,
    steps: int,
    config: dict[str, Any],
    image_size: int | None = None,
    mode: str = "rgb",
) -> BenchCase:
    suffix, images = _images(image_size, mode)
    env = gym.make(env_id, **config, **images)
    obs, _ = env.reset(seed=0)
    scripted = ScriptedPolicy(env) if policy == "scripted" else None
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, *_shape(env.action_space)))
    actions = actions.astype(np.float32)
    state = {"obs": obs}

    def step(k: int) -> None:
        action = scripted.predict(state["obs"])[0] if scripted else actions[k % steps]
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            obs, _ = env.reset()
        state["obs"] = obs

    dt = float(env.get_wrapper_attr("dt"))
    return BenchCase("gym.make" + suffix, policy, 1, dt, lambda n: _timed(step, n), close=env.close)


def _vector_case(
    env_id: str,
    policy: str,
    num_envs: int,
    threads: int | None,
    config: dict[str, Any],
    image_size: int | None = None,
    mode: str = "rgb",
) -> BenchCase:
    suffix, images = _images(image_size, mode)
    envs = PandaVectorEnv(num_envs, num_threads=threads, **env_config(env_id, **config), **images)
    obs, _ = envs.reset(seed=0)
    scripted = ScriptedPolicy(envs) if policy == "scripted" else None
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (64, *_shape(envs.action_space))).astype(np.float32)
    state = {"obs": obs}
    episodes = {"ended": 0, "placed": 0}

    def step(k: int) -> None:
        action = scripted.predict(state["obs"])[0] if scripted else actions[k % len(actions)]
        obs, _, terminated, truncated, infos = envs.step(action)
        ended = terminated | truncated
        if scripted is not None and ended.any():
            episodes["ended"] += int(ended.sum())
            # Tasks without a "placed" predicate count no placements.
            placed = infos.get("is_placed", np.zeros_like(ended))
            episodes["placed"] += int((ended & placed).sum())
        state["obs"] = obs

    return BenchCase(
        "vector" + suffix,
        policy,
        num_envs,
        float(envs.dt),
        lambda n: _timed(step, n) * num_envs,
        episodes=episodes,
        close=envs.close,
    )


def _sb3_case(
    env_id: str, policy: str, num_envs: int, threads: int | None, config: dict[str, Any]
) -> BenchCase:
    # Imported on use: stable-baselines3 (its extra) is only for the sb3 cases.
    from ..sb3 import make_vec_env

    venv = make_vec_env(env_id, n_envs=num_envs, seed=0, num_threads=threads, **config)
    obs = venv.reset()
    scripted = ScriptedPolicy(venv) if policy == "scripted" else None
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (64, num_envs, *_shape(venv.action_space))).astype(np.float32)
    state: dict[str, Any] = {"obs": obs}

    def step(k: int) -> None:
        action = scripted.predict(state["obs"])[0] if scripted else actions[k % len(actions)]
        state["obs"], _, _, _ = venv.step(action)

    return BenchCase(
        "sb3", policy, num_envs, venv.dt, lambda n: _timed(step, n) * num_envs, close=venv.close
    )


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silences the C-level stdout (PyBullet prints its start-up arguments there)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _peer_case(label: str, how: str, num_envs: int) -> BenchCase | None:
    """A peer, or ``None`` when it cannot be made here."""
    kind, env_id = how.split(":", 1)
    try:
        if kind == "gym":
            if num_envs != 1:
                return None
            with _quiet_stdout():
                env = gym.make(env_id)
                env.reset(seed=0)
            dt = float(getattr(env.unwrapped, "dt", 0.04))

            def step(k: int) -> None:
                _, _, terminated, truncated, _ = env.step(env.action_space.sample())
                if terminated or truncated:
                    env.reset()

            env.action_space.seed(0)
            return BenchCase(
                label, "random", 1, dt, lambda n: _timed(step, n), peer=True, close=env.close
            )
        envpool = importlib.import_module("envpool")
        venv = envpool.make_gymnasium(env_id, num_envs=num_envs, seed=0)
        venv.reset()
        space = venv.action_space
        rng = np.random.default_rng(0)
        actions = rng.uniform(space.low, space.high, (64, num_envs, *space.shape))
        actions = actions.astype(space.dtype)
        # envpool's MuJoCo Playground ports step at 50 Hz; Fetch at 25 Hz.
        dt = 0.02 if "Panda" in env_id else 0.04

        def batch_step(k: int) -> None:
            venv.step(actions[k % len(actions)])

        return BenchCase(
            label,
            "random",
            num_envs,
            dt,
            lambda n: _timed(batch_step, n) * num_envs,
            peer=True,
            close=getattr(venv, "close", lambda: None),
        )
    except Exception:  # a peer that fails to start is reported as missing
        return None


def available_peers() -> list[tuple[str, str]]:
    """The peers whose packages import here."""
    found = []
    for label, package, how in PEER_IDS:
        try:
            importlib.import_module(package)
        except Exception:  # a missing or broken install: not measured
            continue
        found.append((label, how))
    return found


def machine() -> dict[str, Any]:
    """What the figures were measured on."""
    return {
        "cpus": os.cpu_count(),
        "machine": platform.machine(),
        "processor": platform.processor() or platform.machine(),
        "system": f"{platform.system()} {platform.release()}",
        "python": platform.python_version(),
        "panda_rapier": __version__,
    }


def run_benchmark(
    *,
    env_id: str = "panda_rapier/PickAndPlace-v0",
    num_envs: Sequence[int] = (1, 16, 64, 256),
    targets: Iterable[str] = ("gym.make", "vector", "sb3"),
    policies: Iterable[str] = ("random", "scripted"),
    threads: int | None = None,
    rounds: int = 3,
    env_steps: int = 4000,
    peers: bool = True,
    progress: Callable[[int, int, str], None] | None = None,
    image_sizes: Sequence[int] = (),
    image_modes: Sequence[str] = ("rgb",),
    **config: Any,
) -> dict[str, Any]:
    """Runs every case ``rounds`` times (each run: about ``env_steps`` environment steps) and
    returns the report (see the module documentation). Each of ``image_sizes`` adds the
    ``gym.make`` and ``vector`` cases again with image observations (``obs_mode="state+rgb"``,
    one camera, square images of that many pixels), once for each of ``image_modes``
    (``obs_mode="state+<mode>"``: ``rgb``, ``depth``, ``segmentation``, ``rgbd``, ...)."""
    targets, policies = list(targets), list(policies)
    builders: list[Callable[[], BenchCase | None]] = []
    for policy in policies:
        if "gym.make" in targets:
            builders.append(partial(_single_env_case, env_id, policy, env_steps, config))
        for n in num_envs:
            if "vector" in targets:
                builders.append(partial(_vector_case, env_id, policy, n, threads, config))
            if "sb3" in targets and importlib.util.find_spec("stable_baselines3") is not None:
                builders.append(partial(_sb3_case, env_id, policy, n, threads, config))
        for size in image_sizes:
            for mode in image_modes:
                if "gym.make" in targets:
                    builders.append(
                        partial(_single_env_case, env_id, policy, env_steps, config, size, mode)
                    )
                for n in num_envs:
                    if "vector" in targets:
                        builders.append(
                            partial(_vector_case, env_id, policy, n, threads, config, size, mode)
                        )
    missing = []
    if peers:
        found = available_peers()
        for label, how in found:
            sizes = [1] if how.startswith("gym:") else list(num_envs)
            builders += [partial(_peer_case, label, how, n) for n in sizes]
        missing += [label for label, _, _ in PEER_IDS if label not in {f for f, _ in found}]
    # Every round builds each case, measures it and closes it again, in the same order, so
    # drift spreads over all cases and only one batch of environments exists at a time.
    records: dict[tuple[str, str, int], BenchCase] = {}
    failed: dict[int, str] = {}
    total = rounds * len(builders)
    for round_index in range(rounds):
        for i, build in enumerate(builders):
            if i in failed:
                continue
            case = build()
            if case is None:
                failed[i] = "peer"
                continue
            record = records.setdefault(case.key, case)
            record.rates.append(_measure_once(case, max(1, env_steps // case.num_envs)))
            if record is not case:
                for k, v in case.episodes.items():
                    record.episodes[k] += v
            if progress is not None:
                progress(round_index * len(builders) + i + 1, total,
                         f"{record.target} {record.policy} N={record.num_envs}")  # fmt: skip
    cases = list(records.values())
    made_peers = {c.target for c in cases if c.peer}
    missing += [
        label for label, _ in (available_peers() if peers else []) if label not in made_peers
    ]
    fidelity: dict[str, float | bool | None] = dict(
        tutorial_fidelity(_common.config_json(env_config(env_id, **config)))
    )
    ended = sum(case.episodes["ended"] for case in cases)
    placed = sum(case.episodes["placed"] for case in cases)
    fidelity["scripted_episodes_ended"] = ended
    fidelity["scripted_placed_rate"] = placed / ended if ended else None
    rows = [case.row() for case in cases]
    return {
        "machine": machine(),
        "env_id": env_id,
        "config": config,
        "threads": threads,
        "rounds": rounds,
        "env_steps_per_run": env_steps,
        "image_sizes": list(image_sizes),
        "image_modes": list(image_modes),
        "results": rows,
        "ratios": _ratios(cases),
        "peers_missing": sorted(set(missing)),
        "fidelity": fidelity,
    }


def _ratios(cases: list[BenchCase]) -> list[dict[str, Any]]:
    """Ours against each peer measurement: the same batch size, random actions, by simulated
    seconds per second (peers step at different control rates) and by env-steps/s."""
    ours = [c for c in cases if not c.peer and c.policy == "random"]
    out = []
    for peer in (c for c in cases if c.peer):
        same = [c for c in ours if c.num_envs == peer.num_envs]
        for mine in same:
            out.append(
                {
                    "ours": f"{mine.target} N={mine.num_envs}",
                    "peer": f"{peer.target} N={peer.num_envs}",
                    "env_steps_ratio": mine.median / peer.median,
                    "sim_time_ratio": (mine.median * mine.dt) / (peer.median * peer.dt),
                }
            )
    return out


def format_report(report: dict[str, Any]) -> str:
    """The report as a table for people."""
    lines = [
        f"machine: {report['machine']['cpus']} cpus, {report['machine']['processor']}, "
        f"{report['machine']['system']}, Python {report['machine']['python']}",
        f"{report['env_id']} ({report['config'].get('arm', 'dynamic')} arm), medians of "
        f"{report['rounds']} rounds, threads: "
        f"{report['threads'] or 'all cores'}",
        "",
        f"{'target':<42} {'policy':<9} {'N':>4} {'env-steps/s':>12} {'sim-s/s':>9}",
    ]
    for row in report["results"]:
        lines.append(
            f"{row['target']:<42} {row['policy']:<9} {row['num_envs']:>4} "
            f"{row['env_steps_per_s']:>12,.0f} {row['sim_s_per_s']:>9.1f}"
        )
    if report["ratios"]:
        lines += ["", f"{'ours':<22} {'peer':<46} {'env-steps':>9} {'sim-time':>9}"]
        for r in report["ratios"]:
            lines.append(
                f"{r['ours']:<22} {r['peer']:<46} {r['env_steps_ratio']:>8.1f}x "
                f"{r['sim_time_ratio']:>8.1f}x"
            )
    if report["peers_missing"]:
        lines += ["", "not measured (not installed or failed to start): "
                  + ", ".join(report["peers_missing"])]  # fmt: skip
    f = report["fidelity"]
    placed = f.get("scripted_placed_rate")
    lines += [
        "",
        "accuracy: tutorial grasp carry slip "
        f"{f['carry_slip_mm']:.2f} mm / {f['carry_slip_deg']:.2f} deg, max slip "
        f"{f['max_slip_mm']:.2f} mm, tracking error {f['max_tracking_error_mm']:.2f} mm, "
        f"placed {f['placement_error_mm']:.1f} mm from the target"
        + (
            f"; scripted policy placed the cube in {placed:.1%} of "
            f"{f['scripted_episodes_ended']} episodes that ended during the runs"
            if placed is not None
            else ""
        ),
    ]
    return "\n".join(lines)


def to_json(report: dict[str, Any]) -> str:
    return json.dumps(report, indent=2)
