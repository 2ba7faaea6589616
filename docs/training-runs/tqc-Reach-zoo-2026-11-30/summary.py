"""Steps to the first evaluation at >= 90 % success, and the last evaluations, of each run kept
here (run from this folder: python summary.py)."""

import glob
import json
import re

import numpy as np

rows = []
for d in sorted(glob.glob("zoo-*")):
    command = open(glob.glob(d + "/*/command.txt")[0]).read()
    seed = re.search(r"--seed (\d+)", command).group(1)
    env = re.search(r"--env (\S+)", command).group(1)
    evaluations = np.load(d + "/evaluations.npz")
    success, steps = evaluations["successes"].mean(axis=1), evaluations["timesteps"]
    first = next((int(x) for x, v in zip(steps, success) if v >= 0.9), None)
    rows.append((f"{env} (rl-zoo3)", seed, first, float(success[-1]), float(success[-5:].mean())))
for d in sorted(glob.glob("train-*")):
    lines = [json.loads(line) for line in open(d + "/evaluations.jsonl")]
    first = next((x["env_steps"] for x in lines if x["success_rate"] >= 0.9), None)
    last5 = float(np.mean([x["success_rate"] for x in lines[-5:]]))
    rows.append(("Reach-v0 (panda-rapier train)", d[-1], first, lines[-1]["success_rate"], last5))
print("run | seed | env steps to >= 0.9 | last evaluation | mean of the last 5")
for row in rows:
    print(" | ".join(str(x) for x in row))
