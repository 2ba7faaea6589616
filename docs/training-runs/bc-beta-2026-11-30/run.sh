#!/bin/sh
# The runs of this record, one after the other, run from the repository's root (runs/ and
# .venv there; the recipes beside this script); PKG is the
# package of the stop-76 tree (its Python files with the stop-75 native module). Only
# validation (200 episodes on the validation seeds, in each run's evaluations.jsonl) is read
# to compare recipes; a run is evaluated on the test seeds 0-999 only if it is a candidate
# to ship.
set -e
d=$(dirname "$0")
for run in "joints SlideJoints 0" "slide Slide 1"; do
  set -- $run
  PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/$2-v0 \
    --conf $d/recipe-$1.yml --out runs/bc-beta-$1-s$3 --seed $3 --eval-episodes 200 --quiet \
    > runs/bc-beta-$1-s$3.log 2>&1
done
touch runs/bc-beta.done
