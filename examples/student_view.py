"""What a policy that sees gets, next to what a person sees: a picture for the README.

    python examples/student_view.py --policy models/student-PickAndPlace-v0.zip --seed 2 \\
        --steps 0 10 18 26 40 --out docs/student-view.png

One seeded episode of a student (a model trained by ``panda-rapier train --algo bc`` on
``obs_mode="proprio+rgb"``, loaded by data: no ``--trust-model-file``) in the environment
recorded with it. Top row: the scene as ``render()`` draws it for a person (with the goal
marker); bottom row: the student's camera image at those steps, enlarged without smoothing
to the same height, so single pixels stay visible. Prints the episode's outcome.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np
from render_scripted import write_png

from panda_rapier.agents.student_model import load_student


def student_view(policy: Path, steps: list[int], seed: int, size: int) -> tuple[np.ndarray, bool]:
    """The person's and the student's pictures at ``steps`` of one episode, and whether the
    episode succeeded."""
    student = load_student(policy)
    run = student.run
    env = gym.make(run["env_id"], **run["env_kwargs"], render_mode="rgb_array", width=size,
                   height=size)  # fmt: skip
    obs, _ = env.reset(seed=seed)
    top, bottom, success = [], [], False
    for step in range(max(steps) + 1):
        if step in steps:
            image = obs["rgb"]
            zoom = max(1, size // image.shape[0])
            big = image.repeat(zoom, axis=0).repeat(zoom, axis=1)
            pad = np.full((size, size, 3), 255, dtype=np.uint8)
            pad[: big.shape[0], : big.shape[1]] = big[:size, :size]
            top.append(env.render())
            bottom.append(pad)
        action, _ = student.predict(obs, deterministic=True)
        obs, _, terminated, truncated, info = env.step(action)
        success = success or bool(info.get("is_success", False))
        if terminated or truncated:
            break
    env.close()
    gap = np.full((size, 4, 3), 255, dtype=np.uint8)

    def row(images: list[np.ndarray]) -> np.ndarray:
        parts: list[np.ndarray] = []
        for image in images:
            parts += [image, gap]
        return np.concatenate(parts[:-1], axis=1)

    first, second = row(top), row(bottom)
    between = np.full((4, first.shape[1], 3), 255, dtype=np.uint8)
    return np.concatenate([first, between, second], axis=0), success


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", type=Path, required=True, help="a student's model zip")
    parser.add_argument("--out", type=Path, required=True, help="PNG file")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--size", type=int, default=252, help="height of each picture (pixels)")
    parser.add_argument("--steps", type=int, nargs="+", default=[0, 12, 22, 34, 50])
    args = parser.parse_args()
    picture, success = student_view(args.policy, args.steps, args.seed, args.size)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_png(args.out, picture)
    print(f"{picture.shape[1]}x{picture.shape[0]} written to {args.out}; episode seed "
          f"{args.seed}: {'success' if success else 'no success'}")  # fmt: skip


if __name__ == "__main__":
    main()
