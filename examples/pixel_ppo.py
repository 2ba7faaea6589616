"""PPO from camera images: SB3's ``MultiInputPolicy`` (its NatureCNN on the image, the goals
beside it) on the native VecEnv with ``obs_mode="rgb"``, then a seeded evaluation.

    python examples/pixel_ppo.py --steps 200000 --out runs/pixel_ppo

The images are drawn by the VecEnv's Rust threads (the GIL released), one per environment
after every step. Prints training and evaluation throughput and the evaluation's success rate;
saves the model (``panda-rapier eval --policy OUT/model.zip --trust-model-file`` evaluates it
again: the image options are read off the model; a CNN runs on torch, so loading it unpickles
the file, hence the flag).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch
from stable_baselines3 import PPO

from panda_rapier.agents.evaluation import evaluate
from panda_rapier.registration import env_config
from panda_rapier.sb3 import make_vec_env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env-id", default="panda_rapier/ReachDense-v0")
    parser.add_argument("--steps", type=int, default=200_000, help="environment steps")
    parser.add_argument("--n-envs", type=int, default=16)
    # SB3's NatureCNN needs at least 36 pixels.
    parser.add_argument("--image-size", type=int, default=64)
    parser.add_argument("--eval-episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True, help="run directory")
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args()

    # One torch thread, the other core to the environments' thread.
    torch.set_num_threads(1)
    images = {"obs_mode": "rgb", "image_size": args.image_size}
    venv = make_vec_env(args.env_id, n_envs=args.n_envs, seed=args.seed, num_threads=1, **images)
    model = PPO(
        "MultiInputPolicy",
        venv,
        n_steps=max(8, 1024 // args.n_envs),
        batch_size=256,
        n_epochs=4,
        learning_rate=3e-4,
        gamma=0.95,
        seed=args.seed,
        device="cpu",
    )
    started = time.perf_counter()
    model.learn(args.steps, progress_bar=not args.no_progress)
    train_s = time.perf_counter() - started
    args.out.mkdir(parents=True, exist_ok=True)
    model.save(args.out / "model.zip")
    report = evaluate(
        model, env_config(args.env_id), args.eval_episodes, num_envs=16, first_seed=10_000,
        **images,
    )  # fmt: skip
    summary = report.summary()
    print(
        f"{args.env_id} from {args.image_size}px images: {model.num_timesteps} steps in "
        f"{train_s:.0f} s ({model.num_timesteps / train_s:.0f} env-steps/s with learning); "
        f"evaluation on {args.eval_episodes} seeded episodes: success "
        f"{summary['success_rate']:.3f}, mean return {summary['mean_return']:.2f}, "
        f"{summary['env_steps_per_s']:.0f} env-steps/s"
    )
    print(f"model saved to {args.out / 'model.zip'}")


if __name__ == "__main__":
    main()
