#!/bin/sh
# recipe-joints-keep12.yml with --seed 0, run from the repository's root as run.sh.
set -e
d=$(dirname "$0")
PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/SlideJoints-v0 \
  --conf $d/recipe-joints-keep12.yml --out runs/bc-beta-joints-keep12-s0 --seed 0 \
  --eval-episodes 200 --quiet > runs/bc-beta-joints-keep12-s0.log 2>&1
touch runs/bc-beta-3.done
