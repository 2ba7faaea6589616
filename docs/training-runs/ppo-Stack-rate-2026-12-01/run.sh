#!/bin/sh
# One run of this record, from the repository's root: `run.sh NAME [--resume]` trains
# recipe-NAME.yml into runs/ppo-Stack-NAME (log: runs/ppo-Stack-NAME.log); PKG: a directory
# holding the package of this tree (with its native module) for PYTHONPATH. As run:
# `run.sh rate2` (stopped by hand after 6 M steps), `run.sh std25` (stopped by hand after 4 M;
# two builds, about 2 minutes, ran beside its fourth million), `run.sh hover` (stopped by hand
# after 2 M), `run.sh hover20` (stopped by hand after 6 M; its 6 M checkpoint copied to
# /work/hover20-6M.zip), `run.sh hover-reach4 --init-from /work/hover20-6M.zip` (stopped by
# hand after 2 M), then `run.sh hover20 --resume` three times (from its 6, 15 and 17 M
# checkpoints; stopped by hand after 15, 17 and 19 M).
set -e
# The previous record's run.sh, with this record's recipes.
d=$(dirname "$0")
RECIPES=$d exec "$d/../ppo-Stack-stage-2026-12-01/run.sh" "$@"
