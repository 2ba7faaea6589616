"""Sweeps a stable-baselines3 recipe (TQC + HER, PPO or SAC) over seeds and learning rates
with Ray Tune: one ``panda-rapier train`` run per trial, each reporting its periodic
evaluations' success rate.

    python examples/tune_sb3.py --algo tqc --env-id panda_rapier/PickAndPlace-v0 \\
        --seeds 0 1 2 --learning-rates 3e-4 1e-3 --timesteps 200000 --eval-every 50000
    python examples/tune_sb3.py --address auto --storage /shared/ray_results ...  # a cluster

``--set KEY=VALUE`` overrides any other recipe key (VALUE is read as YAML, e.g.
``--set batch_size=256 --set "policy_kwargs=dict(net_arch=[256, 256], n_critics=2)"``).
Trials land in STORAGE/NAME/<trial>/ (``recipe.yml``, the run directory ``run/``); the table
of results is printed and, with --json, written to a file.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import ray
import yaml
from ray import tune

from panda_rapier.scale.tuning import METRICS, TUNE_ALGORITHMS, sb3_tuner


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--algo", choices=TUNE_ALGORITHMS, default="tqc")
    parser.add_argument("--env-id", default="panda_rapier/PickAndPlace-v0")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--learning-rates", type=float, nargs="+", default=None,
                        help="a grid of learning rates (default: the recipe's)")  # fmt: skip
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="another recipe override (VALUE as YAML)")  # fmt: skip
    parser.add_argument("--timesteps", type=int, default=None)
    parser.add_argument("--n-envs", type=int, default=None)
    parser.add_argument("--eval-every", type=int, default=None)
    parser.add_argument("--eval-episodes", type=int, default=100)
    parser.add_argument("--cpus-per-trial", type=int, default=1)
    parser.add_argument("--address", default=None,
                        help="a running cluster (auto); default: a new local Ray")  # fmt: skip
    parser.add_argument("--num-cpus", type=int, default=None, help="CPUs of the local Ray")
    parser.add_argument("--storage", type=Path, default=None,
                        help="Tune's storage path (default ~/ray_results)")  # fmt: skip
    parser.add_argument("--name", default=None)
    parser.add_argument("--json", type=Path, default=None)
    return parser.parse_args()


def overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The recipe overrides: --set pairs and the learning-rate grid."""
    found: dict[str, Any] = {}
    for pair in args.set:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise SystemExit(f"--set takes KEY=VALUE, got {pair!r}")
        found[key] = yaml.safe_load(value)
    if args.learning_rates:
        found["learning_rate"] = tune.grid_search(args.learning_rates)
    return found


def main() -> None:
    args = parse_args()
    hyperparams = overrides(args)
    if args.address is not None:
        ray.init(address=args.address)
    else:
        ray.init(address="local", num_cpus=args.num_cpus, include_dashboard=False)
    tuner = sb3_tuner(
        args.algo,
        args.env_id,
        seeds=args.seeds,
        hyperparams=hyperparams,
        timesteps=args.timesteps,
        n_envs=args.n_envs,
        eval_every=args.eval_every,
        eval_episodes=args.eval_episodes,
        cpus_per_trial=args.cpus_per_trial,
        storage_path=args.storage,
        name=args.name,
    )
    results = tuner.fit()
    rows = []
    for result in results:
        if result.error is not None:
            print(f"trial {result.path} failed: {result.error}")
            continue
        row = {
            "seed": result.config["seed"],
            "hyperparams": result.config["hyperparams"],
            **{key: result.metrics.get(key) for key in METRICS},
            "path": result.path,
        }
        rows.append(row)
        print(
            f"seed {row['seed']}, {row['hyperparams']}: success {row['success_rate']:.3f} "
            f"({row['success_ci95_low']:.3f}-{row['success_ci95_high']:.3f}), placed "
            f"{row['placed_rate']:.3f} after {row['env_steps']:,} env steps"
        )
    if rows:
        best = results.get_best_result()
        print(f"best: seed {best.config['seed']}, {best.config['hyperparams']}: {best.path}")
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=2, default=str))
    ray.shutdown()
    if len(rows) < len(results):
        raise SystemExit(f"{len(results) - len(rows)} trial(s) failed")


if __name__ == "__main__":
    main()
