"""Does a Stack policy hold cube2 still at its goal, and let it go there? For each model zip
given, EPISODES seeded episodes (seeds from 2,000,000, as the records' milestones.py) starting
with cube1 on its goal (the tight record's release.py `on_goal`), acted by the native network
(deterministic actions). Printed, as shares of the episodes: cube2 came within PRECISE of its
goal with cube1 let go while still touched by the robot ("held at goal"); and there moved
slower than 10 cm/s (the scripted expert's settle speed, this record's training rest speed)
and than 2 cm/s (the id's rest speed); was loosened there (neither cube grasped: the let-go
milestone of the letgo record's `task.stage_let_go`; added after this record's runs); was let
go there (no robot link touching either cube); and the median over the held episodes of
cube2's slowest speed there (cm/s). Run from the repository's root:

    .venv/bin/python docs/training-runs/ppo-Stack-rest-2026-12-02/hold.py \
        runs/ppo-Stack-rest/ckpt-4000000.zip [...]
"""

from __future__ import annotations

import sys

import numpy as np

sys.path.insert(0, "docs/training-runs/ppo-Stack-tight-2026-12-02")
from release import ENVS, EPISODES, batches, observation_rows, on_goal

PRECISE = 0.02
SPEEDS = {"under 10 cm/s": 0.1, "under 2 cm/s": 0.02}


def hold(path: str) -> dict[str, float]:
    env_id, options, policy = on_goal(path)
    held = np.zeros(EPISODES, dtype=bool)
    loosened = np.zeros(EPISODES, dtype=bool)
    let_go = np.zeros(EPISODES, dtype=bool)
    slowest = np.full(EPISODES, np.inf)
    for first, envs, obs in batches(env_id, options):
        velocity = envs.schema.slot("cube2_linear_velocity")
        done = np.zeros(ENVS, dtype=bool)
        rows = slice(first, first + ENVS)
        while not done.all():
            obs, _, terminated, truncated, info = envs.step(policy.act(obs))
            d = np.linalg.norm(
                (obs["achieved_goal"] - obs["desired_goal"]).reshape(ENVS, 2, 3), axis=2
            )
            flat, _ = observation_rows(obs, policy.observation_dim, "hold.py")
            speed = np.linalg.norm(flat[:, velocity], axis=1)
            there = ~done & (d[:, 1] < PRECISE) & ~np.asarray(info["cube1_grasped"], dtype=bool)
            released = np.asarray(info["cube_released"], dtype=bool)
            holding = there & ~released
            held[rows] |= holding
            grasped = np.asarray(info["is_grasped"], dtype=bool)
            loosened[rows] |= there & ~grasped & held[rows]
            let_go[rows] |= there & released & held[rows]
            slowest[rows] = np.where(holding, np.minimum(slowest[rows], speed), slowest[rows])
            done |= terminated | truncated
    out = {"held at goal": float(held.mean())}
    for name, limit in SPEEDS.items():
        out[name] = float((slowest < limit).mean())
    out["loosened there"] = float(loosened.mean())
    out["let go there"] = float(let_go.mean())
    if held.any():
        out["slowest (cm/s)"] = float(np.median(slowest[held]) * 100)
    return out


if __name__ == "__main__":
    for path in sys.argv[1:]:
        result = hold(path)
        print(path, "  ".join(f"{k}: {v:.3f}" for k, v in result.items()), flush=True)
