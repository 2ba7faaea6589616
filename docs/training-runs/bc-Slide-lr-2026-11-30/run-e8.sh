#!/bin/sh
# recipe-both3e-4-e8.yml with --seed 0, then --seed 1, each evaluated on the test seeds 0-999
# (the package from the stop-75 tree).
set -e
cd /work/main
for s in 0 1; do
  PYTHONPATH=/work/pkg-75 .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/Slide-v0 \
    --conf /work/wt-75/docs/training-runs/bc-Slide-lr-2026-11-30/recipe-both3e-4-e8.yml \
    --out runs/bc-Slide-lr-e8-s$s --seed $s --eval-episodes 200 --quiet > /work/runs/bc-Slide-lr-e8-s$s.log 2>&1
  PYTHONPATH=/work/pkg-75 .venv/bin/panda-rapier eval --policy runs/bc-Slide-lr-e8-s$s/model.zip \
    --episodes 1000 --quiet > runs/bc-Slide-lr-e8-s$s/eval-test-seeds.txt 2>&1
  touch /work/runs/bc-Slide-lr-e8-s$s.done
done
