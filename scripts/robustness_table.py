"""The robustness table of the shipped policies that see: each student evaluated on the
benchmark's first seeds with no visual randomisation, with each kind alone (camera, light,
colors, noise) and with all of them, side by side with one trained under randomisation
(``panda_rapier.tools.reporting.robustness_table``). Writes the markdown table into
``docs/guide/pixels.md`` between its markers and the evaluations to
``docs/robustness.json``.

    .venv/bin/python scripts/robustness_table.py [MODEL.zip ...] [--episodes 500]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from panda_rapier.tools.reporting import robustness_table

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- robustness table: begin -->", "<!-- robustness table: end -->"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "models",
        type=Path,
        nargs="*",
        default=sorted((ROOT / "models").glob("student-*PickAndPlace-v0.zip")),
    )
    parser.add_argument("--episodes", type=int, default=500)
    parser.add_argument("--doc", type=Path, default=ROOT / "docs" / "guide" / "pixels.md")
    parser.add_argument("--json", type=Path, default=ROOT / "docs" / "robustness.json")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args()
    table, records = robustness_table(args.models, args.episodes, progress=not args.quiet)
    text = args.doc.read_text()
    head, _, rest = text.partition(BEGIN)
    _, found, tail = rest.partition(END)
    if not found:
        raise SystemExit(f"{args.doc} has no '{BEGIN}' ... '{END}' markers")
    args.doc.write_text(f"{head}{BEGIN}\n{table}{END}{tail}")
    args.json.write_text(
        json.dumps({"episodes": args.episodes, "evaluations": records}, indent=1) + "\n"
    )
    print(table)


if __name__ == "__main__":
    main()
