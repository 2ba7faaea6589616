#!/bin/sh
# One run of this record, from the repository's root: `run.sh NAME [--resume]` trains
# recipe-NAME.yml into runs/ppo-Stack-NAME (log: runs/ppo-Stack-NAME.log); PKG: a directory
# holding the package of this tree (with its native module) for PYTHONPATH. As run:
# `run.sh rate2` (stopped by hand after 6 M steps), `run.sh std25` (stopped by hand after 4 M;
# two builds, about 2 minutes, ran beside its fourth million), `run.sh hover` (stopped by hand
# after 2 M), `run.sh hover20` (stopped by hand after 6 M; its 6 M checkpoint copied to
# /work/hover20-6M.zip), `run.sh hover-reach4 --init-from /work/hover20-6M.zip` (stopped by
# hand after 2 M), then `run.sh hover20 --resume` (from its 6 M checkpoint).
set -e
d=$(dirname "$0")
name=$1
shift
PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo ppo --env-id panda_rapier/StackDense-v0 \
  --conf $d/recipe-$name.yml --out runs/ppo-Stack-$name --seed 0 --eval-every 1000000 \
  --eval-episodes 200 --final best --checkpoint-every 1000000 --quiet "$@" \
  >> runs/ppo-Stack-$name.log 2>&1
