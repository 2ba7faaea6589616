"""Env-steps/s of PickObject and OpenDrawer beside PickAndPlace (issue 57's speed figures): the
native vector env with 64 environments on 2 threads, random actions, interleaved rounds (every
round measures every case once, in the same order), medians printed with their ratio to
pick-and-place. Cases: PickAndPlace-v0, PickObject-v0 drawing from the shipped set,
PickObject-v0 with only the mug (16 convex parts, the most any shipped object has), and
OpenDrawer-v0 with the drawer's joint in a multibody (default) and as an impulse joint.

    .venv/bin/python scripts/bench_pick_object.py [--rounds 5] [--steps 200]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from tqdm import tqdm

import panda_rapier
from panda_rapier import PandaVectorEnv

CASES: dict[str, dict[str, object]] = {
    "PickAndPlace-v0": {"task": "pick_and_place"},
    "PickObject-v0, the shipped set": {"task": "pick_object", "control_mode": "ee_pose"},
    "PickObject-v0, the mug only (16 parts)": {
        "task": {"name": "pick_object", "objects": ["mug"]},
        "control_mode": "ee_pose",
    },
    "OpenDrawer-v0, multibody joint": {"task": "open_drawer", "control_mode": "ee_pose"},
    "OpenDrawer-v0, impulse joint": {
        "task": {"name": "open_drawer", "joints": "impulse"},
        "control_mode": "ee_pose",
    },
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=200, help="vector steps per measurement")
    parser.add_argument("--num-envs", type=int, default=64)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    envs = {
        name: PandaVectorEnv(args.num_envs, num_threads=args.threads, **config)
        for name, config in CASES.items()
    }
    rng = np.random.default_rng(0)
    rates: dict[str, list[float]] = {name: [] for name in envs}
    for r in tqdm(range(args.rounds), desc="rounds", unit="round"):
        for name, env in envs.items():
            env.reset(seed=r)
            shape = (args.steps, *env.action_space.shape)
            actions = rng.uniform(-1.0, 1.0, shape).astype(np.float32)
            start = time.perf_counter()
            for action in actions:
                env.step(action)
            rates[name].append(args.num_envs * args.steps / (time.perf_counter() - start))
    base = statistics.median(rates["PickAndPlace-v0"])
    print(f"panda_rapier {panda_rapier.__version__}, {args.num_envs} envs, {args.threads} threads")
    for name, values in rates.items():
        median = statistics.median(values)
        rounds = ", ".join(f"{v:,.0f}" for v in values)
        print(f"{name:40s} {median:8,.0f} env-steps/s  {median / base:.2f}x  ({rounds})")


if __name__ == "__main__":
    main()
