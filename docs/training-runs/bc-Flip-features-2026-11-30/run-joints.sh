#!/bin/sh
# From the repository's root; PKG: a directory holding the package of this tree for PYTHONPATH.
# The joint-space expert is evaluated on the test seeds (0-999) first, for the bar.
set -e
d=$(dirname "$0")
PYTHONPATH=$PKG .venv/bin/panda-rapier eval --policy scripted --env panda_rapier/FlipJoints-v0 \
  --episodes 1000 --quiet > runs/fj-expert.txt 2>&1
PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/FlipJoints-v0 \
  --conf $d/recipe-flipjoints-features.yml --out runs/bc-FlipJoints-features --seed 0 \
  --eval-episodes 200 --quiet > runs/bc-FlipJoints-features.log 2>&1
