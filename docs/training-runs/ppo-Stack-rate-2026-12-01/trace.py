"""Where a Stack policy's hand and cube2 go: for one model zip, four seeded episodes (seeds
2,000,000-2,000,003, as milestones.py's first four) of the environment its run record names,
acted by the native network (deterministic actions), every 15th step and the last: the step,
the `stage` term, whether a cube is grasped, cube2's distance from the TCP and from its goal,
and cube2's height (m). With ``--actions`` instead, three episodes' steps 50 and 100: the
action (x, y, z, gripper), the TCP, the gripper's width, the cubes' centres and the reward.
Run from the repository's root:

    PYTHONPATH=$PKG .venv/bin/python docs/training-runs/ppo-Stack-rate-2026-12-01/trace.py \
        [--actions] runs/ppo-Stack-rate2/checkpoints/ckpt-4000000.zip
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from panda_rapier.agents.inference import PolicyNetwork
from panda_rapier.agents.model_file import read_run_info

FIRST_SEED = 2_000_000
EVERY = 15


def _load(path: str) -> tuple[gym.Env, Callable[[Any], np.ndarray]]:
    """The environment the run record names, and the network acting on its goal dicts."""
    run = read_run_info(path) or {}
    env = gym.make(run.get("env_id", "panda_rapier/StackDense-v0"), **(run.get("env_kwargs") or {}))
    return env, PolicyNetwork.from_zip(path).act


def actions(path: str, episodes: int = 3) -> None:
    env, act = _load(path)
    for seed in range(FIRST_SEED, FIRST_SEED + episodes):
        obs, _ = env.reset(seed=seed)
        for step in range(1, 101):
            action = act(obs)
            obs, reward, *_ = env.step(action)
            if step in (50, 100):
                o, g = obs["observation"], obs["achieved_goal"]
                tcp, width = o[18:21].round(3), o[24].round(3)
                cubes = ("cube1", g[:3].round(3), "cube2", g[3:].round(3))
                print(
                    seed,
                    step,
                    action.round(2),
                    "tcp",
                    tcp,
                    "w",
                    width,
                    *cubes,
                    "r",
                    round(float(reward), 2),
                )
    env.close()


def trace(path: str, episodes: int = 4) -> None:
    env, act = _load(path)
    for seed in range(FIRST_SEED, FIRST_SEED + episodes):
        obs, _ = env.reset(seed=seed)
        rows, step, done = [], 0, False
        while not done:
            obs, _, terminated, truncated, info = env.step(act(obs))
            step += 1
            done = terminated or truncated
            if step % EVERY == 0 or done:
                cube2 = obs["achieved_goal"][3:]
                rows.append(
                    (
                        step,
                        round(float(info["reward_stage"]), 1),
                        int(info["is_grasped"]),
                        round(float(np.linalg.norm(obs["observation"][54:57])), 3),
                        round(float(np.linalg.norm(cube2 - obs["desired_goal"][3:])), 3),
                        round(float(cube2[2]), 3),
                    )
                )
        print(seed, rows, flush=True)
    env.close()


if __name__ == "__main__":
    show_actions = "--actions" in sys.argv[1:]
    for path in [a for a in sys.argv[1:] if a != "--actions"]:
        print(path)
        (actions if show_actions else trace)(path)
