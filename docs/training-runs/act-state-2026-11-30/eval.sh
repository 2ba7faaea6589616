#!/bin/sh
# The PickAndPlace ACT (6,000 steps) on seeds 0-999: panda-rapier eval, then lerobot-eval.
export PYTHONPATH=/work/pkg-b
B=/work/main/target/lerobot-venv/bin
P=/work/lr/act-pnp-state/checkpoints/006000/pretrained_model
date
/usr/bin/time -v $B/python -m panda_rapier.cli eval --policy $P --episodes 1000 --num-envs 50 --seed 0 --threads 1 --quiet --json /work/lr/eval-pnp-6000-ours.json 2>&1 | grep -E "success|throughput|Elapsed"
date
OMP_NUM_THREADS=1 /usr/bin/time -v $B/lerobot-eval --policy.path=$P --env.type=panda_rapier --env.task=PickAndPlace-v0 --env.environment_state=true --eval.n_episodes=1000 --eval.batch_size=50 --policy.device=cpu --seed=0 --output_dir=/work/lr/eval-pnp-6000-lerobot 2>&1 | grep -E "pc_success|Elapsed|avg_sum_reward|Error"
date
