"""Would a Stack policy's cube2 stay on the stack if it were let go? For each model zip given,
EPISODES seeded episodes (seeds from 2,000,000, as the night record's milestones.py) starting
with cube1 on its goal, acted by the native network (deterministic actions) until cube2 first
comes within WITHIN metres of its goal with cube1 let go; from that step on the hand is made to
let go: SETTLE steps of standing still with the gripper closed (0 unless `--settle` says), then
OPEN_STEPS steps of standing still with the gripper opening, then up with the gripper open to
the episode's end. `--gain G` scales the policy's hand actions by G (1 unless said) while cube2
is within NEAR of its goal with cube1 let go: would a gentler hand near the stack do? Printed:
the share of episodes that reached that moment, the median speed of the hand then (cm/s; the
scripted expert lets go with the hand still), and of those episodes the share placed and
successful at the end. Run from the repository's root:

    .venv/bin/python docs/training-runs/ppo-Stack-tight-2026-12-02/release.py \
        [--within 0.02] [--settle 5] [--gain 0.3] runs/ppo-Stack-still/ckpt-4000000.zip [...]
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from typing import Any

import gymnasium as gym
import numpy as np

from panda_rapier.agents.inference import PolicyNetwork
from panda_rapier.agents.model_file import read_run_info
from panda_rapier.policy import observation_rows

EPISODES = 200
ENVS = 50
FIRST_SEED = 2_000_000
OPEN_STEPS = 10
NEAR = 0.03
# Action: hand displacement x, y, z, then the gripper (+1 opens it).
STAND_CLOSED = np.array([0.0, 0.0, 0.0, -1.0], dtype=np.float32)
STAND_OPEN = np.array([0.0, 0.0, 0.0, 1.0], dtype=np.float32)
UP_OPEN = np.array([0.0, 0.0, 1.0, 1.0], dtype=np.float32)


def on_goal(path: str) -> tuple[str, dict[str, Any], PolicyNetwork]:
    """The environment id and options the model's run record names, with every episode starting
    with cube1 on its goal, and the model's native network."""
    run = read_run_info(path) or {}
    options = dict(run.get("env_kwargs") or {})
    options["task"] = {"name": "stack", **options.get("task", {}), "cube1_on_goal_probability": 1.0}
    return run.get("env_id", "panda_rapier/StackDense-v0"), options, PolicyNetwork.from_zip(path)


def batches(env_id: str, options: dict[str, Any]) -> Iterator[tuple[int, Any, dict[str, Any]]]:
    """The EPISODES seeded episodes, ENVS at a time: the first one's index, the vector env (closed
    after its batch) and its first observations."""
    for first in range(0, EPISODES, ENVS):
        envs = gym.make_vec(env_id, num_envs=ENVS, vectorization_mode="vector_entry_point",
                            autoreset_mode="disabled", **options)  # fmt: skip
        obs, _ = envs.reset(seed=[FIRST_SEED + first + i for i in range(ENVS)])
        yield first, envs, obs
        envs.close()


def release(path: str, within: float, settle: int = 0, gain: float = 1.0) -> dict[str, float]:
    env_id, options, policy = on_goal(path)
    forced = np.zeros(EPISODES, dtype=bool)
    placed = np.zeros(EPISODES, dtype=bool)
    success = np.zeros(EPISODES, dtype=bool)
    speed = np.full(EPISODES, np.nan)
    for first, envs, obs in batches(env_id, options):
        tcp_velocity = envs.schema.slot("tcp_velocity")
        done = np.zeros(ENVS, dtype=bool)
        since = np.full(ENVS, -1)  # steps since the release began; -1: not begun
        near = np.zeros(ENVS, dtype=bool)
        rows = slice(first, first + ENVS)
        while not done.all():
            action = policy.act(obs)
            action[near, :3] *= gain
            begun = since >= 0
            t = since[begun][:, None]
            action[begun] = np.where(
                t < settle, STAND_CLOSED, np.where(t < settle + OPEN_STEPS, STAND_OPEN, UP_OPEN)
            )
            obs, _, terminated, truncated, info = envs.step(action)
            since[begun] += 1
            d = np.linalg.norm(
                (obs["achieved_goal"] - obs["desired_goal"]).reshape(ENVS, 2, 3), axis=2
            )
            let_go = (d[:, 0] < 0.05) & ~np.asarray(info["cube1_grasped"], dtype=bool)
            near = let_go & (d[:, 1] < NEAR)
            begins = ~begun & ~done & let_go & (d[:, 1] < within)
            since[begins] = 0
            flat, _ = observation_rows(obs, policy.observation_dim, "release.py")
            speed[rows][begins] = np.linalg.norm(flat[begins, tcp_velocity], axis=1) * 100
            ending = ~done & (terminated | truncated)
            # Basic slices are views: these write into the arrays.
            forced[rows][ending] = since[ending] >= 0
            success[rows][ending] = np.asarray(info["is_success"], dtype=bool)[ending]
            placed[rows][ending] = np.asarray(info["is_placed"], dtype=bool)[ending]
            done |= terminated | truncated
    n = max(int(forced.sum()), 1)
    return {
        "let go": float(forced.mean()),
        "hand speed (cm/s)": float(np.nanmedian(speed)) if forced.any() else float("nan"),
        "then placed": float(placed[forced].sum() / n),
        "then success": float(success[forced].sum() / n),
    }


if __name__ == "__main__":
    paths = sys.argv[1:]
    flags = {"--within": 0.05, "--settle": 0.0, "--gain": 1.0}
    while paths[:1] and paths[0] in flags:
        flags[paths[0]], paths = float(paths[1]), paths[2:]
    within, settle, gain = flags["--within"], int(flags["--settle"]), flags["--gain"]
    for path in paths:
        result = release(path, within, settle, gain)
        print(
            path,
            f"within {within}, settle {settle}, gain {gain}:",
            "  ".join(f"{k}: {v:.3f}" for k, v in result.items()),
        )
