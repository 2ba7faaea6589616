#!/bin/sh
# The Lift ACT (final checkpoint) on seeds 0-999: panda-rapier eval, then lerobot-eval.
export PYTHONPATH=/work/pkg-b
B=/work/main/target/lerobot-venv/bin
P=/work/lr/act-lift-state/checkpoints/last/pretrained_model
date
$B/python -m panda_rapier.cli eval --policy $P --episodes 1000 --num-envs 50 --seed 0 --threads 1 --quiet --json /work/lr/eval-lift-ours.json 2>&1 | grep -E "success|throughput"
date
OMP_NUM_THREADS=1 $B/lerobot-eval --policy.path=$P --env.type=panda_rapier --env.task=Lift-v0 --env.environment_state=true --eval.n_episodes=1000 --eval.batch_size=50 --policy.device=cpu --seed=0 --output_dir=/work/lr/eval-lift-lerobot 2>&1 | grep -oE "'pc_success': [0-9.]+|'eval_s': [0-9.]+"
date
