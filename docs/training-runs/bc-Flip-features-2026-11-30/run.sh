#!/bin/sh
# The runs of this record, one after another, from the repository's root; PKG: a directory
# holding the package of this tree (with its native module) for PYTHONPATH. As run:
# `run.sh flip-keep12` (its output then named runs/bc-n77-flip-keep12-s0, stopped by hand before
# round 12), then `run.sh flip-features`.
set -e
d=$(dirname "$0")
for run in "$@"; do
  PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/Flip-v0 \
    --conf $d/recipe-$run.yml --out runs/bc-Flip-$run --seed 0 --eval-episodes 200 --quiet \
    > runs/bc-Flip-$run.log 2>&1
done
