"""How fast cube2 moves when the hand holding it at its goal is driven by exploration noise
alone: on-goal episodes (seeds 2,000,000-2,000,039) acted by the model's network until cube2
is within 2 cm of its goal with cube1 let go, then 13 steps of zero hand actions plus Gaussian
noise of each standard deviation (gripper closed); cube2's speed over the last 9 of them. Run
from the repository's root: `.venv/bin/python <this file> runs/ppo-Stack-first/ckpt-4001792.zip`.
"""

import sys

import gymnasium as gym
import numpy as np

sys.path.insert(0, "docs/training-runs/ppo-Stack-tight-2026-12-02")
from release import observation_rows, on_goal

env_id, options, policy = on_goal(sys.argv[1])
env = gym.make(env_id, **options)
velocity = env.unwrapped.schema.slot("cube2_linear_velocity")
rng = np.random.default_rng(0)
for std in (0.0, 0.1, 0.25):
    speeds = []
    for seed in range(2_000_000, 2_000_040):
        obs, _ = env.reset(seed=seed)
        since = -1
        for _t in range(150):
            a = policy.act(obs)
            if since >= 0:
                a = np.array([*rng.normal(0, std, 3), -1.0], np.float32)
            obs, r, term, trunc, info = env.step(a)
            if since >= 0:
                since += 1
                if since > 3:
                    flat, _ = observation_rows(obs, policy.observation_dim, "noise.py")
                    speeds.append(np.linalg.norm(flat[0, velocity]))
                if since >= 13:
                    break
            d = np.linalg.norm((obs["achieved_goal"] - obs["desired_goal"]).reshape(2, 3), axis=1)
            if since < 0 and d[0] < 0.05 and not info["cube1_grasped"] and d[1] < 0.02:
                since = 0
            if term or trunc:
                break
    s = np.array(speeds)
    print(
        f"std {std}: cube2 speed median {np.median(s) * 100:.1f} cm/s,",
        f"p90 {np.percentile(s, 90) * 100:.1f}, share < 2 cm/s {np.mean(s < 0.02):.2f},",
        f"< 10 cm/s {np.mean(s < 0.1):.2f} (n={len(s)})",
    )
