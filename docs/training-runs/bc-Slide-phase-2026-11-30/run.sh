#!/bin/sh
# The two runs of this record, one after the other (the package from the stop-74 tree).
set -e
cd /work/main
for w in 256 512; do
  PYTHONPATH=/work/pkg-74 .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/Slide-v0 \
    --conf /work/wt-74/docs/training-runs/bc-Slide-phase-2026-11-30/recipe-$w.yml \
    --out runs/bc-Slide-phase-$w --seed 0 --eval-episodes 200 --quiet > /work/runs/bc-Slide-phase-$w.log 2>&1
done
touch /work/runs/bc-Slide-phase.done
