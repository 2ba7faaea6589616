"""What the observation cameras see: a strip of image observations for the README.

    python examples/pixel_observations.py --out docs/pixels.png

One seeded pick-and-place episode of the scripted policy with ``obs_mode="state+rgb"`` and
the two cameras of ``panda_rapier.pixels`` (``DEFAULT_CAMERA`` as ``rgb``, ``SIDE_CAMERA`` as
``side``) at ``--size`` pixels; the images at a few steps, enlarged ``--zoom`` times without
smoothing so single pixels stay visible, front camera above, side camera below.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np
from render_scripted import write_png

import panda_rapier
from panda_rapier.pixels import DEFAULT_CAMERA, SIDE_CAMERA


def observation_strip(size: int, steps: list[int], seed: int = 0) -> np.ndarray:
    """The cameras' images at ``steps`` of one scripted episode, side by side."""
    env = gym.make(
        "panda_rapier/PickAndPlace-v0",
        obs_mode="state+rgb",
        image_size=size,
        cameras={"rgb": DEFAULT_CAMERA, "side": SIDE_CAMERA},
    )
    obs, _ = env.reset(seed=seed)
    policy = panda_rapier.ScriptedPolicy(env)
    columns = []
    for step in range(max(steps) + 1):
        if step in steps:
            columns.append(np.concatenate([obs["rgb"], obs["side"]], axis=0))
        obs, *_ = env.step(policy.predict(obs)[0])
    env.close()
    gap = np.full((2 * size, 2, 3), 255, dtype=np.uint8)
    parts: list[np.ndarray] = []
    for column in columns:
        parts += [column, gap]
    return np.concatenate(parts[:-1], axis=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="PNG file")
    parser.add_argument("--size", type=int, default=84, help="image size (pixels)")
    parser.add_argument("--zoom", type=int, default=3)
    parser.add_argument("--steps", type=int, nargs="+", default=[0, 15, 25, 40])
    args = parser.parse_args()
    strip = observation_strip(args.size, args.steps)
    strip = strip.repeat(args.zoom, axis=0).repeat(args.zoom, axis=1)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_png(args.out, strip)
    print(f"{strip.shape[1]}x{strip.shape[0]} written to {args.out}")


if __name__ == "__main__":
    main()
