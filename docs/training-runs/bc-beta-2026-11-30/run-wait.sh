#!/bin/sh
# recipe-joints-wait.yml with --seed 0, run from the repository's root (as run.sh).
set -e
d=$(dirname "$0")
PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/SlideJoints-v0 \
  --conf $d/recipe-joints-wait.yml --out runs/bc-wait-joints-s0 --seed 0 --eval-episodes 200 \
  --quiet > runs/bc-wait-joints-s0.log 2>&1
touch runs/bc-wait.done
