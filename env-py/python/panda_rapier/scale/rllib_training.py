"""``panda-rapier train --algo ppo --backend rllib``: the PPO recipe trained by RLlib.

:func:`train` writes the same run directory as a stable-baselines3 run of ``panda-rapier
train``: periodic evaluations on the validation seeds of the learner's module exported as the
recipe's stable-baselines3 policy (:func:`panda_rapier.scale.rllib_recipe.as_sb3`;
``evaluations.jsonl``, ``best.zip``), ``model.zip``, ``run.json`` with the wall time and where
it went (``wall_time_split``, from RLlib's timers), and RLlib checkpoints in ``checkpoints/``
for ``--resume``; on a local Ray or a cluster (``address``). ``panda-rapier bench-train``
measures it against stable-baselines3 (``--variant rllib backend=rllib``).
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import ray
import torch

from ..errors import ConfigError
from ..learning.phases import PHASES
from ..learning.recipes import load_recipe, resolve_validation
from ..learning.runs import (
    Recorder,
    cpu_count,
    due,
    finish_run,
    open_run,
    run_record,
    stop_reason,
)
from ..registration import ENV_IDS, env_config
from .rllib import ppo_config
from .rllib_recipe import as_sb3, trained_module

__all__ = ["train"]


def _add_phases(
    split: dict[str, float], result: Mapping[str, Any], seconds: float, envs: int
) -> None:
    """Adds one iteration's ``seconds`` to ``split`` (:data:`panda_rapier.learning.phases.PHASES`)
    from RLlib's timers: the runners' mean vector-env step and module inference times, times the
    steps each runner took (they sample in parallel), the rest of the sampling, and the rest
    of the iteration (the learner's update, weight sync) as ``update``."""
    runners = result.get("env_runners", {})
    sampling = float(result.get("timers", {}).get("env_runner_sampling_timer", 0.0))
    sampling = min(sampling, seconds)
    count = float(runners.get("num_env_steps_sampled", 0)) / max(1, envs)
    workers = max(1, int(result.get("fault_tolerance", {}).get("healthy_env_runners", 1)))
    vector_steps = count / workers
    env_step = min(sampling, float(runners.get("env_step_timer", 0.0)) * vector_steps)
    forward = float(runners.get("rlmodule_inference_timer", 0.0)) * vector_steps
    forward = min(sampling - env_step, forward)
    split["env_step"] += env_step
    split["policy_forward"] += forward
    split["rollout_other"] += sampling - env_step - forward
    split["update"] += seconds - sampling


def train(
    env_id: str,
    out: str | Path,
    *,
    conf: str | Path | None = None,
    seed: int = 0,
    timesteps: int | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    eval_every: int | None = None,
    eval_episodes: int | None = None,
    checkpoint_every: int = 500_000,
    resume: bool = False,
    patience: int | None = None,
    stop_at: float | None = None,
    final: str | None = None,
    num_env_runners: int = 2,
    num_envs_per_env_runner: int | None = None,
    num_cpus_per_env_runner: int = 1,
    address: str | None = None,
    progress: bool = True,
    command: list[str] | None = None,
    say: Any = print,
) -> dict[str, Any]:
    """``panda-rapier train --algo ppo --backend rllib``: the PPO recipe of ``env_id``
    (:func:`panda_rapier.scale.rllib.ppo_config`) trained by RLlib, written to ``out`` as
    ``panda-rapier train`` writes a stable-baselines3 run: periodic evaluations on the
    validation seeds (``evaluations.jsonl``, each of the module exported by :func:`as_sb3`),
    ``best.zip``, ``model.zip`` (``final``: the last or the best evaluation's weights),
    ``run.json``; RLlib checkpoints in ``out/checkpoints`` every ``checkpoint_every`` env
    steps, from which ``resume`` goes on. ``num_envs_per_env_runner`` defaults to the recipe's
    ``n_envs`` shared by the runners. Starts a local Ray on every core unless Ray is running
    or ``address`` names a cluster. ``eval_every``, ``eval_episodes``, ``patience`` and
    ``final`` left ``None`` are the recipe file's (or 250,000 env steps, 100 episodes, none,
    ``"last"``), as :func:`panda_rapier.learning.runner.train` resolves them."""

    if env_id not in ENV_IDS:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS")
    given = {"every": eval_every, "episodes": eval_episodes, "patience": patience, "final": final}
    settings = resolve_validation("ppo", env_id, conf, Path(out), resume, given, stop_at, 250_000)
    eval_every, eval_episodes = settings["every"], int(settings["episodes"])
    patience, final = settings["patience"], str(settings["final"])
    # The learner updates in this process while the EnvRunners wait (PPO on RLlib samples
    # and updates in turn), so its updates take every core: 1.04 -> 0.88 s per 4,096-step
    # iteration on 2 cores.
    torch.set_num_threads(cpu_count())
    out = Path(out)
    state_file = out / "checkpoints" / "state.json"
    previous, recipe, options = open_run(
        out, "ppo", env_id, resume, load_recipe("ppo", env_id, conf), env_kwargs
    )
    config = env_config(env_id, **options)
    total = int(timesteps if timesteps is not None else recipe.get("n_timesteps", 1_000_000))
    runners = max(1, num_env_runners)
    per_runner = num_envs_per_env_runner or max(1, int(recipe.get("n_envs", 64)) // runners)
    if not ray.is_initialized():
        if address is not None:
            ray.init(address=address)
        else:
            ray.init(
                address="local",  # a new Ray here, not one found running (--address auto)
                num_cpus=cpu_count(),
                include_dashboard=False,
                log_to_driver=False,
            )
    run = run_record("ppo", env_id, options, config, recipe, conf, seed, command, previous)
    run.update(
        backend="rllib",
        num_env_runners=num_env_runners,
        num_envs_per_env_runner=per_runner,
        num_cpus_per_env_runner=num_cpus_per_env_runner,
        torch_threads=1,
        update_threads=cpu_count(),
        n_timesteps=total,
        final=final,
        validation=settings,
    )
    run["versions"]["ray"] = ray.__version__
    state: dict[str, Any] = {
        "next_eval": eval_every or 0,
        "next_checkpoint": checkpoint_every or 0,
        "wall_time_s": 0.0,
        "env_steps": 0,
    }
    if resume:
        state.update(json.loads(state_file.read_text()))
    algo = ppo_config(
        env_id,
        seed=seed,
        num_env_runners=num_env_runners,
        num_envs_per_env_runner=per_runner,
        num_cpus_per_env_runner=num_cpus_per_env_runner,
        env_kwargs=options,
        conf=conf,
    ).build_algo()
    try:
        if resume:
            algo.restore_from_path(str((out / "checkpoints" / "algorithm").resolve()))
            say(f"resuming {out} at {state['env_steps']:,} steps")
        recorder = Recorder(out, config, run, eval_episodes, None, float(state["wall_time_s"]), say)
        (out / "run.json").write_text(json.dumps(run, indent=2, default=str))
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=total, initial=int(state["env_steps"]), unit="step", smoothing=0.1)

        def save_checkpoint() -> None:
            began = time.perf_counter()
            algo.save_to_path(str((out / "checkpoints" / "algorithm").resolve()))
            saved = {**state, "wall_time_s": recorder.wall_time()}
            state_file.write_text(json.dumps(saved, indent=2))
            recorder.checkpoint_time += time.perf_counter() - began

        steps = int(state["env_steps"])
        model = None
        split = dict.fromkeys(PHASES, 0.0)
        for phase, seconds in (state.get("wall_time_split") or {}).items():
            split[phase] = float(seconds)
        while steps < total:
            began = time.perf_counter()
            result = algo.train()
            _add_phases(split, result, time.perf_counter() - began, per_runner)
            state["wall_time_split"] = {k: round(v, 3) for k, v in split.items()}
            now = int(result["num_env_steps_sampled_lifetime"])
            if bar is not None:
                metrics = result.get("env_runners", {})
                bar.update(now - steps)
                bar.set_postfix(
                    success=f"{float(metrics.get('success_rate', 0.0)):.2f}",
                    ret=f"{float(metrics.get('episode_return_mean', 0.0)):.1f}",
                )
            steps = state["env_steps"] = now
            if due(state, "next_eval", eval_every, steps):
                model = as_sb3(trained_module(algo), recipe, env_id, options)
                line = recorder.evaluate(model, steps)
                reason = stop_reason(recorder, line, patience, stop_at)
                if reason is not None:
                    run["stopped_early"] = {"env_steps": steps, "reason": reason}
                    say(f"stopping: {reason}")
                    break
            if due(state, "next_checkpoint", checkpoint_every, steps):
                save_checkpoint()
        if bar is not None:
            bar.close()
        run["env_steps"] = steps
        run["wall_time_s"] = round(recorder.wall_time(), 3)
        run["wall_time_split"] = {k: round(v, 3) for k, v in split.items()}
        model = as_sb3(trained_module(algo), recipe, env_id, options)
        last = run.get("last_evaluation") or {}
        if eval_every and last.get("env_steps") != steps:
            recorder.evaluate(model, steps)
        save_checkpoint()
    finally:
        algo.stop()
    return finish_run(model, out, run, final)
