"""Run directories and records: what every trainer (:func:`panda_rapier.learning.runner.train`,
the bc and student runs, :mod:`panda_rapier.scale.rllib_training`) writes to its output
directory, and the periodic validation that ranks its models.

- ``run.json`` (:func:`run_record`, :func:`finish_run`): versions, seeds, hyperparameters, the
  command, steps, wall time and the last evaluation;
- ``evaluations.jsonl`` and ``best.zip`` (:class:`Recorder`): one line per periodic evaluation
  on the validation seeds (:data:`panda_rapier.seeds.VALIDATION_FIRST_SEED` on), and the best
  evaluation's model;
- ``model.zip`` (:func:`finish_run`): the final model, the weights training ended with or the
  best evaluation's (:func:`load_weights`).
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import torch as th

from .. import __version__
from ..agents.evaluation import evaluate, evaluation_environment
from ..agents.inference import space_mismatch
from ..agents.model_file import read_model_file, read_run_info, save_model
from ..errors import InvalidArgumentError
from ..registration import task_places, variant
from ..seeds import VALIDATION_FIRST_SEED

__all__ = [
    "UNTRAINED_BY_CLONING",
    "VALUE_PREFIXES",
    "Recorder",
    "actor_frozen",
    "cpu_count",
    "due",
    "finish_run",
    "load_weights",
    "open_run",
    "run_record",
    "stop_reason",
    "versions",
    "write_run",
]


def write_run(out: Path, run: Mapping[str, Any]) -> None:
    """Writes the run record ``run`` to ``out/run.json``."""
    (out / "run.json").write_text(json.dumps(run, indent=2, default=str))


def versions() -> dict[str, str]:
    """Versions of what a run depends on."""
    found = {"panda_rapier": __version__, "python": platform.python_version()}
    for name in ("stable_baselines3", "sb3_contrib", "torch", "numpy", "gymnasium"):
        try:
            found[name] = str(__import__(name).__version__)
        except ImportError:
            pass
    return found


class Recorder:
    """Periodic seeded evaluation on validation seeds, ``evaluations.jsonl`` and the best
    model; wall time counts the training, not the evaluations."""

    def __init__(
        self,
        out: Path,
        config: Mapping[str, Any],
        run: dict[str, Any],
        episodes: int,
        num_threads: int | None,
        wall_offset: float = 0.0,
        say: Callable[[str], None] = print,
        on_evaluation: Callable[[dict[str, Any]], None] | None = None,
        observation: Mapping[str, Any] | None = None,
    ) -> None:
        self.out = out
        #: The observation options the policy acts on (``obs_mode``, ``image_size``, ...).
        self.observation = dict(observation or {})
        self.on_evaluation = on_evaluation
        self.config = dict(config)
        self.run = run
        self.episodes = episodes
        self.num_threads = num_threads
        self.wall_offset = wall_offset
        self.eval_time = 0.0
        #: Seconds spent writing checkpoints (counted in the wall time, not in its split).
        self.checkpoint_time = 0.0
        self.started = time.perf_counter()
        self.say = say
        self.best: tuple[float, float, float] | None = None
        #: Evaluations since the best one (0: the last was the best).
        self.since_best = 0
        for line in _read_lines(out / "evaluations.jsonl"):
            self._rank(line)
            run["last_evaluation"] = line  # a resumed run knows where it stopped

    def _rank(self, line: Mapping[str, Any]) -> bool:
        """Ranks an evaluation against the best so far (placed rate, then success rate, as
        ``best.zip`` is chosen; the earlier of equal ones stays); True if it is the new best.
        Evaluations that never succeed are ranked by their mean return, so a run that has not
        succeeded yet keeps its most rewarded policy rather than its first (ties between
        succeeding evaluations are not, so earlier runs choose what they chose). An
        evaluation made while the actor was frozen (``actor_frozen``: a critic warm-up) can be
        the best but does not count towards ``--patience``: patience counts from the warm-up's
        end."""
        placed, success = float(line["placed_rate"]), float(line["success_rate"])
        never = placed == 0.0 and success == 0.0
        key = (placed, success, float(line.get("mean_return", 0.0)) if never else 0.0)
        if self.best is None or key > self.best:
            self.best = key
            self.since_best = 0
            return True
        if not line.get("actor_frozen"):
            self.since_best += 1
        return False

    def wall_time(self) -> float:
        return self.wall_offset + time.perf_counter() - self.started - self.eval_time

    def evaluate(self, model: Any, env_steps: int, logger: Any = None) -> dict[str, Any]:
        wall = self.wall_time()
        began = time.perf_counter()
        report = evaluate(
            model,
            self.config,
            self.episodes,
            num_envs=min(32, self.episodes),
            first_seed=VALIDATION_FIRST_SEED,
            num_threads=self.num_threads,
            **self.observation,
        )
        self.eval_time += time.perf_counter() - began
        summary = report.summary()
        line = {
            "env_steps": int(env_steps),
            "wall_time_s": round(wall, 3),
            "episodes": self.episodes,
            "first_seed": VALIDATION_FIRST_SEED,
            "success_rate": summary["success_rate"],
            "success_ci95": summary["success_ci95"],
            "placed_rate": summary["placed_rate"],
            "mean_return": summary["mean_return"],
        }
        if actor_frozen(model):
            line["actor_frozen"] = True
        with (self.out / "evaluations.jsonl").open("a") as file:
            file.write(json.dumps(line) + "\n")
        if logger is not None:
            for key in ("success_rate", "placed_rate", "mean_return"):
                logger.record(f"eval/{key}", line[key])
        low, high = line["success_ci95"]
        placed = (
            f", placed {line['placed_rate']:.3f}"
            if task_places(variant(str(self.run["env_id"]))["task"])
            else ""
        )
        self.say(
            f"[{env_steps:>10,} steps, {wall / 60:6.1f} min] validation success "
            f"{line['success_rate']:.3f} ({low:.3f}-{high:.3f}){placed}"
        )
        if self._rank(line):
            best = {**self.run, "evaluation": line}
            best.update(env_steps=line["env_steps"], wall_time_s=line["wall_time_s"])
            save_model(model, self.out / "best.zip", best)
        self.run["last_evaluation"] = line
        if self.on_evaluation is not None:
            self.on_evaluation(dict(line))
        return line


def _read_lines(path: Path) -> list[dict[str, Any]]:
    try:
        return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    except (OSError, ValueError):
        return []


def stop_reason(
    recorder: Recorder, line: Mapping[str, Any], patience: int | None, stop_at: float | None
) -> str | None:
    """Why training stops after the evaluation ``line`` (``None``: it goes on): its success
    rate (and, on a task that places, its placed rate too) reached ``stop_at``, or
    ``patience`` evaluations in a row have not beaten the best."""
    if stop_at is not None:
        success = float(line["success_rate"])
        if task_places(variant(str(recorder.run["env_id"]))["task"]):
            placed = float(line["placed_rate"])
            if min(success, placed) >= stop_at:
                return (
                    f"validation success {success:.3f} and placed {placed:.3f} reached "
                    f"--stop-at {stop_at}"
                )
        elif success >= stop_at:
            return f"validation success {success:.3f} reached --stop-at {stop_at}"
    if patience is not None and recorder.since_best >= patience:
        return f"{recorder.since_best} evaluations without beating the best (--patience {patience})"
    return None


def open_run(
    out: Path,
    algo: str,
    env_id: str,
    resume: bool,
    recipe: Mapping[str, Any],
    env_kwargs: Mapping[str, Any] | None,
) -> tuple[dict[str, Any] | None, dict[str, Any], dict[str, Any]]:
    """Checks that ``out`` can take the run (a checkpoint to resume from, or no run yet) and
    creates it; returns the earlier run record (``None`` for a new run), the recipe and the
    environment options the run trains with: a resumed run goes on with the ones it recorded,
    ``env_kwargs`` added to the options."""
    state_file = out / "checkpoints" / "state.json"
    previous = None
    if resume:
        if not state_file.is_file():
            raise InvalidArgumentError(f"nothing to resume: {state_file} does not exist")
        previous = json.loads((out / "run.json").read_text())
        if previous.get("algo") != algo or previous.get("env_id") != env_id:
            raise InvalidArgumentError(
                f"{out} holds a {previous.get('algo')} run on {previous.get('env_id')}"
            )
        if isinstance(previous.get("recipe"), dict):
            recipe = previous["recipe"]
        recorded = previous.get("env_kwargs")
        base = recorded if isinstance(recorded, dict) else {}
    elif (out / "run.json").exists():
        raise InvalidArgumentError(f"{out} already holds a run: pass --resume or another --out")
    else:
        base = dict(recipe.get("env_kwargs") or {})
    out.mkdir(parents=True, exist_ok=True)
    return previous, dict(recipe), {**base, **dict(env_kwargs or {})}


def run_record(
    algo: str,
    env_id: str,
    options: Mapping[str, Any],
    config: Mapping[str, Any],
    recipe: Mapping[str, Any],
    conf: str | Path | None,
    seed: int,
    command: list[str] | None,
    previous: Mapping[str, Any] | None,
) -> dict[str, Any]:
    """The run record's entries every trainer writes (a resumed run keeps its first command
    and lists the later ones in ``resumed_with``)."""
    run: dict[str, Any] = {
        "algo": algo,
        "saved_algo": "ppo" if algo == "bc" else algo,
        "env_id": env_id,
        "env_kwargs": dict(options),
        "config": dict(config),
        "recipe": dict(recipe),
        "recipe_file": str(conf)
        if conf is not None
        else f"panda_rapier/learning/hyperparams/{algo}.yml",
        "seed": int(seed),
        "validation_first_seed": VALIDATION_FIRST_SEED,
        "command": command if command is not None else sys.argv,
        "versions": versions(),
        "machine": machine(),
    }
    if previous is not None:
        run["command"] = previous.get("command", run["command"])
        run["resumed_with"] = [*previous.get("resumed_with", []), command or sys.argv]
    return run


def machine() -> dict[str, Any]:
    """Where a run trains, for reading its wall time: the cores it may use, the platform, and
    the CPU's model and vector extensions (as evaluation reports record them)."""
    found = evaluation_environment("training")
    return {"cpus": cpu_count(), "platform": platform.platform(), "cpu": found["cpu"],
            "cpu_flags": found["cpu_flags"]}  # fmt: skip


