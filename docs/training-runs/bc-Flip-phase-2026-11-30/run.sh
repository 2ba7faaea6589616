#!/bin/sh
# This record's run (the package from the stop-74 tree).
set -e
cd /work/main
PYTHONPATH=/work/pkg-74 .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/Flip-v0 \
  --conf /work/wt-74/docs/training-runs/bc-Flip-phase-2026-11-30/recipe.yml \
  --out runs/bc-Flip-phase --seed 0 --eval-episodes 200 --quiet > /work/runs/bc-Flip-phase.log 2>&1
touch /work/runs/bc-Flip-phase.done
