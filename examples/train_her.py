"""Train TQC (or SAC) with hindsight experience replay on PickAndPlace (sparse reward).

    python examples/train_her.py --timesteps 1000000 --out runs/tqc_her

The hyperparameters are rl-baselines3-zoo's for panda-gym's PandaPickAndPlace (TQC + HER,
future strategy with 4 goals, 3x512 networks, batch 2048, gamma 0.95, lr 1e-3, tau 0.05).
Shows a progress bar, logs to TensorBoard (``rollout/success_rate`` among others), saves
checkpoints and the final model (with its replay buffer) to ``--out``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from stable_baselines3 import SAC, HerReplayBuffer
from stable_baselines3.common.callbacks import CheckpointCallback

from panda_rapier.sb3 import make_vec_env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env-id", default="panda_rapier/PickAndPlace-v0")
    parser.add_argument("--algo", choices=["tqc", "sac"], default="tqc")
    parser.add_argument("--timesteps", type=int, default=1_000_000)
    parser.add_argument("--n-envs", type=int, default=4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--learning-starts", type=int, default=1000)
    parser.add_argument("--out", type=Path, default=Path("runs/tqc_her"))
    parser.add_argument(
        "--small", action="store_true", help="64x64 networks, batch 256 (smoke runs)"
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    args = parser.parse_args()

    if args.algo == "tqc":
        from sb3_contrib import TQC as algorithm
    else:
        algorithm = SAC
    env = make_vec_env(args.env_id, n_envs=args.n_envs, seed=args.seed)
    dense = env.config["reward_type"] == "dense"
    model = algorithm(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        # The dense reward is recomputed from the step infos, which the buffer must then keep.
        replay_buffer_kwargs={
            "goal_selection_strategy": "future",
            "n_sampled_goal": 4,
            "copy_info_dict": dense,
        },
        learning_starts=args.learning_starts,
        buffer_size=1_000_000,
        batch_size=256 if args.small else 2048,
        gamma=0.95,
        learning_rate=1e-3,
        tau=0.05,
        policy_kwargs={"net_arch": [64, 64] if args.small else [512, 512, 512]},
        seed=args.seed,
        device="cpu",
        tensorboard_log=str(args.out / "tensorboard"),
        verbose=0,
    )
    checkpoints = CheckpointCallback(
        save_freq=max(1, 100_000 // args.n_envs),
        save_path=str(args.out / "checkpoints"),
        name_prefix=args.algo,
    )
    model.learn(args.timesteps, callback=checkpoints, progress_bar=not args.no_progress)
    path = args.out / "model.zip"
    model.save(path)
    (args.out / "run.json").write_text(json.dumps({"algo": args.algo, "env_id": args.env_id}))
    print(f"saved {path} after {model.num_timesteps} steps")


if __name__ == "__main__":
    main()
