#!/bin/sh
# One run of this record, from the repository's root: `run.sh NAME [--resume]` trains
# recipe-NAME.yml into runs/ppo-Stack-NAME (log: runs/ppo-Stack-NAME.log); PKG: a directory
# holding the package of this tree (with its native module) for PYTHONPATH. As run, one after
# another: `run.sh cur50` (stopped by hand after 4 M steps; its 4 M checkpoint copied to
# /work/cur50-4M.zip); the morning record's `run.sh hover20` again (stopped by hand after 2 M;
# its 2 M checkpoint copied to /work/hover20-2M.zip); `run.sh staged --init-from
# /work/hover20-2M.zip` (stopped by hand after 3 M); `run.sh cur25 --init-from
# /work/cur50-4M.zip`; `run.sh tight --init-from <cur25's 22 M checkpoint>` (cut off when the
# session ended; its checkpoints and measurements were lost with that machine).
set -e
# The night record's run.sh, with this record's recipes.
d=$(dirname "$0")
RECIPES=$d exec "$d/../ppo-Stack-stage-2026-12-01/run.sh" "$@"
