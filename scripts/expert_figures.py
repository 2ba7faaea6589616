"""The scripted expert's figures on every task in both action modes (sparse ids, default dynamic
arm, seeds 0-999), written to docs/expert-figures.json, which the task pages of the docs site
show (scripts/docs_hooks.py). Run after a change to the physics, a task or the expert:

    .venv/bin/python scripts/expert_figures.py [--episodes 1000] [--ids ID ...]
"""

from __future__ import annotations

import argparse
import datetime
import json
from pathlib import Path

from tqdm import tqdm

import panda_rapier
from panda_rapier.agents.evaluation import evaluate
from panda_rapier.registration import env_config

OUT = Path(__file__).resolve().parents[1] / "docs" / "expert-figures.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument(
        "--ids",
        nargs="+",
        metavar="ID",
        help="only these ids (the others keep their recorded figures), e.g. a new task's",
    )
    args = parser.parse_args()
    ids = args.ids or [i for i in panda_rapier.ENV_IDS if not i.endswith("Dense-v0")]
    figures: dict[str, dict[str, float | int | str]] = {}
    old: dict[str, object] = {}
    if args.ids:
        old = json.loads(OUT.read_text())
        figures = dict(old["figures"])  # type: ignore[call-overload]
    for env_id in tqdm(ids, desc="ids", unit="id"):
        config = env_config(env_id)
        report = evaluate(panda_rapier.ScriptedPolicy(config), config, args.episodes)
        figures[env_id] = {
            "episodes": report.num_episodes,
            "success_rate": round(report.success_rate, 4),
            "placed_rate": round(report.placed_rate, 4),
            "mean_steps_to_success": round(report.mean_steps_to_success or 0.0, 1),
            "max_episode_steps": int(config["max_episode_steps"]),
        }
    command = f".venv/bin/python scripts/expert_figures.py --episodes {args.episodes}"
    today = datetime.date.today().isoformat()
    record: dict[str, object] = {
        "what": "the scripted expert (panda_rapier.ScriptedPolicy), seeds 0 to episodes-1, "
        "default dynamic arm, sparse reward ids",
        "command": command,
        "date": today,
        "panda_rapier": panda_rapier.__version__,
    }
    if args.ids:
        # The full run's record stays; the partial runs are listed after it.
        record = {k: v for k, v in old.items() if k != "figures"}
        updates = list(record.get("updates", []))  # type: ignore[call-overload]
        updates.append(
            {"ids": args.ids, "command": f"{command} --ids {' '.join(args.ids)}", "date": today}
        )
        record["updates"] = updates
    record["figures"] = {i: figures[i] for i in panda_rapier.ENV_IDS if i in figures}
    OUT.write_text(json.dumps(record, indent=1) + "\n")
    print(f"written {OUT}")


if __name__ == "__main__":
    main()
