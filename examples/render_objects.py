"""Pictures of the shipped object set for the docs, drawn by the CPU renderer with the colours
their files give (``assets/objects/objects.mtl``).

    python examples/render_objects.py --out docs/objects.png

For each object of ``PickObject-v0``'s set, one seeded episode of its scripted expert: the
object where it starts (top row) and the step of the episode where the expert holds it highest
(bottom row), each from a camera aimed at the object. The same seed gives the same bytes.
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import gymnasium as gym
import numpy as np

import panda_rapier

# The PNG writer of the other rendering example (no imaging library needed).
_spec = importlib.util.spec_from_file_location(
    "render_scripted", Path(__file__).with_name("render_scripted.py")
)
assert _spec is not None and _spec.loader is not None
_render_scripted = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_render_scripted)
write_png = _render_scripted.write_png

OBJECTS = [
    "can",
    "bottle",
    "bowl",
    "mug",
    "banana",
    "tennis_ball",
    "block",
    "hammer",
    "screwdriver",
    "pear",
]


def object_stills(name: str, seed: int, size: int) -> tuple[np.ndarray, np.ndarray]:
    """The object at the start of an episode of `seed`, and where the expert holds it highest."""
    task = {"name": "pick_object", "objects": [name]}
    probe = gym.make("panda_rapier/PickObject-v0", task=task)
    obs, _ = probe.reset(seed=seed)
    start = obs["achieved_goal"].copy()
    policy = panda_rapier.ScriptedPolicy(probe)
    highest, step, held = start[2], 0, start
    for k in range(1, 100):
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, truncated, _ = probe.step(action)
        if obs["achieved_goal"][2] > highest:
            highest, step, held = obs["achieved_goal"][2], k, obs["achieved_goal"].copy()
        if terminated or truncated:
            break
    probe.close()

    def still(target: np.ndarray, steps: int, distance: float, elevation: float) -> np.ndarray:
        camera = {
            "target": [float(c) for c in target],
            "distance": distance,
            "azimuth": -150.0,
            "elevation": elevation,
            "fov": 45.0,
        }
        env = gym.make(
            "panda_rapier/PickObject-v0",
            task=task,
            render_mode="rgb_array",
            width=size,
            height=size,
            camera=camera,
        )
        obs, _ = env.reset(seed=seed)
        policy = panda_rapier.ScriptedPolicy(env)
        for _ in range(steps):
            action, _ = policy.predict(obs, deterministic=True)
            obs, *_ = env.step(action)
        frame = env.render()
        env.close()
        return frame

    return still(start, 0, 0.35, 30.0), still(held, step, 0.4, 5.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="a .png")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--size", type=int, default=200, help="each still's side (pixels)")
    args = parser.parse_args()
    from tqdm import tqdm

    stills = [object_stills(n, args.seed, args.size) for n in tqdm(OBJECTS, desc="objects")]
    rows = [np.concatenate([s[k] for s in stills], axis=1) for k in (0, 1)]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_png(args.out, np.concatenate(rows, axis=0))
    print(f"{len(OBJECTS)} objects rendered; wrote {args.out}")


if __name__ == "__main__":
    main()
