"""Ray Tune over the stable-baselines3 recipes: seeds and hyperparameter sweeps, one
``panda-rapier train`` run per trial, on one machine or a Ray cluster.

Needs the ``rllib`` and ``train`` extras (``pip install "panda-rapier[train,rllib]"``)::

    import ray
    from ray import tune
    from panda_rapier.scale.tuning import sb3_tuner

    ray.init()  # on a cluster: ray.init(address="auto")
    tuner = sb3_tuner(
        "tqc",
        "panda_rapier/PickAndPlace-v0",
        seeds=[0, 1, 2],
        hyperparams={"learning_rate": tune.grid_search([3e-4, 1e-3])},
        timesteps=200_000,
        eval_every=50_000,
    )
    best = tuner.fit().get_best_result()  # by the last evaluation's success_rate
    print(best.config, best.metrics["success_rate"], best.path)

Each trial (:func:`sb3_trainable`) reads the recipe of ``algo`` on ``env_id`` (the package's
``hyperparams/ALGO.yml`` or ``conf``), applies the trial's ``hyperparams`` to it, writes the
result as a recipe file (``TRIAL_DIR/recipe.yml``: ``panda-rapier train --conf`` reruns the
trial alone) and trains with :func:`panda_rapier.learning.runner.train` into ``TRIAL_DIR/run`` (the
usual run directory: ``model.zip``, ``best.zip``, ``evaluations.jsonl``, ``run.json``,
TensorBoard logs). Every periodic evaluation (validation seeds, ``eval_episodes`` episodes)
is reported to Tune with ``tune.report``: ``success_rate``, ``success_ci95_low`` /
``success_ci95_high``, ``placed_rate``, ``mean_return``, ``env_steps``, ``wall_time_s``.
Seeds are ``panda-rapier train``'s: trial seed ``s`` trains on the environment seeds from
``TRAIN_FIRST_SEED + 1_000_000 * s`` and initialises the network from ``s``.
"""

from __future__ import annotations

import inspect
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

try:
    import ray
    from ray import tune
except ImportError as error:  # pragma: no cover - exercised only without the extra
    raise ImportError(
        "panda_rapier.scale.tuning needs Ray Tune: pip install 'panda-rapier[rllib]'"
    ) from error

from ..errors import ConfigError, InvalidArgumentError
from ..learning.recipes import algorithm_class, load_recipe
from ..learning.runner import train
from ..registration import ENV_IDS

__all__ = ["METRICS", "TUNE_ALGORITHMS", "check_sweep", "sb3_trainable", "sb3_tuner"]

#: The stable-baselines3 algorithms a sweep trains (``panda-rapier train --algo``).
TUNE_ALGORITHMS = ("ppo", "sac", "tqc")
#: What every trial reports at each evaluation.
METRICS = (
    "success_rate",
    "success_ci95_low",
    "success_ci95_high",
    "placed_rate",
    "mean_return",
    "env_steps",
    "wall_time_s",
)
# The trial config's keys, with their defaults (None: the recipe's or train()'s).
_TRIAL_KEYS: dict[str, Any] = {
    "algo": None,
    "env_id": None,
    "seed": 0,
    "hyperparams": {},
    "conf": None,
    "timesteps": None,
    "n_envs": None,
    "env_kwargs": {},
    "eval_every": None,
    "eval_episodes": 100,
    "num_threads": 1,
    "torch_threads": 1,
}
# Recipe keys that are not constructor arguments of the algorithm (rl-zoo3's run keys).
_RECIPE_RUN_KEYS = ("n_timesteps", "policy", "n_envs", "env_kwargs", "callback")


