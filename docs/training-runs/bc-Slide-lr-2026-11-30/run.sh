#!/bin/sh
# The runs of this record, one after the other, each then evaluated on the test seeds 0-999
# (the package from the stop-75 tree).
set -e
cd /work/main
for r in dagger3e-4 both3e-4; do
  PYTHONPATH=/work/pkg-75 .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/Slide-v0 \
    --conf /work/wt-75/docs/training-runs/bc-Slide-lr-2026-11-30/recipe-$r.yml \
    --out runs/bc-Slide-lr-$r --seed 0 --eval-episodes 200 --quiet > /work/runs/bc-Slide-lr-$r.log 2>&1
  PYTHONPATH=/work/pkg-75 .venv/bin/panda-rapier eval --policy runs/bc-Slide-lr-$r/model.zip \
    --episodes 1000 --quiet > runs/bc-Slide-lr-$r/eval-test-seeds.txt 2>&1
done
touch /work/runs/bc-Slide-lr.done
