"""Training throughput benchmark: what ``panda-rapier bench-train`` runs.

Trains the same algorithm on the same id with several variants of its recipe (hyperparameter
overrides, ``update_threads``: torch's threads during updates, ``overlap``: updates
overlapped with the next rollout, and ``backend``) for a fixed number of env
steps each, round after round in a fixed interleaved order, so the machine's drift spreads
over every variant; reports per variant the median over the rounds of the end-to-end rate
(env steps per second of training, updates included; evaluations, checkpoints and set-up
excluded) and of where the time went (:mod:`panda_rapier.learning.phases`), and each median's ratio
to the first variant's. Every run is a real ``panda-rapier train`` run (:func:`~panda_rapier.
training.train`, seed 0, no evaluations) in a scratch directory.

Speed is measured here; learning per env step is not (a short run says nothing about it):
compare variants' learning with full runs and their validation curves
(``panda-rapier curves``).
"""

from __future__ import annotations

import statistics
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import ConfigError, InvalidArgumentError
from ..learning.phases import PHASES
from ..learning.recipes import load_recipe
from ..learning.runner import train

__all__ = ["Variant", "benchmark_training", "format_training_report", "parse_variant"]

#: A variant: its name and its overrides (recipe keys, ``update_threads``, and ``backend``:
#: ``sb3``, the default (what ``panda-rapier train`` uses: for ppo
#: :class:`panda_rapier.learning.ppo.PPO`), ``sb3-stock`` (``stable_baselines3.PPO`` itself, ppo
#: only) or ``rllib`` (ppo only: the same recipe trained by RLlib), and ``overlap`` (``true``:
#: ppo's updates overlapped with the next rollout, :mod:`panda_rapier.learning.overlap`).
Variant = tuple[str, dict[str, Any]]
#: Variant keys that are not recipe keys.
_RUN_KEYS = ("update_threads", "backend", "overlap")


def parse_variant(tokens: Sequence[str]) -> Variant:
    """``["fast", "n_epochs=4", "update_threads=2"]`` -> ``("fast", {...})``; values are read
    as YAML scalars (``0.98``, ``null``, ``lin_3e-4``)."""
    import yaml

    if not tokens:
        raise InvalidArgumentError("a variant needs a name")
    name, *pairs = tokens
    if "=" in name:
        raise InvalidArgumentError(f"a variant starts with its name, got {name!r}")
    overrides: dict[str, Any] = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or not key:
            raise InvalidArgumentError(f"variant {name}: expected KEY=VALUE, got {pair!r}")
        overrides[key] = yaml.safe_load(text)
    threads = overrides.get("update_threads")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int)
                                or threads < 1):  # fmt: skip
        raise InvalidArgumentError(f"variant {name}: update_threads must be an int >= 1")
    return name, overrides