def due(state: dict[str, Any], key: str, every: int | None, steps: int) -> bool:
    """Whether the periodic ``key`` (``next_eval``, ``next_checkpoint``) is due at ``steps``;
    if so, moves it past ``steps`` by whole periods."""
    if not every or steps < state[key]:
        return False
    while state[key] <= steps:
        state[key] += every
    return True


def finish_run(model: Any, out: Path, run: dict[str, Any], final: str) -> dict[str, Any]:
    """Writes ``model.zip`` (the weights training ended with, or with ``final="best"`` the
    best evaluation's) and ``run.json``; returns the run record."""
    run["final_weights"] = run.get("last_evaluation")
    if final == "best" and (out / "best.zip").is_file():
        load_weights(model, out / "best.zip")
        run["final_weights"] = (read_run_info(out / "best.zip") or {}).get("evaluation")
    save_model(model, out / "model.zip", run)
    write_run(out, run)
    return run


#: Parameter-name prefixes of the value function in SB3's actor-critic policies.
VALUE_PREFIXES = ("mlp_extractor.value_net.", "value_net.", "vf_features_extractor.")


def actor_frozen(model: Any) -> bool:
    """Whether ``model``'s action head takes no gradient: a value-function warm-up
    (:class:`panda_rapier.learning.finetune.CriticWarmup`) is under way, so its evaluations show the
    policy it started from and ``--patience`` does not count them."""
    head = getattr(getattr(model, "policy", None), "action_net", None)
    parameters = list(head.parameters()) if head is not None else []
    return bool(parameters) and not any(p.requires_grad for p in parameters)


