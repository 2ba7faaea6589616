#!/bin/sh
# The joint-control run of this record and its test-seed evaluation (the package from the stop-74 tree).
set -e
cd /work/main
PYTHONPATH=/work/pkg-74 .venv/bin/panda-rapier train --algo bc --env-id panda_rapier/SlideJoints-v0 \
  --conf /work/wt-74/docs/training-runs/bc-Slide-phase-2026-11-30/recipe-512-joints.yml \
  --out runs/bc-SlideJoints-phase-512 --seed 0 --eval-episodes 200 --quiet > /work/runs/bc-SlideJoints-phase-512.log 2>&1
PYTHONPATH=/work/pkg-74 .venv/bin/panda-rapier eval --policy runs/bc-SlideJoints-phase-512/model.zip --episodes 1000 --quiet > /work/runs/eval-SlideJoints-phase-512.txt 2>&1
PYTHONPATH=/work/pkg-74 .venv/bin/panda-rapier eval --policy scripted --env panda_rapier/SlideJoints-v0 --episodes 1000 --quiet > /work/runs/eval-SlideJoints-scripted.txt 2>&1
PYTHONPATH=/work/pkg-74 .venv/bin/panda-rapier eval --policy scripted --env panda_rapier/Slide-v0 --episodes 1000 --quiet > /work/runs/eval-Slide-scripted.txt 2>&1
touch /work/runs/bc-SlideJoints-phase-512.done
