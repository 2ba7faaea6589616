#!/bin/sh
# One run of this record, from the repository's root: `run.sh NAME [--resume]` trains
# recipe-NAME.yml into runs/ppo-Stack-NAME (log: runs/ppo-Stack-NAME.log); PKG: a directory
# holding the package of this tree (with its native module) for PYTHONPATH. As run:
# `run.sh stage3` (stopped by hand after 5 M steps), `run.sh reach4` (stopped by hand after
# 2 M), `run.sh g95` (stopped by hand after 4 M), `run.sh curriculum` (stopped by hand after
# 3 M), then `run.sh carry8`.
set -e
# RECIPES: the directory of recipe-NAME.yml (this one's unless set; the next record's run.sh sets it).
d=${RECIPES:-$(dirname "$0")}
name=$1
shift
PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo ppo --env-id panda_rapier/StackDense-v0 \
  --conf $d/recipe-$name.yml --out runs/ppo-Stack-$name --seed 0 --eval-every 1000000 \
  --eval-episodes 200 --final best --checkpoint-every 1000000 --quiet "$@" \
  >> runs/ppo-Stack-$name.log 2>&1
