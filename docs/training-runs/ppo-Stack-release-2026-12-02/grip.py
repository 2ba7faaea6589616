"""Where does a Stack policy command its gripper while cube2 is ready to be let go? For each
model zip given, EPISODES seeded episodes starting with cube1 on its goal (the tight record's
release.py `on_goal`; seeds from 2,000,000), acted by the native network (deterministic
actions). At every step where cube2 is "ready" (the `release` term's condition, with the
training threshold and rest speed: both cubes within PRECISE of their goals, cube1 not
grasped, both slower than 10 cm/s): printed, the number of such steps, the 10th, 50th and 90th
percentiles of the gripper action there (-1 closes, +1 opens; a release needs it above about
+0.5 for two steps), the share of them above 0, and the share of episodes placed at the end.
Run from the repository's root:

    .venv/bin/python docs/training-runs/ppo-Stack-release-2026-12-02/grip.py \
        runs/ppo-Stack-finetune/ckpt-4001792.zip [...]
"""

from __future__ import annotations

import sys

import numpy as np

sys.path.insert(0, "docs/training-runs/ppo-Stack-tight-2026-12-02")
from release import ENVS, batches, on_goal

PRECISE = 0.02


def grip(path: str) -> str:
    env_id, options, policy = on_goal(path)
    actions: list[float] = []
    placed: list[bool] = []
    for _, envs, obs in batches(env_id, options):
        done = np.zeros(ENVS, dtype=bool)
        while not done.all():
            action = policy.act(obs)
            obs, _, terminated, truncated, info = envs.step(action)
            d = np.linalg.norm(
                (obs["achieved_goal"] - obs["desired_goal"]).reshape(ENVS, 2, 3), axis=2
            )
            ready = (
                ~done
                & (d[:, 0] < PRECISE)
                & (d[:, 1] < PRECISE)
                & ~np.asarray(info["cube1_grasped"], dtype=bool)
                & np.asarray(info["cube_at_rest"], dtype=bool)
            )
            actions.extend(action[ready, -1].tolist())
            ending = ~done & (terminated | truncated)
            placed.extend(np.asarray(info["is_placed"], dtype=bool)[ending].tolist())
            done |= terminated | truncated
    a = np.array(actions)
    p10, p50, p90 = np.percentile(a, [10, 50, 90]) if len(a) else (np.nan,) * 3
    share = float(np.mean(a > 0)) if len(a) else 0.0
    return (
        f"ready steps: {len(a)}  gripper p10 {p10:.2f}  p50 {p50:.2f}  p90 {p90:.2f}  "
        f"above 0: {share:.3f}  placed at the end: {np.mean(placed):.3f}"
    )


if __name__ == "__main__":
    for path in sys.argv[1:]:
        print(path, grip(path))
