#!/bin/sh
# The third run of this record and its test-seed evaluation (the package from the stop-74 tree).
set -e
cd /work/main
PYTHONPATH=/work/pkg-74 .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/Slide-v0 \
  --conf /work/wt-74/docs/training-runs/bc-Slide-phase-2026-11-30/recipe-512-final30.yml \
  --out runs/bc-Slide-phase-512-final30 --seed 0 --eval-episodes 200 --quiet > /work/runs/bc-Slide-phase-512-final30.log 2>&1
PYTHONPATH=/work/pkg-74 .venv/bin/panda-rapier eval --policy runs/bc-Slide-phase-512-final30/model.zip --episodes 1000 --quiet > /work/runs/eval-Slide-phase-512-final30.txt 2>&1
touch /work/runs/bc-Slide-phase-512-final30.done
