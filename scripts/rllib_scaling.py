"""RLlib on this machine: sampling and learning throughput against the number of EnvRunners
and environments per runner, Ray's overhead against the native vector env alone, and from
those a projection to N nodes (docs/guide/ray.md).

    python scripts/rllib_scaling.py --json docs/rllib-scaling.json

For every (runners, envs per runner) in the grid, with the PPO recipe's config
(panda_rapier.scale.rllib.ppo_config, PickAndPlaceDense-v0):
- sampling: every runner samples ``--fragment`` steps per environment with the policy
  (``runner.sample``), all runners at once; env steps per second of wall time;
- learning: ``--iterations`` PPO iterations of the recipe's 4,096 steps (after one warm-up),
  env steps per second with the updates; RLlib's own timers split each iteration into
  sampling and the learner's update;
- native: the same number of environments in one PandaVectorEnv on as many Rust threads
  as runners, random actions, no Ray: what the runners' sampling would be without RLlib.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import ray
import torch
from tqdm import tqdm

from panda_rapier import PandaVectorEnv, env_config
from panda_rapier.scale.rllib import ppo_config

ENV_ID = "panda_rapier/PickAndPlaceDense-v0"


def native_rate(num_envs: int, threads: int, steps: int) -> float:
    """Env steps per second of one PandaVectorEnv with random actions, no Ray."""
    env = PandaVectorEnv(
        num_envs, num_threads=threads, **env_config(ENV_ID, reward_weights={"release": 1.0})
    )
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (steps, num_envs, 4)).astype(np.float32)
    began = time.perf_counter()
    for a in actions:
        env.step(a)
    elapsed = time.perf_counter() - began
    env.close()
    return num_envs * steps / elapsed


def measure(runners: int, envs: int, fragment: int, iterations: int) -> dict[str, Any]:
    config = ppo_config(ENV_ID, num_env_runners=runners, num_envs_per_env_runner=envs)
    algo = config.build_algo()
    try:
        group = algo.env_runner_group
        group.foreach_env_runner(lambda r: r.sample(num_timesteps=r.num_envs * 8),
                                 local_env_runner=False)  # fmt: skip
        began = time.perf_counter()
        group.foreach_env_runner(
            lambda r: r.sample(num_timesteps=r.num_envs * fragment), local_env_runner=False
        )
        sampling = runners * envs * fragment / (time.perf_counter() - began)
        algo.train()  # warm-up
        began = time.perf_counter()
        first = None
        for _ in range(iterations):
            result = algo.train()
            first = first or result
        elapsed = time.perf_counter() - began
        steps = (
            result["num_env_steps_sampled_lifetime"]
            - first["num_env_steps_sampled_lifetime"]
            + first["env_runners"]["num_env_steps_sampled"]
        )
        timers = result["timers"]
    finally:
        algo.stop()
    return {
        "env_runners": runners,
        "envs_per_runner": envs,
        "sampling_env_steps_per_s": round(sampling, 1),
        "learning_env_steps_per_s": round(float(steps) / elapsed, 1),
        "iteration_s": round(elapsed / iterations, 3),
        "sampling_s": round(float(timers["env_runner_sampling_timer"]), 3),
        "update_s": round(float(timers["learner_update_timer"]), 3),
        "native_env_steps_per_s": round(native_rate(runners * envs, runners, fragment), 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runners", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--envs", type=int, nargs="+", default=[8, 16, 32, 64])
    parser.add_argument("--fragment", type=int, default=140, help="steps per environment")
    parser.add_argument("--iterations", type=int, default=3)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    torch.set_num_threads(os.cpu_count() or 1)  # the learner, while the runners wait
    ray.init(address="local", num_cpus=os.cpu_count(), include_dashboard=False, log_to_driver=False)
    rows = []
    grid = [(r, e) for r in args.runners for e in args.envs]
    for runners, envs in tqdm(grid, desc="configurations"):
        row = measure(runners, envs, args.fragment, args.iterations)
        row["ray_overhead"] = round(
            1 - row["sampling_env_steps_per_s"] / row["native_env_steps_per_s"], 3
        )
        rows.append(row)
        tqdm.write(json.dumps(row))
    ray.shutdown()
    print("| runners | envs/runner | native env steps/s | RLlib sampling | overhead | "
          "PPO with updates | iteration: sampling + update (s) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['env_runners']} | {r['envs_per_runner']} | {r['native_env_steps_per_s']:,.0f} "
            f"| {r['sampling_env_steps_per_s']:,.0f} | {100 * r['ray_overhead']:.0f} % "
            f"| {r['learning_env_steps_per_s']:,.0f} | {r['sampling_s']:.2f} + "
            f"{r['update_s']:.2f} |"
        )
    if args.json is not None:
        machine = {"cpus": os.cpu_count(), "ray": ray.__version__, "torch": torch.__version__}
        args.json.write_text(json.dumps({"machine": machine, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
