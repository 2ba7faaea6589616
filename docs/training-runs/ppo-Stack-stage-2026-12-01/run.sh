#!/bin/sh
# The run of this record, from the repository's root; PKG: a directory holding the package of
# this tree (with its native module) for PYTHONPATH. Resumable: `run.sh --resume` continues from
# the last checkpoint.
set -e
d=$(dirname "$0")
PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo ppo --env-id panda_rapier/StackDense-v0 \
  --conf $d/recipe.yml --out runs/ppo-Stack-stage --seed 0 --eval-every 1000000 \
  --eval-episodes 200 --final best --checkpoint-every 1000000 --quiet "$@" \
  >> runs/ppo-Stack-stage.log 2>&1
