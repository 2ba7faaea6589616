#!/bin/sh
# recipe-512.yml again with --seed 1 (another initialisation, and demonstration and DAgger episodes from
# TRAIN_FIRST_SEED + TRAIN_SEED_STRIDE) and its test-seed evaluation; the package as installed by scripts/test.
set -e
cd /work/main
.venv/bin/panda-rapier train --algo bc --env-id panda_rapier/Slide-v0 \
  --conf /work/wt-74/docs/training-runs/bc-Slide-phase-2026-11-30/recipe-512.yml \
  --out runs/bc-Slide-phase-512-seed1 --seed 1 --eval-episodes 200 --quiet > /work/runs/bc-Slide-phase-512-seed1.log 2>&1
.venv/bin/panda-rapier eval --policy runs/bc-Slide-phase-512-seed1/model.zip --episodes 1000 --quiet > /work/runs/eval-Slide-phase-512-seed1.txt 2>&1
touch /work/runs/bc-Slide-phase-512-seed1.done
