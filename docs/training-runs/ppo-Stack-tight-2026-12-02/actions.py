"""Where a Stack policy's actions are near cube2's goal: on-goal episodes (seeds
2,000,000-2,000,019), the share of the network's (clipped) hand actions at the bounds and the
Gaussian's means before the clip (stable-baselines3's policy, loaded from our own checkpoint)
while cube2 is within 3 cm of its goal. Run from the repository's root:
`.venv/bin/python <this file> runs/ppo-Stack-still/ckpt-3000000.zip`.
"""

import sys

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3 import PPO

sys.path.insert(0, "docs/training-runs/ppo-Stack-tight-2026-12-02")
from release import on_goal

th.set_num_threads(1)
path = sys.argv[1]
model = PPO.load(path, device="cpu")
env_id, options, policy = on_goal(path)
env = gym.make(env_id, **options)
# Both at the same states: the native network's actions drive the episodes.
actions, raw = [], []
for seed in range(2_000_000, 2_000_020):
    obs, _ = env.reset(seed=seed)
    for _t in range(150):
        a = policy.act(obs)
        d = np.linalg.norm((obs["achieved_goal"] - obs["desired_goal"]).reshape(2, 3), axis=1)
        if d[1] < 0.03:
            o = {k: th.as_tensor(v[None]) for k, v in obs.items()}
            with th.no_grad():
                raw.append(model.policy.get_distribution(o).distribution.mean.numpy()[0])
            actions.append(a)
        obs, r, term, trunc, info = env.step(a)
        if term or trunc:
            break
m, r = np.array(actions), np.array(raw)
print("clipped actions near the goal: share |a|>0.95 per dim",
      np.round(np.mean(np.abs(m) > 0.95, axis=0), 2), "n", len(m))  # fmt: skip
print("mean |a|", np.round(np.mean(np.abs(m), axis=0), 2))
print("raw means near the goal: median |mu|", np.round(np.median(np.abs(r), axis=0), 2),
      "share |mu|>1.3", np.round(np.mean(np.abs(r) > 1.3, axis=0), 2),
      "p90", np.round(np.percentile(np.abs(r), 90, axis=0), 2))  # fmt: skip
