"""Learning curves and the table of shipped models: what ``panda-rapier curves`` and
``panda-rapier models-table`` run.

Both read what ``panda-rapier train`` writes (``evaluations.jsonl``, ``run.json``, the run
record inside each model zip); the table evaluates every model with exactly the command a
user runs, ``panda-rapier eval --policy MODEL.zip``, so nothing in it is typed by hand.
"""

from __future__ import annotations

import json
import shlex
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .errors import InvalidArgumentError
from .training import read_run_info

__all__ = ["models_table", "plot_curves", "run_label"]


def _evaluations(run: Path) -> list[dict[str, Any]]:
    path = run / "evaluations.jsonl"
    try:
        lines = path.read_text().splitlines()
    except OSError as error:
        raise InvalidArgumentError(f"{run} has no evaluations.jsonl: {error}") from error
    return [json.loads(line) for line in lines if line.strip()]


def run_label(run: dict[str, Any]) -> str:
    """A short name of a run: algorithm, task variant, arm and non-default options."""
    env = str(run.get("env_id", "?")).split("/")[-1]
    options = dict(run.get("env_kwargs") or {})
    arm = options.pop("arm", "dynamic")
    weights = options.pop("reward_weights", None) or {}  # shown as term=weight
    options.update({str(k): v for k, v in dict(weights).items()})
    extra = ", ".join(f"{k}={v}" for k, v in sorted(options.items()))
    tuned = ", fine-tuned" if run.get("init_from") else ""
    return f"{run.get('algo', '?')} {env} ({arm} arm{tuned}{', ' + extra if extra else ''})"


