#!/bin/bash
# rl-zoo3's TQC+HER Reach recipe on panda-gym and on panda_rapier, same pipeline (gym.make, DummyVecEnv, VecNormalize).
cd /work/runs/zoo
export PYTHONPATH=/work/pg-site OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
for seed in $SEEDS; do
for env in $ENVS; do
  pkg=panda_gym; [[ $env == panda_rapier/* ]] && pkg=panda_rapier
  name=$(echo $env | tr / _)
  start=$(date +%s)
  /work/main/.venv/bin/python -m rl_zoo3.train --algo tqc --env $env --gym-packages $pkg -conf tqc-zoo.yml \
     --seed $seed --eval-freq 1000 --eval-episodes 50 --n-eval-envs 5 -f logs --vec-env dummy -P \
     > log-$name-$seed.txt 2>&1
  echo "$env seed $seed rc $? $(( $(date +%s) - start )) s" >> times.txt
done; done
