#!/bin/sh
# The second queue of this record (after run.sh's SlideJoints run; its Slide run had died when
# the package's native module under it was overwritten, and is repeated here), run from the
# repository's root as run.sh; PKG: the package of the stop-76 tree with phase_keep.
set -e
d=$(dirname "$0")
for run in "joints-keep SlideJoints 0" "slide Slide 1"; do
  set -- $run
  PYTHONPATH=$PKG .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/$2-v0 \
    --conf $d/recipe-$1.yml --out runs/bc-beta-$1-s$3 --seed $3 --eval-episodes 200 --quiet \
    > runs/bc-beta-$1-s$3.log 2>&1
done
touch runs/bc-beta-2.done