def plot_curves(runs: Sequence[Path], out: Path, reference: Path | None = None) -> None:
    """Success (solid, with its 95 % interval) and placed (dashed) rate of each run's periodic
    evaluations, against env steps and against wall-clock minutes of training. ``reference``:
    a JSON list of ``{"label", "env_steps_per_s"}`` (another recipe's measured training
    throughput on the same machine), drawn on the steps axis at the step count it reaches in
    the longest run's wall time. A fine-tuning run (``--init-from``) is drawn after the steps
    and minutes of the model it started from, so its curve shows the whole cost."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as error:
        raise ImportError("curves need matplotlib: pip install matplotlib") from error
    figure, (by_steps, by_time) = plt.subplots(1, 2, figsize=(13, 4.8))
    longest = 0.0
    for index, run_dir in enumerate(runs):
        lines = _evaluations(Path(run_dir))
        run = json.loads((Path(run_dir) / "run.json").read_text())
        color = f"C{index}"
        source = (run.get("init_from") or {}).get("run") or {}
        step0 = int(source.get("env_steps", 0))
        minute0 = float(source.get("wall_time_s", 0.0)) / 60
        steps = [step0 + line["env_steps"] for line in lines]
        minutes = [minute0 + line["wall_time_s"] / 60 for line in lines]
        longest = max(longest, max(minutes, default=0.0))
        success = [line["success_rate"] for line in lines]
        low = [line["success_ci95"][0] for line in lines]
        high = [line["success_ci95"][1] for line in lines]
        placed = [line["placed_rate"] for line in lines]
        for axis, x in ((by_steps, steps), (by_time, minutes)):
            axis.plot(x, success, "-o", color=color, ms=3, label=f"{run_label(run)}: success")
            axis.fill_between(x, low, high, color=color, alpha=0.15)
            axis.plot(x, placed, "--", color=color, label=f"{run_label(run)}: placed")
    if reference is not None and longest > 0:
        for index, item in enumerate(json.loads(Path(reference).read_text())):
            reached = float(item["env_steps_per_s"]) * longest * 60
            by_steps.axvline(reached, color=f"C{7 + index % 3}", ls=":", lw=1.5)
            by_steps.annotate(
                f"{item['label']}: {reached:,.0f} steps\nin {longest:.0f} min",
                (reached, 0.5 - 0.12 * index),
                fontsize=7,
                ha="left",
            )
    by_steps.set_xlabel("env steps (expert demonstrations and learner rollouts included)")
    by_steps.set_xscale("log")
    by_time.set_xlabel("wall-clock minutes of training on 2 cores (evaluations excluded)")
    for axis in (by_steps, by_time):
        axis.set_ylabel("rate on validation seeds")
        axis.set_ylim(-0.02, 1.02)
        axis.grid(alpha=0.3)
    by_time.legend(fontsize=7, loc="lower right")
    figure.suptitle("panda_rapier: learning curves (solid: success, dashed: cube placed)")
    figure.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(out, dpi=110)
    plt.close(figure)


def _evaluate_file(model: Path, episodes: int, quiet: bool) -> dict[str, Any]:
    from .cli import main

    with tempfile.TemporaryDirectory() as folder:
        report = Path(folder) / "eval.json"
        argv = ["eval", "--policy", str(model), "--episodes", str(episodes), "--json", str(report)]
        if quiet:
            argv.append("--quiet")
        code = main(argv)
        if code != 0:
            raise InvalidArgumentError(f"panda-rapier eval failed on {model} (exit {code})")
        return dict(json.loads(report.read_text()))


def models_table(
    folder: Path, episodes: int = 1000, progress: bool = True
) -> tuple[str, dict[str, Any]]:
    """Evaluates every ``*.zip`` in ``folder`` with ``panda-rapier eval --policy MODEL.zip``
    (seeds ``0 .. episodes - 1``, which no training run uses) and returns the markdown of
    ``folder``'s README (one row per model) and the evaluations (per model: the summary and
    each episode's success and placed flags as strings of 0 and 1)."""
    models = sorted(Path(folder).glob("*.zip"))
    if not models:
        raise InvalidArgumentError(f"no .zip models in {folder}")
    rows = []
    commands = []
    records: dict[str, Any] = {}
    for model in models:
        run = read_run_info(model)
        if run is None:
            raise InvalidArgumentError(f"{model} has no run record: was it made by train?")
        summary = _evaluate_file(model, episodes, quiet=not progress)
        episodes_run = summary.pop("episode_records")
        summary.pop("failed_episodes", None)
        records[model.name] = {
            **summary,
            "success_by_episode": "".join("1" if e["success"] else "0" for e in episodes_run),
            "placed_by_episode": "".join("1" if e["placed"] else "0" for e in episodes_run),
        }
        low, high = summary["success_ci95"]
        options = json.dumps(run.get("env_kwargs") or {}, sort_keys=True)
        # A fine-tuned model's cost includes the model it started from.
        source = (run.get("init_from") or {}).get("run") or {}
        env_steps = run["env_steps"] + int(source.get("env_steps", 0))
        wall_time = run["wall_time_s"] + float(source.get("wall_time_s", 0.0))
        rows.append(
            f"| `{model.name}` | {run['algo']} | `{run['env_id']}` | `{options}` "
            f"| {env_steps:,} | {wall_time / 60:.1f} "
            f"| {summary['success_rate']:.3f} ({low:.3f}-{high:.3f}) "
            f"| {summary['placed_rate']:.3f} |"
        )
        steps = [f"`{shlex.join(run['command'])}`, then copy `{_out_of(run['command'])}/"
                 f"{_saved_as(run)}` here as `{model.name}`"]  # fmt: skip
        if source:
            steps.insert(0, f"`{shlex.join(source['command'])}` (its `{_saved_as(source)}` is "
                            f"the `--init-from` model: {source.get('env_steps', 0):,} steps, "
                            f"{float(source.get('wall_time_s', 0)) / 60:.1f} min, included in "
                            "the row)")  # fmt: skip
        commands.append(
            f"- `{model.name}`: "
            + "; then ".join(steps)
            + (f" ({run['note']})" if run.get("note") else "")
        )
    header = (
        "# Trained policies\n\n"
        f"Generated by `panda-rapier models-table {folder.as_posix()}`: every row is "
        f"`panda-rapier eval --policy {folder.as_posix()}/NAME.zip` (no other flag: the "
        f"environment id and options are stored in the zip) on {episodes} episodes, seeds "
        f"0..{episodes - 1}, which no training run uses. Wall time is training on the 2-core "
        "development machine, evaluations excluded; env steps include the expert's "
        "demonstrations and every rollout the learner drove. Success: the cube within 5 cm of "
        "the goal at the last step (95 % Wilson interval); placed: also released and at rest "
        "on the platform. Actions come from the native float64 network (the same bits on "
        "every CPU): an evaluation repeats these episodes exactly wherever the package "
        "version, CPU architecture and C library recorded in `evaluations.json` match, and "
        "these rates within their interval elsewhere (`docs/reproducibility.md`).\n\n"
        "| model | algorithm | env id | options | env steps | wall time (min) "
        "| success (95 % CI) | placed |\n|---|---|---|---|---|---|---|---|\n"
    )
    text = header + "\n".join(rows) + "\n\n## Reproduce\n\n" + "\n".join(commands) + "\n"
    return text, records


def _saved_as(run: dict[str, Any]) -> str:
    """Which file of its run directory a model is: ``best.zip`` (the best periodic
    evaluation's, whose record holds that evaluation) or ``model.zip``."""
    return "best.zip" if "evaluation" in run else "model.zip"


def _out_of(command: Sequence[str]) -> str:
    """The ``--out`` directory of a recorded ``panda-rapier train`` command."""
    parts = list(command)
    if "--out" in parts[:-1]:
        return parts[parts.index("--out") + 1]
    return "OUT"
