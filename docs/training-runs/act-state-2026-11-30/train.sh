#!/bin/sh
# ACT from state on 1,000 expert episodes (issue 61): the small configuration, no CVAE, learning
# rate 1e-4. The runs: train.sh PickAndPlace pnp-state-1000 act-pnp-state 20 and
# train.sh Lift lift-state-1000 act-lift-state 5 (TASK DATASET OUTPUT ACTIONS_ACTED_PER_CHUNK).
export PYTHONPATH=/work/pkg-b
B=/work/main/target/lerobot-venv/bin
exec $B/lerobot-train --dataset.repo_id=panda_rapier/$1-expert --dataset.root=/work/lr/$2 \
  --policy.type=act --policy.device=cpu --policy.push_to_hub=false --policy.pretrained_backbone_weights=null \
  --policy.dim_model=256 --policy.dim_feedforward=1024 --policy.n_heads=4 --policy.n_encoder_layers=2 \
  --policy.n_decoder_layers=1 --policy.chunk_size=20 --policy.n_action_steps=$4 --policy.use_vae=false \
  --policy.optimizer_lr=1e-4 --steps=6000 --batch_size=64 --log_freq=100 --save_freq=1000 \
  --output_dir=/work/lr/$3 --wandb.enable=false --num_workers=1 --seed=1000
