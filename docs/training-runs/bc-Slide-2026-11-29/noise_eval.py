# Lab record, not part of the package (docs/training.md, 2026-11-30): the 8-round Slide clone's success with
# Gaussian noise added to its actions. Run as: python noise_eval.py runs/bc-Slide/best.zip panda_rapier/Slide-v0 200
"""The clone's success with Gaussian action noise of a given std added to its mean action (as PPO's rollouts sample)."""
import sys
import numpy as np, torch as th
from stable_baselines3 import PPO
from panda_rapier.agents.evaluation import evaluate
from panda_rapier.registration import env_config
th.set_num_threads(1)
path, env_id, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
model = PPO.load(path, device="cpu")
config = env_config(env_id)
for std in [0.0, 0.01, 0.03, 0.1]:
    rng = np.random.default_rng(0)
    class Noisy:
        def predict(self, obs, deterministic=True):
            a, s = model.predict(obs, deterministic=True)
            return np.clip(a + rng.normal(0, std, a.shape), -1, 1).astype(np.float32), s
    r = evaluate(Noisy(), config, n, first_seed=500_000_000)
    print(f"noise std {std}: success {r.success_rate:.3f}", flush=True)
