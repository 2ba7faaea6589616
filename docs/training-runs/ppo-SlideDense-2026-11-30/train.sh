#!/bin/bash
# Slide from scratch (PPO, dense reward), first run: stopped at 60 minutes of wall time.
cd /work/wt-73
timeout 3700 /work/main/.venv/bin/panda-rapier train --algo ppo --env-id panda_rapier/SlideDense-v0 \
  --conf docs/training-runs/ppo-SlideDense-2026-11-30/recipe.yml --out /work/runs/ppo-SlideDense \
  --checkpoint-every 1000000 --quiet > /work/runs/ppo-SlideDense.log 2>&1
echo "rc $?" >> /work/runs/ppo-SlideDense.log
