"""Whether the way from where a Stack policy stops is paid: for one model zip, one seeded
episode (seed 2,000,000) of the environment its run record names, acted by the native network
for its first STEPS steps and by the scripted expert from there; prints the reward at the
hand-over and at every step after it (the expert reads only the observation, so it takes over
from the policy's own state). Run from the repository's root:

    PYTHONPATH=$PKG .venv/bin/python docs/training-runs/ppo-Stack-rate-2026-12-01/handover.py \
        runs/ppo-Stack-hover20/checkpoints/ckpt-8000000.zip
"""

from __future__ import annotations

import sys

import gymnasium as gym

import panda_rapier
from panda_rapier.agents.inference import PolicyNetwork
from panda_rapier.agents.model_file import read_run_info

SEED = 2_000_000
STEPS = 40


def handover(path: str) -> None:
    run = read_run_info(path) or {}
    env = gym.make(run.get("env_id", "panda_rapier/StackDense-v0"), **(run.get("env_kwargs") or {}))
    policy = PolicyNetwork.from_zip(path)
    expert = panda_rapier.ScriptedPolicy(env.unwrapped.config)
    obs, _ = env.reset(seed=SEED)
    rewards: list[float] = []
    for step in range(env.spec.max_episode_steps or 150):
        actor = policy.act if step < STEPS else expert
        obs, reward, terminated, truncated, _ = env.step(actor(obs))
        if step >= STEPS - 1:
            rewards.append(round(float(reward), 2))
        if terminated or truncated:
            break
    print(path, f"reward at step {STEPS} (the policy's) and after (the expert's):", rewards)
    env.close()


if __name__ == "__main__":
    for path in sys.argv[1:]:
        handover(path)
