"""Trains PPO, SAC or TQC with RLlib (Ray's new API stack) on the native vector environment:
one PandaVectorEnv per EnvRunner, the runners spread over a local Ray or a cluster.

    python examples/rllib_train.py --iterations 200 --num-env-runners 2          # this machine
    python examples/rllib_train.py --address auto --num-env-runners 32 \\
        --num-cpus-per-env-runner 2 --checkpoint runs/rllib_ppo               # a Ray cluster

Prints one line per iteration (env steps, episodes, mean return, success rate) and, with
--json, writes them to a file; --checkpoint saves the algorithm at the end
(``Algorithm.from_checkpoint`` restores it). The configs come from panda_rapier.scale.rllib.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import ray

from panda_rapier.scale.rllib import ppo_config, sac_config, tqc_config

BUILDERS = {"ppo": ppo_config, "sac": sac_config, "tqc": tqc_config}


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--algo", choices=sorted(BUILDERS), default="ppo")
    parser.add_argument("--env-id", default="panda_rapier/PickAndPlaceDense-v0")
    parser.add_argument("--iterations", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--num-env-runners", type=int, default=2)
    parser.add_argument("--num-envs-per-env-runner", type=int, default=None,
                        help="default: the builder's (PPO 16, SAC/TQC 4)")  # fmt: skip
    parser.add_argument("--num-cpus-per-env-runner", type=int, default=1)
    parser.add_argument("--env-kwargs", type=json.loads, default={},
                        help='environment options as JSON: {"arm": "kinematic"}')  # fmt: skip
    parser.add_argument("--train-batch-size", type=int, default=None,
                        help="train_batch_size_per_learner (default: the builder's)")  # fmt: skip
    parser.add_argument("--minibatch-size", type=int, default=None, help="PPO only")
    parser.add_argument("--learning-starts", type=int, default=None, help="SAC / TQC only")
    parser.add_argument("--address", default=None,
                        help="a running cluster (auto); default: a new local Ray")  # fmt: skip
    parser.add_argument("--num-cpus", type=int, default=None, help="CPUs of the local Ray")
    parser.add_argument("--checkpoint", type=Path, default=None)
    parser.add_argument("--json", type=Path, default=None)
    return parser.parse_args()


def main() -> None:
    args = parse_args()
    if args.address is not None:
        ray.init(address=args.address)
    else:
        ray.init(address="local", num_cpus=args.num_cpus, include_dashboard=False)
    training: dict[str, Any] = {}
    if args.train_batch_size is not None:
        training["train_batch_size_per_learner"] = args.train_batch_size
    if args.minibatch_size is not None:
        training["minibatch_size"] = args.minibatch_size
    if args.learning_starts is not None:
        training["num_steps_sampled_before_learning_starts"] = args.learning_starts
    runners: dict[str, Any] = {}
    if args.num_envs_per_env_runner is not None:
        runners["num_envs_per_env_runner"] = args.num_envs_per_env_runner
    config = BUILDERS[args.algo](
        args.env_id,
        seed=args.seed,
        num_env_runners=args.num_env_runners,
        num_cpus_per_env_runner=args.num_cpus_per_env_runner,
        env_kwargs=args.env_kwargs,
        **runners,
        **training,
    )
    algo = config.build_algo()
    lines = []
    started = time.perf_counter()
    for iteration in range(1, args.iterations + 1):
        result = algo.train()
        runner_metrics = result["env_runners"]
        line = {
            "iteration": iteration,
            "env_steps": int(result.get("num_env_steps_sampled_lifetime", 0)),
            "episodes": int(runner_metrics.get("num_episodes_lifetime", 0)),
            "episode_return_mean": _number(runner_metrics.get("episode_return_mean")),
            "success_rate": _number(runner_metrics.get("success_rate")),
            "wall_time_s": round(time.perf_counter() - started, 3),
        }
        lines.append(line)
        print(
            f"iteration {iteration}: {line['env_steps']:,} env steps, {line['episodes']:,} "
            f"episodes, return {line['episode_return_mean']}, success "
            f"{line['success_rate']}, {line['wall_time_s']:.1f} s",
            flush=True,
        )
    if args.checkpoint is not None:
        path = algo.save_to_path(str(args.checkpoint.resolve()))
        print(f"checkpoint: {path}")
    if args.json is not None:
        args.json.write_text(json.dumps(lines, indent=2))
    algo.stop()
    ray.shutdown()


def _number(value: Any) -> float | None:
    """A metric as a plain float (None before the first episode ends)."""
    return None if value is None else round(float(value), 4)


if __name__ == "__main__":
    main()
