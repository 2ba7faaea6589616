#!/usr/bin/env python3
"""How often a shipped model's actions differ between torch's CPU kernel paths, and between
torch float32 and the native float64 network (docs/reproducibility.md).

For every model in models/: the flat observations of 64 scripted-expert episodes of its
environment; their actions by torch under each ATEN_CPU_CAPABILITY given (one subprocess each)
and by the native network; prints, per pair, the fraction of rows whose action bits differ and
the largest difference.

    .venv/bin/python scripts/inference_capabilities.py default avx2 detected
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

MODELS = Path(__file__).resolve().parents[1] / "models"

CHILD = r"""
import sys, numpy as np, torch
torch.set_num_threads(1)
from stable_baselines3 import PPO
from panda_rapier.agents.inference import PolicyNetwork
path, rows_file, out = sys.argv[1:4]
rows = np.load(rows_file)
obs = {"achieved_goal": rows[:, :3], "desired_goal": rows[:, 3:6], "observation": rows[:, 6:]}
torch_actions = np.asarray(PPO.load(path, device="cpu").predict(obs, deterministic=True)[0],
                           np.float32)
np.savez(out, torch=torch_actions, native=PolicyNetwork.from_zip(path).act(rows),
         capability=torch.backends.cpu.get_cpu_capability())
"""


def main(capabilities: list[str]) -> None:
    from tqdm import tqdm

    from panda_rapier.agents.model_file import read_run_info
    from panda_rapier.learning.imitation import collect
    from panda_rapier.registration import env_config

    results = {}
    with tempfile.TemporaryDirectory() as folder:
        jobs = [(m, c) for m in sorted(MODELS.glob("*.zip")) for c in capabilities]
        rows_of = {}
        for model, capability in tqdm(jobs, desc="model x capability"):
            if model not in rows_of:
                run = read_run_info(model) or {}
                config = env_config(run["env_id"], **run["env_kwargs"])
                rows_of[model] = Path(folder) / f"{model.stem}.npy"
                np.save(rows_of[model], collect(config, 64, first_seed=7_000_000)[0].observations)
            env = {k: v for k, v in os.environ.items() if k != "ATEN_CPU_CAPABILITY"}
            if capability != "detected":
                env["ATEN_CPU_CAPABILITY"] = capability
            out = Path(folder) / f"{model.stem}-{capability}.npz"
            subprocess.run([sys.executable, "-c", CHILD, str(model), str(rows_of[model]),
                            str(out)], env=env, check=True)  # fmt: skip
            results[(model.name, capability)] = dict(np.load(out))
    report = {}
    for model in sorted({m for m, _ in results}):
        runs = {c: results[(model, c)] for c in capabilities}
        entry = {"rows": len(runs[capabilities[0]]["native"]),
                 "capabilities": {c: str(r["capability"]) for c, r in runs.items()}}  # fmt: skip
        pairs = [(f"torch {a} vs torch {b}", runs[a]["torch"], runs[b]["torch"])
                 for i, a in enumerate(capabilities) for b in capabilities[i + 1:]]  # fmt: skip
        pairs += [(f"native {a} vs native {b}", runs[a]["native"], runs[b]["native"])
                  for i, a in enumerate(capabilities) for b in capabilities[i + 1:]]  # fmt: skip
        pairs += [(f"torch {c} vs native", runs[c]["torch"], runs[c]["native"])
                  for c in capabilities]  # fmt: skip
        for label, x, y in pairs:
            differ = np.any(x.view(np.uint32) != y.view(np.uint32), axis=1)
            entry[label] = {"rows_differing": float(differ.mean()),
                            "max_abs_diff": float(np.abs(x - y).max())}  # fmt: skip
        report[model] = entry
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:] or ["default", "avx2", "detected"])
