"""The robustness table of the shipped policies that see: each student evaluated on the
benchmark's first seeds with no visual randomisation, with each kind alone (camera, light,
colors, noise) and with all of them, side by side with one trained under randomisation
(``panda_rapier.tools.reporting.robustness_table``). Writes the markdown table into
``docs/guide/pixels.md`` between its markers and the evaluations to
``docs/robustness.json``; ``--table NAME`` writes another table of the page, between
``<!-- NAME: begin -->`` and ``<!-- NAME: end -->``.

    .venv/bin/python scripts/robustness_table.py [MODEL.zip ...] [--episodes 500]
        [--table NAME --json FILE]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from panda_rapier.tools.reporting import robustness_table

ROOT = Path(__file__).resolve().parents[1]
#: The table of the page that the script writes by default.
TABLE = "robustness table"


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
    parser.add_argument("--table", default=TABLE, help="the name in the page's markers")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args()
    begin, end = f"<!-- {args.table}: begin -->", f"<!-- {args.table}: end -->"
    table, records = robustness_table(args.models, args.episodes, progress=not args.quiet)
    text = args.doc.read_text()
    head, _, rest = text.partition(begin)
    _, found, tail = rest.partition(end)
    if not found:
        raise SystemExit(f"{args.doc} has no '{begin}' ... '{end}' markers")
    args.doc.write_text(f"{head}{begin}\n{table}{end}{tail}")
    args.json.write_text(
        json.dumps({"episodes": args.episodes, "evaluations": records}, indent=1) + "\n"
    )
    print(table)


if __name__ == "__main__":
    main()
