"""How far a Stack policy gets: for each model zip given, EPISODES seeded episodes (seeds from
2,000,000: neither validation's nor the test seeds) of the environment its run record names,
acted by the native network (deterministic actions; a start-state curriculum in the record's
options, `task.cube1_on_goal_probability`, is dropped: the id's own episodes), and the share
of episodes that reached each milestone of the `stage` term (env-core/src/task/stack.rs) at
some step, with success and placed at the episode's end, and where cube2 was the first time it
reached its goal (the third milestone): the medians, over the episodes that reached it, of its
height above its goal and its distance beside it, in centimetres; and the share of episodes in
which cube2 came within 2 cm of its goal (PRECISE) after cube1 was let go on its goal. Run from
the repository's root:

    PYTHONPATH=$PKG .venv/bin/python docs/training-runs/ppo-Stack-stage-2026-12-01/milestones.py \
        [--cube1-on-goal P] runs/ppo-Stack-stage/best.zip [more.zip ...]

With ``--cube1-on-goal P`` the episodes start with cube1 resting on its goal with probability
P (the curriculum's own episodes at 1) instead of the id's own episodes.
"""

from __future__ import annotations

import sys

import gymnasium as gym
import numpy as np

from panda_rapier.agents.inference import PolicyNetwork
from panda_rapier.agents.model_file import read_run_info

EPISODES = 200
ENVS = 50
FIRST_SEED = 2_000_000
THRESHOLD = 0.05
PRECISE = 0.02
NAMES = ["cube1 at goal", "and let go", "cube2 at goal", "both let go"]


def milestones(path: str, on_goal: float | None = None) -> dict[str, float]:
    run = read_run_info(path) or {}
    env_id = run.get("env_id", "panda_rapier/StackDense-v0")
    options = dict(run.get("env_kwargs") or {})
    if isinstance(options.get("task"), dict):
        task = {k: v for k, v in options["task"].items() if k != "cube1_on_goal_probability"}
        options["task"] = task
    if on_goal is not None:
        options["task"] = {
            "name": "stack",
            **options.get("task", {}),
            "cube1_on_goal_probability": on_goal,
        }
    policy = PolicyNetwork.from_zip(path)
    reached = np.zeros((EPISODES, 4), dtype=bool)
    success = np.zeros(EPISODES, dtype=bool)
    placed = np.zeros(EPISODES, dtype=bool)
    precise = np.zeros(EPISODES, dtype=bool)
    # cube2's offset from its goal (x, y, z) at the step it first reached it; NaN: never.
    offset = np.full((EPISODES, 3), np.nan)
    for first in range(0, EPISODES, ENVS):
        envs = gym.make_vec(env_id, num_envs=ENVS, vectorization_mode="vector_entry_point",
                            autoreset_mode="disabled", **options)  # fmt: skip
        obs, _ = envs.reset(seed=[FIRST_SEED + first + i for i in range(ENVS)])
        done = np.zeros(ENVS, dtype=bool)
        rows = slice(first, first + ENVS)
        while not done.all():
            # Gymnasium's flatten order: the dict space's keys in order.
            flat = np.concatenate(
                [np.asarray(obs[k], dtype=np.float32).reshape(ENVS, -1)
                 for k in envs.single_observation_space.spaces], axis=1)  # fmt: skip
            obs, _, terminated, truncated, info = envs.step(policy.act(flat))
            d = np.linalg.norm(
                (obs["achieved_goal"] - obs["desired_goal"]).reshape(ENVS, 2, 3), axis=2
            )
            first_at = d[:, 0] < THRESHOLD
            let_go = first_at & ~np.asarray(info["cube1_grasped"], dtype=bool)
            second = let_go & (d[:, 1] < THRESHOLD)
            both = second & np.asarray(info["cube_released"], dtype=bool)
            live = ~done
            new = second & live & ~reached[rows, 2]
            offset[rows][new] = (obs["achieved_goal"] - obs["desired_goal"])[new, 3:]
            precise[rows] |= let_go & (d[:, 1] < PRECISE) & live
            for k, m in enumerate([first_at, let_go, second, both]):
                reached[rows, k] |= m & live
            ending = live & (terminated | truncated)
            s, p = success[rows], placed[rows]
            s[ending] = np.asarray(info["is_success"], dtype=bool)[ending]
            p[ending] = np.asarray(info["is_placed"], dtype=bool)[ending]
            success[rows], placed[rows] = s, p
            done |= terminated | truncated
        envs.close()
    out = {name: float(reached[:, k].mean()) for k, name in enumerate(NAMES)}
    out["success at the end"] = float(success.mean())
    out["placed at the end"] = float(placed.mean())
    held = offset[~np.isnan(offset[:, 0])]
    if len(held):
        out["cube2 above (cm)"] = float(np.median(held[:, 2]) * 100)
        out["beside (cm)"] = float(np.median(np.linalg.norm(held[:, :2], axis=1)) * 100)
    out["cube2 within 2 cm"] = float(precise.mean())
    return out


if __name__ == "__main__":
    paths = sys.argv[1:]
    on_goal = None
    if paths[:1] == ["--cube1-on-goal"]:
        on_goal, paths = float(paths[1]), paths[2:]
    for path in paths:
        result = milestones(path, on_goal)
        print(path, "  ".join(f"{k}: {v:.3f}" for k, v in result.items()), flush=True)
