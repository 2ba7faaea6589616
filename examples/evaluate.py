"""Evaluate a saved stable-baselines3 model on a panda_rapier environment.

    python examples/evaluate.py runs/tqc_her/model.zip --episodes 100

Loads the model (PPO, SAC, TQC, ...: the algorithm is read from the file), runs seeded
episodes on the native vector environment with a progress bar, and prints the success rate
(with a 95 % Wilson interval), the placed rate and the mean return and length. The training
scripts write ``run.json`` (algorithm and environment id) beside the model.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from panda_rapier.sb3 import make_vec_env

ALGORITHMS = ("ppo", "sac", "tqc", "td3", "a2c")


def load_model(path: Path, algo: str, env: Any) -> Any:
    """Loads a stable-baselines3 (or sb3-contrib) model of algorithm ``algo``; ``env`` is
    needed by models with a hindsight replay buffer."""
    if algo == "tqc":
        from sb3_contrib import TQC as algorithm
    else:
        import stable_baselines3

        algorithm = getattr(stable_baselines3, algo.upper())
    return algorithm.load(path, env=env, device="cpu")


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a success rate."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", type=Path)
    parser.add_argument("--env-id", default=None, help="default: from run.json beside the model")
    parser.add_argument("--algo", choices=ALGORITHMS, default=None, help="default: from run.json")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--n-envs", type=int, default=8)
    parser.add_argument("--seed", type=int, default=10_000)
    args = parser.parse_args()

    run_file = args.model.parent / "run.json"
    run = json.loads(run_file.read_text()) if run_file.exists() else {}
    env_id = args.env_id or run.get("env_id", "panda_rapier/PickAndPlace-v0")
    algo = args.algo or run.get("algo")
    if algo is None:
        raise SystemExit(f"no run.json beside {args.model}: pass --algo and --env-id")
    env = make_vec_env(env_id, n_envs=args.n_envs, seed=args.seed)
    model = load_model(args.model, algo, env)
    obs = env.reset()
    returns, lengths, successes, placed = [], [], 0, 0
    with tqdm(total=args.episodes, desc="episodes", unit="ep") as bar:
        while len(returns) < args.episodes:
            actions, _ = model.predict(obs, deterministic=True)
            obs, _, dones, infos = env.step(actions)
            for i in np.flatnonzero(dones):
                if len(returns) == args.episodes:
                    break
                info = infos[i]
                returns.append(info["episode"]["r"])
                lengths.append(info["episode"]["l"])
                successes += bool(info["is_success"])
                placed += bool(info["is_placed"])
                bar.update(1)
    low, high = wilson(successes, len(returns))
    print(
        f"success rate {successes / len(returns):.3f} (95 % CI {low:.3f}-{high:.3f}) "
        f"over {len(returns)} episodes"
    )
    print(f"placed rate  {placed / len(returns):.3f}")
    print(
        f"mean return  {np.mean(returns):.2f} +- {np.std(returns):.2f}, "
        f"mean length {np.mean(lengths):.1f}"
    )


if __name__ == "__main__":
    main()