def _plain(value: Any) -> Any:
    """Tune's sampled values as YAML-safe builtins (numpy scalars become Python numbers)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    item = getattr(value, "item", None)
    if callable(item) and not isinstance(value, str | bytes):
        return item()
    return value


def _constructor_arguments(cls: type) -> set[str]:
    """The keyword arguments ``cls(env, ...)`` takes: its ``__init__``'s named parameters and,
    where that forwards ``**kwargs`` (a subclass such as :class:`panda_rapier.learning.PPO`),
    those of the base classes it forwards to, without ``self``, ``env``, ``*args`` or
    ``**kwargs``."""
    names: set[str] = set()
    for klass in cls.__mro__:
        if "__init__" not in vars(klass) or klass is object:
            continue
        parameters = inspect.signature(vars(klass)["__init__"]).parameters.values()
        names |= {
            p.name
            for p in parameters
            if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD) and p.name not in ("self", "env")
        }
        if not any(p.kind is p.VAR_KEYWORD for p in parameters):
            break
    return names


def check_sweep(
    algo: str,
    env_id: str,
    hyperparams: Mapping[str, Any] | None = None,
    conf: str | Path | None = None,
) -> dict[str, Any]:
    """Checks a sweep before Ray starts any trial and returns the recipe it starts from:
    ``algo`` in :data:`TUNE_ALGORITHMS`, ``env_id`` in ``panda_rapier.ENV_IDS`` with a recipe
    (in ``conf`` or the package's), and every key of ``hyperparams`` a recipe key (the
    algorithm's constructor arguments, ``n_timesteps``, ``n_envs``, ``policy``, ``env_kwargs``,
    ``callback``). Errors are :class:`~panda_rapier.InvalidArgumentError` /
    :class:`~panda_rapier.ConfigError`."""
    if algo not in TUNE_ALGORITHMS:
        raise InvalidArgumentError(f"algo must be one of {TUNE_ALGORITHMS}, got {algo!r}")
    if env_id not in ENV_IDS:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS")
    recipe = load_recipe(algo, env_id, conf)
    if hyperparams is not None and not isinstance(hyperparams, Mapping):
        raise InvalidArgumentError(f"hyperparams must be a mapping, got {hyperparams!r}")
    known = _constructor_arguments(algorithm_class(algo)) | set(_RECIPE_RUN_KEYS)
    unknown = sorted(set(hyperparams or {}) - known)
    if unknown:
        raise ConfigError(f"unknown {algo} hyperparameters {unknown}; recipe keys: {sorted(known)}")
    return recipe


def sb3_trainable(config: Mapping[str, Any]) -> None:
    """A Ray Tune function trainable: one ``panda-rapier train`` run (see the module's
    documentation), reporting :data:`METRICS` at every evaluation.

    ``config`` keys: ``algo`` and ``env_id`` (required); ``seed`` (0); ``hyperparams``
    (recipe overrides, ``{}``); ``conf`` (a recipe file; default the package's);
    ``timesteps``, ``n_envs`` (default: the recipe's); ``env_kwargs`` (environment options
    added to the recipe's); ``eval_every`` (env steps between evaluations; default
    ``timesteps``: one evaluation at the end); ``eval_episodes`` (100); ``num_threads`` (the
    vector env's Rust threads, 1) and ``torch_threads`` (1): match them to the trial's CPUs
    (``tune.with_resources``).
    """
    import yaml

    unknown = sorted(set(config) - set(_TRIAL_KEYS))
    if unknown:
        raise ConfigError(
            f"unknown sb3_trainable config keys {unknown}; known: {list(_TRIAL_KEYS)}"
        )
    settings = {**_TRIAL_KEYS, **dict(config)}
    algo, env_id = settings["algo"], settings["env_id"]
    hyperparams = _plain(dict(settings["hyperparams"] or {}))
    recipe = {**check_sweep(algo, env_id, hyperparams, settings["conf"]), **hyperparams}
    timesteps = settings["timesteps"]
    total = int(timesteps if timesteps is not None else recipe.get("n_timesteps", 1_000_000))
    eval_every = int(settings["eval_every"] if settings["eval_every"] is not None else total)
    if eval_every < 1:
        raise InvalidArgumentError(
            f"eval_every must be >= 1 (trials report evaluations), got {eval_every}"
        )

    trial_dir = Path(tune.get_context().get_trial_dir())
    trial_dir.mkdir(parents=True, exist_ok=True)
    recipe_file = trial_dir / "recipe.yml"
    recipe_file.write_text(yaml.safe_dump({env_id: _plain(recipe)}, sort_keys=False))

    run_dir = trial_dir / "run"
    resume = _restore(run_dir)
    _log_attempt(run_dir, resume)
    pending: list[dict[str, Any]] = []

    def metrics_of(line: Mapping[str, Any]) -> dict[str, Any]:
        low, high = line["success_ci95"]
        metrics = {key: line[key] for key in METRICS if key in line}
        return {**metrics, "success_ci95_low": low, "success_ci95_high": high}

    def checkpointed(out: Path) -> None:
        """Reports the evaluation just made with the checkpoint just written (the run
        directory's resumable part), which Tune keeps in its storage."""
        if not pending:
            return
        line = pending.pop()
        with tempfile.TemporaryDirectory() as staging:
            for name in _RESUMABLE:
                source = out / name
                if source.is_dir():
                    shutil.copytree(source, Path(staging) / name)
                elif source.is_file():
                    shutil.copy2(source, Path(staging) / name)
            tune.report(metrics_of(line), checkpoint=tune.Checkpoint.from_directory(staging))

    train(
        algo,
        env_id,
        run_dir,
        conf=recipe_file,
        seed=int(settings["seed"]),
        timesteps=total,
        n_envs=settings["n_envs"],
        num_threads=settings["num_threads"],
        env_kwargs=_plain(dict(settings["env_kwargs"] or {})),
        eval_every=eval_every,
        eval_episodes=int(settings["eval_episodes"]),
        checkpoint_every=eval_every,
        resume=resume,
        # Tune's scheduler decides when a trial stops, and what it reports is the last
        # evaluation: the recipe's patience and final weights are not the trial's.
        patience=0,
        final="last",
        torch_threads=int(settings["torch_threads"]),
        progress=False,
        command=["ray.tune", "panda_rapier.scale.tuning.sb3_trainable", str(trial_dir)],
        on_evaluation=pending.append,
        on_checkpoint=checkpointed,
    )
    for line in pending:  # an evaluation after the last checkpoint (none in a plain run)
        tune.report(metrics_of(line))


#: What a trial's checkpoint holds of its run directory: what ``train(resume=True)`` reads.
#: ``attempts.jsonl`` rides along, so every checkpoint in Tune's storage lists the attempts
#: before it, even those whose node died (a node's working directory dies with it).
_RESUMABLE = ("checkpoints", "run.json", "evaluations.jsonl", "best.zip", "attempts.jsonl")


def _restore(run_dir: Path) -> bool:
    """Fills ``run_dir`` from the trial's last checkpoint when Tune retries a failed trial
    (``tune.get_checkpoint()``); True if the run is to be resumed. A retried trial without
    one starts over."""
    checkpoint = tune.get_checkpoint()
    if run_dir.exists():
        shutil.rmtree(run_dir)
    if checkpoint is None:
        return False
    with checkpoint.as_directory() as folder:
        shutil.copytree(folder, run_dir)
    return True


def _log_attempt(run_dir: Path, resumed: bool) -> None:
    """Appends this attempt of the trial to ``RUN_DIR/attempts.jsonl`` (restored from the
    checkpoint with the rest of the run): the Ray node and host it runs on, and the env steps
    it resumes from (0: from the start)."""
    import json
    import socket
    import time

    steps = 0
    if resumed:
        state = json.loads((run_dir / "checkpoints" / "state.json").read_text())
        steps = int(state.get("num_timesteps", 0))
    line = {
        "node_id": ray.get_runtime_context().get_node_id(),
        "host": socket.gethostname(),
        "started": time.time(),
        "resumed_from_env_steps": steps,
    }
    run_dir.mkdir(parents=True, exist_ok=True)
    with (run_dir / "attempts.jsonl").open("a") as file:
        file.write(json.dumps(line) + "\n")


def sb3_tuner(
    algo: str,
    env_id: str,
    *,
    seeds: Sequence[int] = (0,),
    hyperparams: Mapping[str, Any] | None = None,
    timesteps: int | None = None,
    n_envs: int | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    eval_every: int | None = None,
    eval_episodes: int = 100,
    conf: str | Path | None = None,
    cpus_per_trial: int = 1,
    num_samples: int = 1,
    max_concurrent_trials: int | None = None,
    storage_path: str | Path | None = None,
    name: str | None = None,
    max_failures: int = 2,
) -> tune.Tuner:
    """A ``ray.tune.Tuner`` over :func:`sb3_trainable`: one trial per seed in ``seeds`` (a
    grid) and per point of ``hyperparams``' search space (recipe overrides whose values may
    be Tune search spaces: ``tune.grid_search``, ``tune.loguniform``, ...; ``num_samples``
    draws of the random ones), picking the best by the last reported ``success_rate``.

    Each trial takes ``cpus_per_trial`` CPUs, as many Rust threads for its vector env and one
    torch thread. ``storage_path`` (default Ray's ``~/ray_results``; on a multi-node cluster a
    shared or cloud path) and ``name`` are Tune's ``RunConfig``'s. The sweep is checked
    (:func:`check_sweep`) before anything starts. ``tuner.fit()`` runs it and returns Tune's
    ``ResultGrid``.

    Fault tolerance: a trial checkpoints its run at every evaluation (Tune keeps the
    checkpoints in its storage); a trial that fails, for instance because its node died, is
    started again up to ``max_failures`` times, on any node with room, and goes on from its
    last checkpoint (``panda-rapier train --resume``). ``TRIAL_DIR/run/attempts.jsonl`` lists
    each attempt's node and the env steps it resumed from; each checkpoint carries the list as
    it stood then.
    """
    check_sweep(algo, env_id, hyperparams, conf)
    seeds = list(seeds)
    if not seeds or any(isinstance(s, bool) or not isinstance(s, int) or s < 0 for s in seeds):
        raise InvalidArgumentError(f"seeds must be a non-empty list of ints >= 0, got {seeds!r}")
    if (
        isinstance(cpus_per_trial, bool)
        or not isinstance(cpus_per_trial, int)
        or cpus_per_trial < 1
    ):
        raise InvalidArgumentError(f"cpus_per_trial must be an int >= 1, got {cpus_per_trial!r}")
    param_space = {
        "algo": algo,
        "env_id": env_id,
        "seed": tune.grid_search(seeds),
        "hyperparams": dict(hyperparams or {}),
        "conf": None if conf is None else str(Path(conf).resolve()),
        "timesteps": timesteps,
        "n_envs": n_envs,
        "env_kwargs": dict(env_kwargs or {}),
        "eval_every": eval_every,
        "eval_episodes": eval_episodes,
        "num_threads": cpus_per_trial,
        "torch_threads": 1,
    }
    return tune.Tuner(
        tune.with_resources(sb3_trainable, {"cpu": cpus_per_trial}),
        param_space=param_space,
        tune_config=tune.TuneConfig(
            metric="success_rate",
            mode="max",
            num_samples=num_samples,
            max_concurrent_trials=max_concurrent_trials,
        ),
        run_config=tune.RunConfig(
            storage_path=None if storage_path is None else str(Path(storage_path).resolve()),
            name=name,
            failure_config=tune.FailureConfig(max_failures=max_failures),
        ),
    )
