"""Train PPO on the native vector environment (dense reward).

    python examples/train_ppo.py --timesteps 1000000 --n-envs 32 --out runs/ppo

Shows a progress bar, logs to TensorBoard (``tensorboard --logdir runs``: episode return,
length and ``rollout/success_rate``), saves checkpoints and the final model to ``--out``;
evaluate it with ``panda-rapier eval --policy runs/.../model.zip``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import CheckpointCallback

from panda_rapier.sb3 import make_vec_env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env-id", default="panda_rapier/PickAndPlaceDense-v0")
    parser.add_argument("--timesteps", type=int, default=1_000_000)
    parser.add_argument("--n-envs", type=int, default=32)
    parser.add_argument("--num-threads", type=int, default=None)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("runs/ppo"))
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    args = parser.parse_args()

    env = make_vec_env(
        args.env_id, n_envs=args.n_envs, seed=args.seed, num_threads=args.num_threads
    )
    n_steps = max(64, 2048 // args.n_envs)
    model = PPO(
        "MultiInputPolicy",
        env,
        n_steps=n_steps,
        batch_size=min(256, n_steps * args.n_envs),
        gamma=0.98,
        seed=args.seed,
        device="cpu",
        tensorboard_log=str(args.out / "tensorboard"),
        verbose=0,
    )
    checkpoints = CheckpointCallback(
        save_freq=max(1, 100_000 // args.n_envs),
        save_path=str(args.out / "checkpoints"),
        name_prefix="ppo",
    )
    model.learn(args.timesteps, callback=checkpoints, progress_bar=not args.no_progress)
    path = args.out / "model.zip"
    model.save(path)
    (args.out / "run.json").write_text(json.dumps({"algo": "ppo", "env_id": args.env_id}))
    print(f"saved {path} after {model.num_timesteps} steps")


if __name__ == "__main__":
    main()