#: The parameters a cloned policy (``--algo bc``) never trained: behaviour cloning fits the
#: action mean only, so its value function and action noise are the network's initial ones.
UNTRAINED_BY_CLONING = (*VALUE_PREFIXES, "log_std")


def load_weights(model: Any, path: Path) -> list[str]:
    """Copies the policy weights (normaliser buffers included) of the model file at ``path``
    into ``model``, reading the file by data alone (:func:`~panda_rapier.agents.model_file.
    read_model_file`: nothing in it is unpickled); other spaces or another architecture are an
    :class:`InvalidArgumentError`. From a cloned policy (a ``bc`` run's model) only what
    cloning trained is copied, the actor and the observation normaliser: the value function
    and the action noise (:data:`UNTRAINED_BY_CLONING`) stay the recipe's, whose value network
    may then have any size. Returns the names of the entries left as the recipe made them."""
    data, weights = read_model_file(path)
    mismatch = space_mismatch(data, model.observation_space, model.action_space)
    if mismatch is not None:
        raise InvalidArgumentError(f"--init-from {path}: its {mismatch} (this environment's)")
    target = model.policy.state_dict()
    source_run = read_run_info(path) or {}
    kept: list[str] = []
    if source_run.get("algo") == "bc":
        untrained: tuple[str, ...] = UNTRAINED_BY_CLONING
        if isinstance(source_run.get("student"), Mapping):
            # A student's image encoder is shared by its actor and value function (its zip
            # holds it under both names): what cloning trained of it starts both, also when
            # the fine-tune gives the value function its own copy.
            untrained = tuple(p for p in untrained if p != "vf_features_extractor.")
        kept = sorted(k for k in target if k.startswith(untrained))
        weights = {k: v for k, v in weights.items() if not k.startswith(untrained)}
    shapes = {k: tuple(v.shape) for k, v in weights.items()}
    wanted = {k: tuple(v.shape) for k, v in target.items() if k not in kept}
    if shapes != wanted:
        differ = sorted(set(shapes.items()) ^ set(wanted.items()))[:4]
        raise InvalidArgumentError(
            f"--init-from {path}: its network does not match the recipe's (first differences, "
            f"name and shape: {differ})"
        )
    model.policy.load_state_dict({**target, **{k: th.as_tensor(v) for k, v in weights.items()}})
    return kept


def cpu_count() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
