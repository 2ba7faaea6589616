#!/bin/sh
# recipe-joints-e8.yml with --seed 0, evaluated on the test seeds 0-999 (the package from the
# stop-75 tree).
set -e
cd /work/main
PYTHONPATH=/work/pkg-75 .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/SlideJoints-v0 \
  --conf /work/wt-75/docs/training-runs/bc-Slide-lr-2026-11-30/recipe-joints-e8.yml \
  --out runs/bc-SlideJoints-lr-e8 --seed 0 --eval-episodes 200 --quiet > /work/runs/bc-SlideJoints-lr-e8.log 2>&1
PYTHONPATH=/work/pkg-75 .venv/bin/panda-rapier eval --policy runs/bc-SlideJoints-lr-e8/model.zip \
  --episodes 1000 --quiet > runs/bc-SlideJoints-lr-e8/eval-test-seeds.txt 2>&1
touch /work/runs/bc-SlideJoints-lr-e8.done
