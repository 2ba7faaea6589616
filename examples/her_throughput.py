"""Training throughput of the TQC + HER recipe that solves panda-gym's pick-and-place
(rl-zoo3's hyperparameters: 3x512 networks, batch 2048, one gradient step per env step), on
panda-gym's PandaPickAndPlace-v3 (PyBullet) and on panda_rapier, measured on this machine.

    python examples/her_throughput.py --steps 300 --json her_throughput.json

It fills the replay buffer for ``learning_starts`` steps (not timed), then times ``--steps``
env steps with their gradient steps, with one torch thread. The JSON is a list of
``{"label", "env_steps_per_s"}`` for ``panda-rapier curves --reference``: what the same wall
time buys with that recipe. Needs the train extra; panda-gym for its row.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
import torch
from sb3_contrib import TQC
from stable_baselines3.common.callbacks import BaseCallback
from tqdm import tqdm

import panda_rapier  # noqa: F401  (registers the ids)
from panda_rapier.learning.recipes import load_recipe, model_kwargs


class Timer(BaseCallback):
    """Records when the timed part (after learning_starts) begins; ticks a progress bar."""

    def __init__(self, start_after: int, bar: tqdm) -> None:
        super().__init__()
        self.start_after = start_after
        self.bar = bar
        self.started: float | None = None

    def _on_step(self) -> bool:
        self.bar.update(1)
        if self.started is None and self.num_timesteps >= self.start_after:
            self.started = time.perf_counter()
        return True


def measure(label: str, env: gym.Env, steps: int, learning_starts: int) -> dict[str, float | str]:
    recipe = load_recipe("tqc", "panda_rapier/PickAndPlace-v0")
    kwargs = {**model_kwargs("tqc", recipe), "learning_starts": learning_starts}
    model = TQC(recipe["policy"], env, seed=0, device="cpu", **kwargs)
    with tqdm(total=learning_starts + steps, desc=label, unit="step") as bar:
        timer = Timer(learning_starts, bar)
        model.learn(learning_starts + steps, callback=timer)
    assert timer.started is not None
    elapsed = time.perf_counter() - timer.started
    return {"label": label, "env_steps_per_s": steps / elapsed, "timed_steps": steps}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300, help="timed env steps")
    parser.add_argument("--learning-starts", type=int, default=1000)
    parser.add_argument("--json", type=Path, default=Path("her_throughput.json"))
    parser.add_argument("--no-panda-gym", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(1)
    results = []
    if not args.no_panda_gym:
        import panda_gym  # noqa: F401

        env = gym.make("PandaPickAndPlace-v3")
        results.append(
            measure("panda-gym TQC+HER (rl-zoo3)", env, args.steps, args.learning_starts)
        )
    env = gym.make("panda_rapier/PickAndPlace-v0")
    results.append(
        measure("panda_rapier TQC+HER (same recipe)", env, args.steps, args.learning_starts)
    )
    for item in results:
        print(f"{item['label']}: {item['env_steps_per_s']:.2f} env-steps/s")
    args.json.write_text(json.dumps(results, indent=2))
    print(f"written to {args.json}")


if __name__ == "__main__":
    main()
