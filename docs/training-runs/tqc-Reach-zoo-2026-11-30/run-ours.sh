#!/bin/bash
# panda-rapier train with the package's tqc.yml (rl-zoo3's PandaReach-v1 entry) on Reach-v0.
cd /work/runs/zoo
export PYTHONPATH=/work/pkg-73
for seed in $SEEDS; do
  start=$(date +%s)
  /work/main/.venv/bin/python -m panda_rapier.cli train --algo tqc --env-id panda_rapier/Reach-v0 \
    --out train-Reach-$seed --seed $seed --eval-every 1000 --eval-episodes 50 --quiet > log-train-Reach-$seed.txt 2>&1
  echo "panda-rapier train Reach-v0 seed $seed rc $? $(( $(date +%s) - start )) s" >> times.txt
done