def benchmark_training(
    algo: str,
    env_id: str,
    variants: Sequence[Variant],
    *,
    steps: int = 81_920,
    rounds: int = 3,
    conf: str | Path | None = None,
    progress: Callable[[int, int, str], None] | None = None,
) -> dict[str, Any]:
    """Measures ``variants`` of ``algo``'s recipe for ``env_id`` (from ``conf``, default the
    package's), ``steps`` env steps per run, ``rounds`` interleaved rounds; returns the
    report (see the module's documentation). ``progress(done, total, label)`` is called
    before each run."""
    import yaml

    if algo == "bc":
        raise InvalidArgumentError("bench-train measures ppo, sac and tqc (bc has no env loop)")
    if not variants:
        raise InvalidArgumentError("give at least one variant")
    names = [name for name, _ in variants]
    if len(set(names)) != len(names):
        raise InvalidArgumentError(f"variant names must differ, got {names}")
    for label, value in (("steps", steps), ("rounds", rounds)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise InvalidArgumentError(f"{label} must be an int >= 1, got {value!r}")
    base = load_recipe(algo, env_id, conf)
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in names}
    total = rounds * len(variants)
    with tempfile.TemporaryDirectory(prefix="bench-train-") as scratch:
        recipes: dict[str, tuple[Path, int | None, str, Any]] = {}
        for name, overrides in variants:
            recipe = {**base, **{k: v for k, v in overrides.items() if k not in _RUN_KEYS}}
            path = Path(scratch) / f"{name}.yml"
            path.write_text(yaml.safe_dump({env_id: recipe}))
            backend = overrides.get("backend", "sb3")
            overlap = overrides.get("overlap", False)
            recipes[name] = (path, overrides.get("update_threads"), backend, overlap)
            if overlap not in (True, False) or (overlap and (backend != "sb3" or algo != "ppo")):
                raise InvalidArgumentError(
                    f"variant {name}: overlap is true or false, and true only for ppo with "
                    f"backend sb3, got {overlap!r}"
                )
            if backend not in ("sb3", "sb3-stock", "rllib") or (backend != "sb3" and algo != "ppo"):
                raise InvalidArgumentError(
                    f"variant {name}: backend is sb3, sb3-stock or rllib (the last two ppo "
                    f"only), got {backend!r}"
                )
        for r in range(rounds):
            for k, name in enumerate(names):
                if progress is not None:
                    progress(r * len(names) + k, total, f"round {r + 1}, {name}")
                path, threads, backend, overlap = recipes[name]
                out = Path(scratch) / f"run-{r}-{name}"
                try:
                    if backend == "rllib":
                        from ..scale.rllib_training import train as train_rllib

                        run = train_rllib(
                            env_id, out, conf=path, timesteps=steps, eval_every=0,
                            checkpoint_every=0, progress=False, say=lambda _: None,
                        )  # fmt: skip
                    else:
                        run = train(
                            algo, env_id, out, conf=path, timesteps=steps,
                            update_threads=threads, eval_every=0, checkpoint_every=0,
                            progress=False, say=lambda _: None,
                            stock_sb3=backend == "sb3-stock",
                            overlap_updates=bool(overlap),
                        )  # fmt: skip
                except ConfigError as error:
                    raise ConfigError(f"variant {name}: {error}") from error
                split = run["wall_time_split"]
                seconds = sum(split.values())
                runs[name].append(
                    {"env_steps": run["env_steps"], "seconds": round(seconds, 3),
                     "env_steps_per_s": run["env_steps"] / seconds, **split}
                )  # fmt: skip
        if progress is not None:
            progress(total, total, "done")
    rows: list[dict[str, Any]] = []
    for name, overrides in variants:
        median = {
            key: statistics.median(float(one[key]) for one in runs[name])
            for key in ("env_steps_per_s", "seconds", *PHASES)
        }
        rows.append({"variant": name, "overrides": overrides, "median": median,
                     "rounds": runs[name]})  # fmt: skip
    first = rows[0]["median"]["env_steps_per_s"]
    for row in rows:
        row["ratio_to_first"] = row["median"]["env_steps_per_s"] / first
    return {"algo": algo, "env_id": env_id, "steps": steps, "rounds": rounds, "variants": rows}


def format_training_report(report: Mapping[str, Any]) -> str:
    """The report as a markdown table: median env-steps/s, ratio to the first variant and
    the median seconds of each phase."""
    head = (
        f"{report['algo']} on {report['env_id']}: {report['steps']:,} env steps per run, "
        f"medians of {report['rounds']} interleaved rounds\n\n"
        "| variant | overrides | env-steps/s | ratio | env stepping (s) | policy in rollouts (s) "
        "| other rollout work (s) | updates (s) |\n|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for row in report["variants"]:
        median = row["median"]
        overrides = " ".join(f"{k}={v}" for k, v in row["overrides"].items()) or "-"
        lines.append(
            f"| {row['variant']} | {overrides} | {median['env_steps_per_s']:,.0f} "
            f"| {row['ratio_to_first']:.2f} | "
            + " | ".join(f"{median[phase]:.2f}" for phase in PHASES)
            + " |"
        )
    return head + "\n".join(lines)
