"""rl-zoo3's run folders (``python -m rl_zoo3.train ... --eval-freq N``) read as data, so that
``panda-rapier curves`` can draw a run of another environment (panda-gym's, say) beside its
own."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import InvalidArgumentError

__all__ = ["is_zoo_run", "zoo_curve"]


def is_zoo_run(folder: Path) -> bool:
    """Whether ``folder`` is an rl-zoo3 run (its evaluations, and no ``panda-rapier train``
    run record)."""
    return (folder / "evaluations.npz").is_file() and not (folder / "run.json").is_file()


def _zoo_arguments(run: Path) -> dict[str, Any]:
    """The ``args.yml`` rl-zoo3 writes into a run folder (``RUN/ENV/args.yml``), read as data:
    its one Python tag (an ``OrderedDict`` as a list of pairs) becomes a dict, and nothing is
    constructed from any other tag."""
    import yaml

    class Loader(yaml.SafeLoader):
        pass

    def pairs(loader: yaml.SafeLoader, node: yaml.Node) -> dict[str, Any]:
        items = loader.construct_sequence(node, deep=True)  # type: ignore[arg-type]
        return {str(k): v for k, v in (items[0] if items else [])}

    Loader.add_constructor("tag:yaml.org,2002:python/object/apply:collections.OrderedDict",
                           pairs)  # fmt: skip
    found = sorted(run.glob("*/args.yml"))
    if not found:
        raise InvalidArgumentError(f"{run}: an rl-zoo3 run folder has ENV/args.yml; none found")
    try:
        data = yaml.load(found[0].read_text(), Loader=Loader)  # a SafeLoader: data only
    except yaml.YAMLError as error:
        raise InvalidArgumentError(f"{found[0]} is not rl-zoo3's args.yml: {error}") from error
    if not isinstance(data, dict):
        raise InvalidArgumentError(f"{found[0]} is not rl-zoo3's args.yml")
    return data


def zoo_curve(run: Path) -> tuple[str, list[dict[str, Any]]]:
    """An rl-zoo3 run folder (``python -m rl_zoo3.train ... --eval-freq N``) as a label and
    evaluation lines like ``evaluations.jsonl``'s: success rate (with its Wilson interval) of
    each evaluation in ``evaluations.npz``, and the wall time at that step from the training
    Monitor files (``*.monitor.csv``: episodes' lengths and end times; evaluations included)."""
    import csv

    import numpy as np

    from ..agents.evaluation import wilson_interval

    arguments = _zoo_arguments(run)
    with np.load(run / "evaluations.npz", allow_pickle=False) as data:
        if "successes" not in data.files:
            raise InvalidArgumentError(
                f"{run}/evaluations.npz has no successes: the environment reported no is_success"
            )
        steps, successes = data["timesteps"], data["successes"]
    # (env steps done, seconds) at each training episode's end; with n environments (one
    # Monitor file each, stepped together) n times one file's steps.
    monitors = sorted(run.glob("*.monitor.csv"))
    ends: list[tuple[int, float]] = []
    for monitor in monitors:
        done = 0
        for row in csv.DictReader(monitor.read_text().splitlines()[1:]):
            done += int(row["l"])
            ends.append((done * len(monitors), float(row["t"])))
    ends.sort()
    lines = []
    for step, outcomes in zip(steps.tolist(), successes, strict=True):
        wins, n = int(np.sum(outcomes)), int(np.size(outcomes))
        seconds = next((t for done, t in ends if done >= step), ends[-1][1] if ends else 0.0)
        lines.append({
            "env_steps": int(step), "wall_time_s": seconds, "success_rate": wins / max(n, 1),
            "success_ci95": list(wilson_interval(wins, n)), "placed_rate": 0.0,
        })  # fmt: skip
    label = (f"{arguments.get('algo', '?')} (rl-zoo3) {arguments.get('env', '?')}"
             f" (seed {arguments.get('seed', '?')})")  # fmt: skip
    return label, lines
