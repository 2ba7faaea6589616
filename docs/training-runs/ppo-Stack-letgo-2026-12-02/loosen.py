"""What follows when a Stack policy loosens its grip on cube2 at its goal? For each model zip
given, EPISODES seeded episodes starting with cube1 on its goal (the tight record's release.py
`on_goal`; seeds from 2,000,000), acted by the native network (deterministic actions). In the
episodes where cube2, held within PRECISE of its goal with cube1 let go, is at some step no
longer grasped while still touched (hold.py's "loosened there"), the AFTER steps from that
step on: printed, as shares of those episodes, whether within them cube2 was squeezed again,
let go (no robot link touching either cube), and still within PRECISE of its goal at the
last of them; and the median over them of the gripper action (-1 closes, +1 opens) at the
loosening step and the mean over the steps after. Run from the repository's root:

    .venv/bin/python docs/training-runs/ppo-Stack-letgo-2026-12-02/loosen.py \
        runs/ppo-Stack-letgo/ckpt-32002048.zip [...]
"""

from __future__ import annotations

import sys

import numpy as np

sys.path.insert(0, "docs/training-runs/ppo-Stack-tight-2026-12-02")
from release import ENVS, EPISODES, batches, on_goal

PRECISE = 0.02
AFTER = 10


def loosen(path: str) -> dict[str, float]:
    env_id, options, policy = on_goal(path)
    # The step of the first loosening (-1: none), and what followed.
    at = np.full(EPISODES, -1)
    regrasped = np.zeros(EPISODES, dtype=bool)
    let_go = np.zeros(EPISODES, dtype=bool)
    kept = np.zeros(EPISODES, dtype=bool)
    first_action = np.full(EPISODES, np.nan)
    # The gripper actions over the steps after, summed, and how many.
    later_sum = np.zeros(EPISODES)
    later_count = np.zeros(EPISODES, dtype=int)
    for first, envs, obs in batches(env_id, options):
        done = np.zeros(ENVS, dtype=bool)
        rows = np.arange(first, first + ENVS)
        step = 0
        while not done.all():
            action = policy.act(obs)
            obs, _, terminated, truncated, info = envs.step(action)
            d = np.linalg.norm(
                (obs["achieved_goal"] - obs["desired_goal"]).reshape(ENVS, 2, 3), axis=2
            )
            grasped = np.asarray(info["is_grasped"], dtype=bool)
            released = np.asarray(info["cube_released"], dtype=bool)
            cube1 = np.asarray(info["cube1_grasped"], dtype=bool)
            there = ~done & (d[:, 1] < PRECISE) & ~cube1
            new = there & ~grasped & ~released & (at[rows] < 0)
            at[rows[new]] = step
            first_action[rows[new]] = action[new, -1]
            since = step - at[rows]
            watching = (at[rows] >= 0) & (since > 0) & (since <= AFTER) & ~done
            regrasped[rows] |= watching & grasped
            let_go[rows] |= watching & released
            last = watching & (since == AFTER)
            kept[rows[last]] = d[last, 1] < PRECISE
            later_sum[rows[watching]] += action[watching, -1]
            later_count[rows[watching]] += 1
            done |= terminated | truncated
            step += 1
    loosened = at >= 0
    out = {"loosened": float(loosened.mean())}
    if loosened.any():
        out["squeezed again"] = float(regrasped[loosened].mean())
        out["let go"] = float(let_go[loosened].mean())
        out[f"within 2 cm {AFTER} steps on"] = float(kept[loosened].mean())
        out["gripper action then"] = float(np.median(first_action[loosened]))
        watched = loosened & (later_count > 0)
        if watched.any():
            out["after"] = float(np.median(later_sum[watched] / later_count[watched]))
    return out


if __name__ == "__main__":
    for path in sys.argv[1:]:
        result = loosen(path)
        print(path, "  ".join(f"{k}: {v:.3f}" for k, v in result.items()), flush=True)
