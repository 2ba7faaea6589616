"""Learning curves of every shipped model, one picture per task (both action modes; the
students that see, panda_rapier.learning.student, in a picture of their own): success
and placed rate on validation seeds against env steps and against wall-clock minutes, drawn
by ``panda_rapier.tools.reporting.plot_curves`` from the runs' evaluation logs kept in
``docs/training-runs/`` (each run's ``run.json`` and ``evaluations.jsonl``; a model is matched
to its run by the recorded ``panda-rapier train`` command). Run after adding a model:

    .venv/bin/python scripts/learning_curves.py [--models models] [--runs docs/training-runs]
        [--out docs/curves]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tqdm import tqdm

from panda_rapier.agents.model_file import read_run_info
from panda_rapier.registration import TASK_NAMES, variant
from panda_rapier.tools.reporting import plot_curves

ROOT = Path(__file__).resolve().parents[1]


def run_dirs(runs: Path) -> dict[tuple[str, ...], Path]:
    """Each kept run's directory by its recorded command."""
    found = {}
    for record in sorted(runs.glob("*/run.json")):
        command = tuple(json.loads(record.read_text())["command"])
        found[command] = record.parent
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=Path, default=ROOT / "models")
    parser.add_argument("--runs", type=Path, default=ROOT / "docs" / "training-runs")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "curves")
    args = parser.parse_args()
    kept = run_dirs(args.runs)
    by_task: dict[str, list[Path]] = {}
    for model in sorted(args.models.glob("*.zip")):
        run = read_run_info(model)
        if run is None:
            raise SystemExit(f"{model} has no run record")
        directory = kept.get(tuple(run["command"]))
        if directory is None:
            raise SystemExit(
                f"no run in {args.runs} recorded the command of {model.name}: copy its run's "
                "run.json and evaluations.jsonl there"
            )
        # The students that see get their own picture: "<Task>-student.png".
        name = TASK_NAMES[variant(run["env_id"])["task"]]
        by_task.setdefault(f"{name}-student" if "student" in run else name, []).append(directory)
    for name in tqdm(sorted(by_task), desc="pictures", unit="picture"):
        out = args.out / f"{name}.png"
        plot_curves(by_task[name], out)
        print(f"{out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}: "
              f"{', '.join(d.name for d in by_task[name])}")  # fmt: skip


if __name__ == "__main__":
    main()
