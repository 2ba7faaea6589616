"""Training: what ``panda-rapier train`` runs.

A run trains one algorithm on one registered id with the native stable-baselines3 ``VecEnv``
and writes everything to its output directory:

- ``model.zip`` (the final model; ``best.zip``: the best periodic evaluation's), loadable by
  stable-baselines3 and by ``panda-rapier eval --policy DIR/model.zip`` with no other flag: the
  env id and every environment option are stored inside the zip (``panda_rapier_run.json``)
  and in ``run.json``;
- ``run.json``: versions, seeds, hyperparameters, the command, steps, wall time and the last
  evaluation; for the SB3 algorithms, where the wall time went (``wall_time_split``: seconds
  of env stepping, the policy's forward passes in rollouts, other rollout work and updates,
  :mod:`panda_rapier.phases`);
- ``evaluations.jsonl``: one line per periodic evaluation (env steps, wall time, success rate
  with its 95 % interval, placed rate, mean return) on validation seeds, which neither the
  training episodes nor the final test seeds (``panda-rapier eval``'s default, 0 to 999) use;
- ``tensorboard/`` (``tensorboard --logdir DIR``) and ``checkpoints/`` for ``--resume``
  (:mod:`panda_rapier.checkpoint`: read by data, nothing in it unpickled but a replay buffer
  this user's runs signed);
- for ``bc``: ``demonstrations.npz``, every state gathered with the expert's action in it
  (:meth:`panda_rapier.imitation.Demonstrations.load`).

Hyperparameters come from a recipe file in rl-zoo3's YAML format (one entry per env id; the
package's own in ``panda_rapier/hyperparams/ALGO.yml``), so ``python -m rl_zoo3.train --algo
ppo --env ID --gym-packages panda_rapier -conf FILE`` reads the same file. ``bc`` (behaviour
cloning and DAgger from the scripted expert, :mod:`panda_rapier.imitation`) is ours; its
recipe has its own keys and it saves a PPO model.

Seeds: the training environments and the expert's demonstrations are seeded from
``TRAIN_FIRST_SEED + 1_000_000 * seed`` (a resumed run's environments from that plus the
steps already done), periodic evaluations use ``VALIDATION_FIRST_SEED`` onwards, and the
final test (``panda-rapier eval``) seeds ``0, 1, ...``.

Over 600 lines: recipes, the SB3 run loop with evaluation/checkpoints/resume/--init-from and
the bc run live together; moving the bc run into :mod:`.imitation` is the planned split.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from collections.abc import Callable, Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from . import __version__, checkpoint
from .errors import ConfigError, InvalidArgumentError

# Re-exported: the run record's member name, reader and writer were first found here.
from .model_file import RUN_MEMBER as RUN_MEMBER
from .model_file import read_run_info as read_run_info
from .model_file import save_model as save_model
from .pixels import plain_observation, split_options
from .registration import ENV_IDS, env_config, task_places, variant

__all__ = [
    "ALGORITHMS",
    "TRAIN_FIRST_SEED",
    "VALIDATION_FIRST_SEED",
    "load_recipe",
    "model_kwargs",
    "read_run_info",
    "recipes_train_alike",
    "train",
]

#: Algorithms ``panda-rapier train`` knows.
ALGORITHMS = ("ppo", "sac", "tqc", "bc")
#: First seed of the training episodes (run seed 0).
TRAIN_FIRST_SEED = 1_000_000_000
#: First seed of the periodic evaluations during training.
VALIDATION_FIRST_SEED = 500_000_000

# Recipe keys that configure the run rather than the algorithm (rl-zoo3's names).
# `monitor_kwargs` only matters to rl-zoo3 (its Monitor wrappers); the native VecEnv reports
# `is_success` and `is_placed` in every info, and the periodic evaluations log both.
_RUN_KEYS = (
    "n_timesteps",
    "policy",
    "n_envs",
    "env_kwargs",
    "callback",
    "normalize",
    "monitor_kwargs",
)
_UNSUPPORTED = ("frame_stack", "env_wrapper", "vec_env_wrapper")
# Recipe keys ``panda-rapier train`` does not read at all.
_ZOO_ONLY_KEYS = ("monitor_kwargs",)
_BC_KEYS = {
    "policy": "MultiInputPolicy",
    "policy_kwargs": None,
    "n_envs": 32,
    "demo_episodes": 200,
    "dagger_rounds": 8,
    "dagger_episodes": 250,
    "epochs": 30,
    "dagger_epochs": 10,
    "final_epochs": 20,
    "batch_size": 256,
    "learning_rate": 1e-3,
}
# A bc recipe with a ``student`` entry: DAgger of a policy that sees (panda_rapier.student).
_STUDENT_KEYS = {
    "env_kwargs": None,
    "student": None,
    "n_envs": 32,
    "demo_episodes": 200,
    "dagger_rounds": 8,
    "dagger_episodes": 200,
    "first_updates": 3000,
    "round_updates": 1500,
    "final_updates": 4000,
    "batch_size": 128,
    "learning_rate": 3e-4,
}


def _yaml() -> Any:
    try:
        import yaml
    except ImportError as error:  # pragma: no cover - part of the train extra
        raise ImportError("recipes need PyYAML: pip install 'panda-rapier[train]'") from error
    return yaml


def default_recipe_path(algo: str) -> Path:
    """The package's recipe file for ``algo``."""
    return Path(str(resources.files("panda_rapier") / "hyperparams" / f"{algo}.yml"))


def _recipe_file(algo: str, conf: str | Path | None) -> tuple[Path, Any]:
    """The recipe file ``conf`` (else the package's for ``algo``) and its parsed content."""
    path = Path(conf) if conf is not None else default_recipe_path(algo)
    try:
        return path, _yaml().safe_load(path.read_text())
    except OSError as error:
        raise ConfigError(f"cannot read the recipe file {path}: {error}") from error


def load_recipe(algo: str, env_id: str, conf: str | Path | None = None) -> dict[str, Any]:
    """The hyperparameters of ``algo`` on ``env_id`` from a recipe file (rl-zoo3's format:
    a mapping from env id to hyperparameters; default: the package's ``hyperparams/ALGO.yml``)."""
    if algo not in ALGORITHMS:
        raise InvalidArgumentError(f"algo must be one of {ALGORITHMS}, got {algo!r}")
    path, recipes = _recipe_file(algo, conf)
    if not isinstance(recipes, Mapping) or env_id not in recipes:
        known = sorted(recipes) if isinstance(recipes, Mapping) else []
        raise ConfigError(f"{path} has no recipe for {env_id}; it has {known}")
    recipe = dict(recipes[env_id] or {})
    for key in _UNSUPPORTED:
        if key in recipe:
            raise ConfigError(f"recipe key {key!r} is not supported by panda-rapier train")
    if recipe.get("normalize"):
        raise ConfigError(
            "recipe key 'normalize' (VecNormalize) is not used here: normalise inside the "
            "network with features_extractor_class=NormalizedFlatten, so the saved model is "
            "self-contained"
        )
    if algo == "bc":
        keys = _STUDENT_KEYS if "student" in recipe else _BC_KEYS
        unknown = set(recipe) - set(keys)
        if unknown:
            raise ConfigError(f"unknown bc recipe keys {sorted(unknown)}; known: {list(keys)}")
        return {**keys, **recipe}
    return recipe


def recipes_train_alike(first: Mapping[str, Any], second: Mapping[str, Any]) -> bool:
    """Whether ``panda-rapier train`` trains the same way with either recipe: equal but for
    the keys only rl-zoo3 reads (``monitor_kwargs``)."""

    def used(recipe: Mapping[str, Any]) -> dict[str, Any]:
        return {k: v for k, v in recipe.items() if k not in _ZOO_ONLY_KEYS}

    return used(first) == used(second)


def _schedule(value: Any) -> Any:
    """rl-zoo3's ``lin_X`` strings: a linear decay from X to 0."""
    if isinstance(value, str) and value.startswith("lin_"):
        start = float(value[4:])
        return lambda progress_remaining: progress_remaining * start
    return value


def _evaluate_expression(text: str) -> Any:
    """rl-zoo3 evaluates string-valued ``policy_kwargs`` / ``replay_buffer_kwargs`` as Python;
    the same names are available here (``nn``, ``th``), plus ``NormalizedFlatten``."""
    import torch as th
    from torch import nn

    from .normalization import NormalizedFlatten

    names = {"nn": nn, "th": th, "torch": th, "NormalizedFlatten": NormalizedFlatten}
    try:
        return eval(text, names)
    except Exception as error:
        raise ConfigError(f"cannot evaluate recipe expression {text!r}: {error}") from error


def _callbacks(spec: Any) -> list[Any]:
    """Callbacks named in a recipe (rl-zoo3: a class path, or a mapping of it to kwargs, or a
    list of either)."""
    import importlib

    items = spec if isinstance(spec, list) else [spec] if spec else []
    built = []
    for item in items:
        path, kwargs = next(iter(item.items())) if isinstance(item, Mapping) else (item, {})
        module, _, name = str(path).rpartition(".")
        try:
            built.append(getattr(importlib.import_module(module), name)(**(kwargs or {})))
        except (ImportError, AttributeError, TypeError) as error:
            raise ConfigError(f"cannot build the recipe callback {path!r}: {error}") from error
    return built


def _algorithm_class(algo: str, stock: bool = False) -> Any:
    """The class that trains ``algo``: :class:`panda_rapier.ppo.PPO` for ppo (SB3's own with
    ``stock``), else stable-baselines3's or sb3-contrib's."""
    if algo == "tqc":
        from sb3_contrib import TQC

        return TQC
    if algo == "ppo" and not stock:
        from .ppo import PPO

        return PPO
    import stable_baselines3

    return getattr(stable_baselines3, "PPO" if algo == "bc" else algo.upper())


def model_kwargs(algo: str, recipe: Mapping[str, Any]) -> dict[str, Any]:
    """The algorithm's constructor arguments from a recipe (rl-zoo3's conventions: string
    ``policy_kwargs`` / ``replay_buffer_kwargs`` evaluated, ``lin_X`` schedules,
    ``HerReplayBuffer`` by name), without the keys that configure the run."""
    kwargs = {k: v for k, v in recipe.items() if k not in _RUN_KEYS}
    for key in ("policy_kwargs", "replay_buffer_kwargs"):
        if isinstance(kwargs.get(key), str):
            kwargs[key] = _evaluate_expression(kwargs[key])
    for key in ("learning_rate", "clip_range"):
        if key in kwargs:
            kwargs[key] = _schedule(kwargs[key])
    if isinstance(kwargs.get("replay_buffer_class"), str):
        from stable_baselines3 import HerReplayBuffer

        if kwargs["replay_buffer_class"] != "HerReplayBuffer":
            raise ConfigError(f"unknown replay_buffer_class {kwargs['replay_buffer_class']!r}")
        kwargs["replay_buffer_class"] = HerReplayBuffer
    return kwargs


def versions() -> dict[str, str]:
    """Versions of what a run depends on."""
    found = {"panda_rapier": __version__, "python": platform.python_version()}
    for name in ("stable_baselines3", "sb3_contrib", "torch", "numpy", "gymnasium"):
        try:
            found[name] = str(__import__(name).__version__)
        except ImportError:
            pass
    return found


class _Recorder:
    """Periodic seeded evaluation on validation seeds, ``evaluations.jsonl`` and the best
    model; wall time counts the training, not the evaluations."""

    def __init__(
        self,
        out: Path,
        config: Mapping[str, Any],
        run: dict[str, Any],
        episodes: int,
        num_threads: int | None,
        wall_offset: float = 0.0,
        say: Callable[[str], None] = print,
        on_evaluation: Callable[[dict[str, Any]], None] | None = None,
        observation: Mapping[str, Any] | None = None,
    ) -> None:
        self.out = out
        #: The observation options the policy acts on (``obs_mode``, ``image_size``, ...).
        self.observation = dict(observation or {})
        self.on_evaluation = on_evaluation
        self.config = dict(config)
        self.run = run
        self.episodes = episodes
        self.num_threads = num_threads
        self.wall_offset = wall_offset
        self.eval_time = 0.0
        #: Seconds spent writing checkpoints (counted in the wall time, not in its split).
        self.checkpoint_time = 0.0
        self.started = time.perf_counter()
        self.say = say
        self.best: tuple[float, float] | None = None
        #: Evaluations since the best one (0: the last was the best).
        self.since_best = 0
        for line in _read_lines(out / "evaluations.jsonl"):
            self._rank(line)
            run["last_evaluation"] = line  # a resumed run knows where it stopped

    def _rank(self, line: Mapping[str, Any]) -> bool:
        """Ranks an evaluation against the best so far (placed rate, then success rate, as
        ``best.zip`` is chosen); True if it is the new best. An evaluation made while the
        actor was frozen (``actor_frozen``: a critic warm-up) can be the best but does not
        count towards ``--patience``: patience counts from the warm-up's end."""
        key = (float(line["placed_rate"]), float(line["success_rate"]))
        if self.best is None or key > self.best:
            self.best = key
            self.since_best = 0
            return True
        if not line.get("actor_frozen"):
            self.since_best += 1
        return False

    def wall_time(self) -> float:
        return self.wall_offset + time.perf_counter() - self.started - self.eval_time

    def evaluate(self, model: Any, env_steps: int, logger: Any = None) -> dict[str, Any]:
        from .evaluation import evaluate

        wall = self.wall_time()
        began = time.perf_counter()
        report = evaluate(
            model,
            self.config,
            self.episodes,
            num_envs=min(32, self.episodes),
            first_seed=VALIDATION_FIRST_SEED,
            num_threads=self.num_threads,
            **self.observation,
        )
        self.eval_time += time.perf_counter() - began
        summary = report.summary()
        line = {
            "env_steps": int(env_steps),
            "wall_time_s": round(wall, 3),
            "episodes": self.episodes,
            "first_seed": VALIDATION_FIRST_SEED,
            "success_rate": summary["success_rate"],
            "success_ci95": summary["success_ci95"],
            "placed_rate": summary["placed_rate"],
            "mean_return": summary["mean_return"],
        }
        if actor_frozen(model):
            line["actor_frozen"] = True
        with (self.out / "evaluations.jsonl").open("a") as file:
            file.write(json.dumps(line) + "\n")
        if logger is not None:
            for key in ("success_rate", "placed_rate", "mean_return"):
                logger.record(f"eval/{key}", line[key])
        low, high = line["success_ci95"]
        placed = (
            f", placed {line['placed_rate']:.3f}"
            if task_places(variant(str(self.run["env_id"]))["task"])
            else ""
        )
        self.say(
            f"[{env_steps:>10,} steps, {wall / 60:6.1f} min] validation success "
            f"{line['success_rate']:.3f} ({low:.3f}-{high:.3f}){placed}"
        )
        if self._rank(line):
            best = {**self.run, "evaluation": line}
            best.update(env_steps=line["env_steps"], wall_time_s=line["wall_time_s"])
            save_model(model, self.out / "best.zip", best)
        self.run["last_evaluation"] = line
        if self.on_evaluation is not None:
            self.on_evaluation(dict(line))
        return line


def _read_lines(path: Path) -> list[dict[str, Any]]:
    try:
        return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    except (OSError, ValueError):
        return []


def stop_reason(
    recorder: _Recorder, line: Mapping[str, Any], patience: int | None, stop_at: float | None
) -> str | None:
    """Why training stops after the evaluation ``line`` (``None``: it goes on): its success
    rate (and, on a task that places, its placed rate too) reached ``stop_at``, or
    ``patience`` evaluations in a row have not beaten the best."""
    if stop_at is not None:
        success = float(line["success_rate"])
        if task_places(variant(str(recorder.run["env_id"]))["task"]):
            placed = float(line["placed_rate"])
            if min(success, placed) >= stop_at:
                return (
                    f"validation success {success:.3f} and placed {placed:.3f} reached "
                    f"--stop-at {stop_at}"
                )
        elif success >= stop_at:
            return f"validation success {success:.3f} reached --stop-at {stop_at}"
    if patience is not None and recorder.since_best >= patience:
        return f"{recorder.since_best} evaluations without beating the best (--patience {patience})"
    return None


def _sb3_callback(
    recorder: _Recorder,
    eval_every: int,
    checkpoint_every: int,
    state: dict[str, Any],
    patience: int | None = None,
    stop_at: float | None = None,
    split: Callable[[], dict[str, float]] | None = None,
    on_checkpoint: Callable[[Path], None] | None = None,
) -> Any:
    from stable_baselines3.common.callbacks import BaseCallback

    out = recorder.out

    class Periodic(BaseCallback):
        def _on_step(self) -> bool:
            steps = self.num_timesteps
            if due(state, "next_eval", eval_every, steps):
                line = recorder.evaluate(self.model, steps, self.logger)
                reason = stop_reason(recorder, line, patience, stop_at)
                if reason is not None:
                    recorder.run["stopped_early"] = {"env_steps": int(steps), "reason": reason}
                    recorder.say(f"stopping: {reason}")
                    return False
            if due(state, "next_checkpoint", checkpoint_every, steps):
                self.save_checkpoint()
            return True

        def save_checkpoint(self) -> None:
            began = time.perf_counter()
            saved = {**state, "num_timesteps": self.num_timesteps}
            saved["wall_time_s"] = recorder.wall_time()
            if split is not None:
                saved["wall_time_split"] = split()
            checkpoint.save(self.model, out / "checkpoints", saved, recorder.run)
            (out / "run.json").write_text(json.dumps(recorder.run, indent=2, default=str))
            recorder.checkpoint_time += time.perf_counter() - began
            if on_checkpoint is not None:
                on_checkpoint(out)

    return Periodic()


def train(
    algo: str,
    env_id: str,
    out: str | Path,
    *,
    conf: str | Path | None = None,
    seed: int = 0,
    timesteps: int | None = None,
    n_envs: int | None = None,
    num_threads: int | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    eval_every: int | None = None,
    eval_episodes: int | None = None,
    checkpoint_every: int | None = None,
    resume: bool = False,
    init_from: str | Path | None = None,
    trust: bool = False,
    torch_threads: int = 1,
    update_threads: int | None = None,
    progress: bool = True,
    command: list[str] | None = None,
    say: Callable[[str], None] = print,
    on_evaluation: Callable[[dict[str, Any]], None] | None = None,
    patience: int | None = None,
    stop_at: float | None = None,
    final: str | None = None,
    on_checkpoint: Callable[[Path], None] | None = None,
    default_eval_every: int | None = None,
    stock_sb3: bool = False,
    overlap_updates: bool | None = None,
) -> dict[str, Any]:
    """Trains ``algo`` on ``env_id`` with its recipe and writes the run to ``out`` (see the
    module's documentation); returns the run record. ``timesteps`` and ``n_envs`` override
    the recipe's; ``env_kwargs`` are added to the recipe's environment options. ``init_from``
    (a model saved by this algorithm, with the same observation and action spaces) gives the
    network its starting weights, observation normaliser included: fine-tuning. From a cloned
    policy (a ``bc`` run's model, for ``ppo``) only its actor and normaliser are taken
    (:func:`_load_weights`); the recipe's ``panda_rapier.finetune.CriticWarmup`` then lets
    the new value function catch up before the actor changes. The run record
    keeps that model's own run record, so its training time can be added up. ``resume`` goes
    on from ``out``'s checkpoint with the recipe and options the run recorded, reading the
    checkpoint by data (:mod:`panda_rapier.checkpoint`; ``trust`` lets it unpickle a replay
    buffer this user's runs did not write). ``on_evaluation`` is called with each periodic
    evaluation's line of ``evaluations.jsonl`` (env steps, wall time, success and placed rate,
    mean return), after it is written and ``best.zip`` is saved: :mod:`panda_rapier.tuning`
    reports them to Ray Tune; ``on_checkpoint`` with ``out`` after each checkpoint is written
    (``out/checkpoints``, ``run.json`` and ``evaluations.jsonl`` are then a resumable whole).
    torch runs on ``torch_threads`` threads while environments step
    and on ``update_threads`` (``None``: every core) while nothing else runs: PPO's updates and
    behaviour cloning's fits (:mod:`panda_rapier.threads`). PPO is trained by
    :class:`panda_rapier.ppo.PPO` (SB3's algorithm with cheaper loops), or with ``stock_sb3``
    by ``stable_baselines3.PPO`` itself (``panda-rapier bench-train`` compares the two); the
    run record names the class in ``algorithm_class``. ``overlap_updates`` (ppo with
    :class:`panda_rapier.ppo.PPO` only) runs each update in a learner process while the next
    rollout is collected, by the policy from before that update (:mod:`panda_rapier.overlap`);
    the run record keeps it, and a resumed run keeps what it recorded (``None``: that, else
    ``False``).

    Early stopping, judged on the periodic evaluations: training ends once an evaluation's
    success rate reaches ``stop_at``, or after ``patience`` evaluations in a row that do not
    beat the best (ranked as ``best.zip`` is: placed rate, then success rate); the run record
    says why in ``stopped_early``. ``final`` chooses what ``model.zip`` holds: ``"last"``, the
    weights training ended with, or ``"best"``, the best evaluation's (``best.zip``'s), so
    that a run's final model is never one that fell back after its best evaluation; the run
    record's ``final_weights`` says which evaluation's they are.

    ``eval_every``, ``eval_episodes``, ``patience`` and ``final`` left ``None`` take the
    recipe file's validation entry for ``env_id`` (:func:`recipe_validation`; a resumed run
    keeps what it recorded), else ``default_eval_every`` (none), 100, none and ``"last"``
    (:func:`resolve_validation`); the run record keeps them under ``validation``."""
    import torch as th

    from .phases import PhaseClock, describe_split
    from .threads import UpdateThreads, all_cores

    if env_id not in ENV_IDS:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS")
    th.set_num_threads(torch_threads)
    out = Path(out)
    recipe = load_recipe(algo, env_id, conf)
    train_seed = TRAIN_FIRST_SEED + 1_000_000 * int(seed)
    state_file = out / "checkpoints" / "state.json"
    given = {"every": eval_every, "episodes": eval_episodes, "patience": patience, "final": final}
    settings = resolve_validation(algo, env_id, conf, out, resume, given, stop_at,
                                  default_eval_every)  # fmt: skip
    eval_every, eval_episodes = settings["every"], int(settings["episodes"])
    patience, final = settings["patience"], str(settings["final"])
    previous, recipe, options = open_run(out, algo, env_id, resume, recipe, env_kwargs)
    student = _student_source(algo, previous, init_from)
    if student is not None:  # a student fine-tuned: it sees what it was trained on
        options = {**student[1], **options}
    config = env_config(env_id, **split_options(options)[0])
    observation = split_options(options)[1]
    run = run_record(algo, env_id, options, config, recipe, conf, seed, command, previous)
    run.update(
        train_first_seed=train_seed,
        torch_threads=torch_threads,
        update_threads=update_threads if update_threads is not None else all_cores(),
    )
    if init_from is not None:
        if resume:
            raise InvalidArgumentError("--init-from starts a new run; it cannot be resumed into")
        if not Path(init_from).is_file():
            raise InvalidArgumentError(f"--init-from: no model at {init_from}")
        run["init_from"] = {"path": str(init_from), "run": read_run_info(init_from)}
    if algo != "bc":
        run[VALIDATION] = settings
    if algo == "bc":
        if init_from is not None:
            raise InvalidArgumentError("bc runs start from the scripted expert, not --init-from")
        if resume or timesteps is not None:
            raise InvalidArgumentError(
                "bc runs are short and are not resumed; their length is the recipe's "
                "demo_episodes and dagger_rounds, not --timesteps"
            )
        sees = observation.get("obs_mode", "state") != "state"
        if sees != ("student" in recipe):
            raise ConfigError(
                "a bc run on image observations needs a student recipe (a 'student' entry, "
                "e.g. models/recipes/bc-pixels.yml), and a student recipe needs obs_mode "
                f"proprio+rgb; got obs_mode {observation.get('obs_mode', 'state')!r}"
            )
        if sees:
            from .student import train_student

            recorder = _Recorder(out, config, run, eval_episodes, num_threads, 0.0, say,
                                 on_evaluation, plain_observation(observation))  # fmt: skip
            return train_student(
                run, recipe, config, observation, out, n_envs, num_threads, recorder, say,
                show_progress=progress, fit_threads=run["update_threads"],
            )  # fmt: skip
        return _train_bc(
            run, recipe, config, out, n_envs, num_threads, eval_episodes, say, on_evaluation,
            show_progress=progress, fit_threads=run["update_threads"],
        )  # fmt: skip

    from .sb3 import make_vec_env

    total = int(timesteps if timesteps is not None else recipe.get("n_timesteps", 1_000_000))
    n = int(n_envs if n_envs is not None else recipe.get("n_envs", 1))
    run.update(n_envs=n, n_timesteps=total)
    algorithm = _algorithm_class(algo, stock=stock_sb3)
    run["algorithm_class"] = f"{algorithm.__module__}.{algorithm.__qualname__}"
    if overlap_updates is None:
        overlap_updates = bool((previous or {}).get("overlap_updates", False)) if resume else False
    if overlap_updates and (algo != "ppo" or stock_sb3):
        raise InvalidArgumentError(
            "overlapped updates are for ppo trained by panda_rapier.ppo.PPO (not "
            f"{'stable_baselines3.PPO' if stock_sb3 else algo})"
        )
    run["overlap_updates"] = bool(overlap_updates)
    state: dict[str, Any] = {
        "next_eval": eval_every or 0,
        "next_checkpoint": checkpoint_every or 0,
        "wall_time_s": 0.0,
        "num_timesteps": 0,
    }
    if resume:
        state.update(json.loads(state_file.read_text()))
    # A resumed run's environments start from seeds its first part never used.
    env_seed = train_seed + int(state["num_timesteps"])
    env = make_vec_env(env_id, n_envs=n, seed=env_seed, num_threads=num_threads, **options)
    kwargs = model_kwargs(algo, recipe)
    if student is not None:
        run["student"], kwargs["policy_kwargs"] = _student_network(
            student[0], kwargs.get("policy_kwargs")
        )
    model = algorithm(
        recipe.get("policy", "MultiInputPolicy"),
        env,
        seed=int(seed),
        device="cpu",
        tensorboard_log=str(out / "tensorboard"),
        verbose=0,
        **kwargs,
    )
    if overlap_updates:
        model.overlap_updates = True
    if resume:
        # Rebuilt from the recorded recipe, then filled from the checkpoint by data alone.
        checkpoint.restore(model, out / "checkpoints", trust=trust)
        say(f"resuming {out} at {model.num_timesteps:,} steps")
    else:
        if init_from is not None:
            kept = _load_weights(model, Path(init_from))
            say(f"starting from the weights of {init_from}")
            if kept:
                say(
                    "a cloned policy: its actor and observation normaliser are taken; the "
                    "value function and action noise start as the recipe makes them"
                )
    recorder = _Recorder(
        out,
        config,
        run,
        eval_episodes,
        num_threads,
        float(state["wall_time_s"]),
        say,
        on_evaluation,
        plain_observation(observation),
    )
    (out / "run.json").write_text(json.dumps(run, indent=2, default=str))
    run["final"] = final
    clock = PhaseClock(lambda: recorder.eval_time + recorder.checkpoint_time)
    earlier: Mapping[str, Any] = state.get("wall_time_split") or {}  # a resumed run's first part

    def split() -> dict[str, float]:
        return {
            phase: round(float(earlier.get(phase, 0.0)) + seconds, 3)
            for phase, seconds in clock.split().items()
        }

    periodic = _sb3_callback(
        recorder, eval_every or 0, checkpoint_every or 0, state, patience, stop_at, split,
        on_checkpoint,
    )  # fmt: skip
    callbacks = [*_callbacks(recipe.get("callback")), periodic]
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm

    if isinstance(model, OnPolicyAlgorithm) and not overlap_updates:  # rollouts, updates take turns
        callbacks.append(UpdateThreads(run["update_threads"], rollout=torch_threads))
    callbacks.append(clock)
    remaining = total - int(model.num_timesteps)
    if remaining > 0:
        model.learn(
            remaining,
            callback=callbacks,
            progress_bar=progress,
            reset_num_timesteps=not resume,
            tb_log_name=algo,
        )
        run["wall_time_split"] = split()
        say(f"wall time: {describe_split(run['wall_time_split'])}")
    run["env_steps"] = int(model.num_timesteps)
    run["wall_time_s"] = round(recorder.wall_time(), 3)
    last = run.get("last_evaluation") or {}
    if eval_every and last.get("env_steps") != int(model.num_timesteps):
        recorder.evaluate(model, int(model.num_timesteps))
    if remaining > 0:
        periodic.save_checkpoint()  # a later --resume with more --timesteps goes on
    return finish_run(model, out, run, final)


#: The ``policy_kwargs`` a recipe may set when it fine-tunes a student: the rest of the
#: network is the student's (:func:`_student_network`).
STUDENT_FINETUNE_POLICY_KWARGS = ("log_std_init", "ortho_init", "share_features_extractor")


def _student_source(
    algo: str, previous: Mapping[str, Any] | None, init_from: str | Path | None
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """For an RL run that fine-tunes a student (:mod:`panda_rapier.student`, a policy that
    sees): its architecture and the observation options it was trained with (taken from the
    ``--init-from`` model's run record, or from the run's own record when it is resumed);
    ``None`` for any other run."""
    if algo == "bc":
        return None
    if previous is not None:
        source: Any = previous if isinstance(previous.get("student"), Mapping) else None
    elif init_from is not None and Path(init_from).is_file():
        source = read_run_info(init_from)
    else:
        source = None
    if not isinstance(source, Mapping) or not isinstance(source.get("student"), Mapping):
        return None
    if algo != "ppo":
        raise InvalidArgumentError(
            f"a student (a policy that sees) is fine-tuned with ppo, not {algo}: its network "
            "is an actor-critic policy"
        )
    from .student_model import student_architecture

    arch = student_architecture(source["student"])
    options = source.get("env_kwargs")
    if not isinstance(options, Mapping):
        raise InvalidArgumentError("the student's run record has no environment options")
    return arch, split_options(options)[1]


def _student_network(
    arch: Mapping[str, Any], recipe: Mapping[str, Any] | None
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The architecture (as the run record keeps it, for :func:`~panda_rapier.student_model.
    load_student`) and ``policy_kwargs`` of a fine-tuned student: its own network (``arch``),
    with the recipe's :data:`STUDENT_FINETUNE_POLICY_KWARGS` (the action noise's start;
    ``share_features_extractor=False`` gives the value function its own copy of the image
    encoder, so the value loss no longer moves the actor's); any other entry in the recipe's
    would contradict the student's and is a ConfigError."""
    from .student_model import policy_kwargs, student_architecture

    recipe = dict(recipe or {})
    other = sorted(set(recipe) - set(STUDENT_FINETUNE_POLICY_KWARGS))
    if other:
        raise ConfigError(
            f"a student's fine-tune takes the student's network; its recipe's policy_kwargs "
            f"may set only {list(STUDENT_FINETUNE_POLICY_KWARGS)}, not {other}"
        )
    share = recipe.pop("share_features_extractor", arch.get("share_features_extractor", True))
    arch = student_architecture({**arch, "share_features_extractor": share})
    return arch, {**policy_kwargs(arch), **recipe}


def open_run(
    out: Path,
    algo: str,
    env_id: str,
    resume: bool,
    recipe: Mapping[str, Any],
    env_kwargs: Mapping[str, Any] | None,
) -> tuple[dict[str, Any] | None, dict[str, Any], dict[str, Any]]:
    """Checks that ``out`` can take the run (a checkpoint to resume from, or no run yet) and
    creates it; returns the earlier run record (``None`` for a new run), the recipe and the
    environment options the run trains with: a resumed run goes on with the ones it recorded,
    ``env_kwargs`` added to the options."""
    state_file = out / "checkpoints" / "state.json"
    previous = None
    if resume:
        if not state_file.is_file():
            raise InvalidArgumentError(f"nothing to resume: {state_file} does not exist")
        previous = json.loads((out / "run.json").read_text())
        if previous.get("algo") != algo or previous.get("env_id") != env_id:
            raise InvalidArgumentError(
                f"{out} holds a {previous.get('algo')} run on {previous.get('env_id')}"
            )
        if isinstance(previous.get("recipe"), dict):
            recipe = previous["recipe"]
        recorded = previous.get("env_kwargs")
        base = recorded if isinstance(recorded, dict) else {}
    elif (out / "run.json").exists():
        raise InvalidArgumentError(f"{out} already holds a run: pass --resume or another --out")
    else:
        base = dict(recipe.get("env_kwargs") or {})
    out.mkdir(parents=True, exist_ok=True)
    return previous, dict(recipe), {**base, **dict(env_kwargs or {})}


def run_record(
    algo: str,
    env_id: str,
    options: Mapping[str, Any],
    config: Mapping[str, Any],
    recipe: Mapping[str, Any],
    conf: str | Path | None,
    seed: int,
    command: list[str] | None,
    previous: Mapping[str, Any] | None,
) -> dict[str, Any]:
    """The run record's entries every trainer writes (a resumed run keeps its first command
    and lists the later ones in ``resumed_with``)."""
    run: dict[str, Any] = {
        "algo": algo,
        "saved_algo": "ppo" if algo == "bc" else algo,
        "env_id": env_id,
        "env_kwargs": dict(options),
        "config": dict(config),
        "recipe": dict(recipe),
        "recipe_file": str(conf) if conf is not None else f"panda_rapier/hyperparams/{algo}.yml",
        "seed": int(seed),
        "validation_first_seed": VALIDATION_FIRST_SEED,
        "command": command if command is not None else sys.argv,
        "versions": versions(),
        "machine": _machine(),
    }
    if previous is not None:
        run["command"] = previous.get("command", run["command"])
        run["resumed_with"] = [*previous.get("resumed_with", []), command or sys.argv]
    return run


def _machine() -> dict[str, Any]:
    """Where a run trains, for reading its wall time: the cores it may use, the platform, and
    the CPU's model and vector extensions (as evaluation reports record them)."""
    from .evaluation import evaluation_environment

    found = evaluation_environment("training")
    return {"cpus": _cpu_count(), "platform": platform.platform(), "cpu": found["cpu"],
            "cpu_flags": found["cpu_flags"]}  # fmt: skip


def due(state: dict[str, Any], key: str, every: int | None, steps: int) -> bool:
    """Whether the periodic ``key`` (``next_eval``, ``next_checkpoint``) is due at ``steps``;
    if so, moves it past ``steps`` by whole periods."""
    if not every or steps < state[key]:
        return False
    while state[key] <= steps:
        state[key] += every
    return True


def finish_run(model: Any, out: Path, run: dict[str, Any], final: str) -> dict[str, Any]:
    """Writes ``model.zip`` (the weights training ended with, or with ``final="best"`` the
    best evaluation's) and ``run.json``; returns the run record."""
    run["final_weights"] = run.get("last_evaluation")
    if final == "best" and (out / "best.zip").is_file():
        _load_weights(model, out / "best.zip")
        run["final_weights"] = (read_run_info(out / "best.zip") or {}).get("evaluation")
    save_model(model, out / "model.zip", run)
    (out / "run.json").write_text(json.dumps(run, indent=2, default=str))
    return run


#: What ``model.zip`` can hold: the weights training ended with, or the best evaluation's.
FINAL_CHOICES = ("last", "best")

#: The top-level key of a recipe file under which ``panda-rapier train`` finds how each id's
#: runs are validated, stopped and finished (rl-zoo3 reads only the ids' own entries, so the
#: file stays an rl-zoo3 recipe file):
#:
#: .. code-block:: yaml
#:
#:     validation:
#:       panda_rapier/StackJointsDense-v0: {every: 262144, episodes: 200, patience: 4, final: best}
VALIDATION = "validation"

#: What a recipe's validation entry may set, and what each is when nothing sets it:
#: ``every`` env steps between evaluations on the validation seeds (``None``: no periodic
#: evaluation; ``panda-rapier train`` makes it 250,000), ``episodes`` per evaluation,
#: ``patience`` (stop after that many evaluations in a row without a new best; ``None`` or 0:
#: never) and ``final`` (what ``model.zip`` holds: ``"last"`` or ``"best"``).
VALIDATION_DEFAULTS: dict[str, Any] = {"every": None, "episodes": 100, "patience": None,
                                       "final": "last"}  # fmt: skip


def recipe_validation(env_id: str, conf: str | Path | None, algo: str) -> dict[str, Any]:
    """The validation settings the recipe file (``conf``, else the package's for ``algo``)
    gives ``env_id`` under its top-level :data:`VALIDATION` key; ``{}`` if none. Checked:
    unknown keys or values of the wrong kind are a :class:`ConfigError`."""
    path, recipes = _recipe_file(algo, conf)
    table = recipes.get(VALIDATION) if isinstance(recipes, Mapping) else None
    if table is None:
        return {}
    if not isinstance(table, Mapping):
        raise ConfigError(f"{path}: {VALIDATION} must map environment ids to settings")
    entry = table.get(env_id)
    if entry is None:
        return {}
    if not isinstance(entry, Mapping) or set(entry) - set(VALIDATION_DEFAULTS):
        raise ConfigError(
            f"{path}: {VALIDATION} of {env_id} must be a mapping of "
            f"{sorted(VALIDATION_DEFAULTS)}, got {entry!r}"
        )
    for key in ("every", "episodes", "patience"):
        value = entry.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                                  or value < (1 if key == "episodes" else 0)):  # fmt: skip
            raise ConfigError(f"{path}: {VALIDATION} {key} of {env_id} must be a whole number")
    if "final" in entry and entry["final"] not in FINAL_CHOICES:
        raise ConfigError(f"{path}: {VALIDATION} final of {env_id} must be one of {FINAL_CHOICES}")
    return dict(entry)


def resolve_validation(
    algo: str,
    env_id: str,
    conf: str | Path | None,
    out: Path,
    resume: bool,
    given: Mapping[str, Any],
    stop_at: float | None = None,
    default_every: int | None = None,
) -> dict[str, Any]:
    """A run's validation settings (:data:`VALIDATION_DEFAULTS`' keys), checked with
    ``stop_at`` (:func:`_check_stopping`): each one ``given`` (not ``None``) wins; then, for a
    run resumed in ``out``, the one it recorded; then the recipe file's
    (:func:`recipe_validation`); then ``default_every`` for ``every`` and
    :data:`VALIDATION_DEFAULTS`. A ``patience`` or ``every`` of 0 is none; a run without
    periodic evaluations keeps only the ``patience`` and ``final`` it was given (which
    :func:`_check_stopping` then refuses)."""
    run_file = Path(out) / "run.json"
    previous = json.loads(run_file.read_text()) if resume and run_file.is_file() else {}
    recorded = previous.get(VALIDATION) or {}
    # A resumed run goes on as it started; one recorded before runs kept these reads the file.
    recipe = {} if algo == "bc" or recorded else recipe_validation(env_id, conf, algo)
    fallback = {**VALIDATION_DEFAULTS, "every": default_every}
    settings = {}
    for key, value in fallback.items():
        for source in (given, recorded, recipe):
            if source.get(key) is not None:
                value = source[key]
                break
        settings[key] = value
    if settings["patience"] == 0:
        settings["patience"] = None
    if settings["every"] == 0:
        settings["every"] = None
    if settings["every"] is None:  # nothing to judge on: only what was asked for stays
        settings["patience"] = given.get("patience") or None
        settings["final"] = given.get("final") or "last"
    _check_stopping(algo, settings["every"], settings["patience"], stop_at, settings["final"])
    return settings


def _check_stopping(
    algo: str, eval_every: int | None, patience: int | None, stop_at: float | None, final: str
) -> None:
    if final not in FINAL_CHOICES:
        raise InvalidArgumentError(f"final must be one of {FINAL_CHOICES}, got {final!r}")
    if patience is not None and (
        isinstance(patience, bool) or not isinstance(patience, int) or patience < 1
    ):
        raise InvalidArgumentError(f"patience must be an int >= 1, got {patience!r}")
    if stop_at is not None and not 0.0 < float(stop_at) <= 1.0:
        raise InvalidArgumentError(f"stop_at must be a success rate in (0, 1], got {stop_at!r}")
    wanted = patience is not None or stop_at is not None or final != "last"
    if wanted and algo == "bc":
        raise InvalidArgumentError(
            "bc runs have a fixed length (demo_episodes, dagger_rounds); their best round is "
            "best.zip: --patience, --stop-at and --final are for ppo, sac and tqc"
        )
    if wanted and not eval_every:
        raise InvalidArgumentError(
            "--patience, --stop-at and --final best are judged on the periodic evaluations: "
            "give --eval-every a number of env steps"
        )


#: Parameter-name prefixes of the value function in SB3's actor-critic policies.
VALUE_PREFIXES = ("mlp_extractor.value_net.", "value_net.", "vf_features_extractor.")


def actor_frozen(model: Any) -> bool:
    """Whether ``model``'s action head takes no gradient: a value-function warm-up
    (:class:`panda_rapier.finetune.CriticWarmup`) is under way, so its evaluations show the
    policy it started from and ``--patience`` does not count them."""
    head = getattr(getattr(model, "policy", None), "action_net", None)
    parameters = list(head.parameters()) if head is not None else []
    return bool(parameters) and not any(p.requires_grad for p in parameters)


#: The parameters a cloned policy (``--algo bc``) never trained: behaviour cloning fits the
#: action mean only, so its value function and action noise are the network's initial ones.
UNTRAINED_BY_CLONING = (*VALUE_PREFIXES, "log_std")


def _load_weights(model: Any, path: Path) -> list[str]:
    """Copies the policy weights (normaliser buffers included) of the model file at ``path``
    into ``model``, reading the file by data alone (:func:`~panda_rapier.model_file.
    read_model_file`: nothing in it is unpickled); other spaces or another architecture are an
    :class:`InvalidArgumentError`. From a cloned policy (a ``bc`` run's model) only what
    cloning trained is copied, the actor and the observation normaliser: the value function
    and the action noise (:data:`UNTRAINED_BY_CLONING`) stay the recipe's, whose value network
    may then have any size. Returns the names of the entries left as the recipe made them."""
    import torch as th

    from .inference import space_mismatch
    from .model_file import read_model_file

    data, weights = read_model_file(path)
    mismatch = space_mismatch(data, model.observation_space, model.action_space)
    if mismatch is not None:
        raise InvalidArgumentError(f"--init-from {path}: its {mismatch} (this environment's)")
    target = model.policy.state_dict()
    source_run = read_run_info(path) or {}
    kept: list[str] = []
    if source_run.get("algo") == "bc":
        untrained: tuple[str, ...] = UNTRAINED_BY_CLONING
        if isinstance(source_run.get("student"), Mapping):
            # A student's image encoder is shared by its actor and value function (its zip
            # holds it under both names): what cloning trained of it starts both, also when
            # the fine-tune gives the value function its own copy.
            untrained = tuple(p for p in untrained if p != "vf_features_extractor.")
        kept = sorted(k for k in target if k.startswith(untrained))
        weights = {k: v for k, v in weights.items() if not k.startswith(untrained)}
    shapes = {k: tuple(v.shape) for k, v in weights.items()}
    wanted = {k: tuple(v.shape) for k, v in target.items() if k not in kept}
    if shapes != wanted:
        differ = sorted(set(shapes.items()) ^ set(wanted.items()))[:4]
        raise InvalidArgumentError(
            f"--init-from {path}: its network does not match the recipe's (first differences, "
            f"name and shape: {differ})"
        )
    model.policy.load_state_dict({**target, **{k: th.as_tensor(v) for k, v in weights.items()}})
    return kept


def _cpu_count() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _train_bc(
    run: dict[str, Any],
    recipe: Mapping[str, Any],
    config: Mapping[str, Any],
    out: Path,
    n_envs: int | None,
    num_threads: int | None,
    eval_episodes: int,
    say: Callable[[str], None],
    on_evaluation: Callable[[dict[str, Any]], None] | None = None,
    show_progress: bool = True,
    fit_threads: int | None = None,
) -> dict[str, Any]:
    """Behaviour cloning and DAgger from the scripted expert (see :mod:`.imitation`); progress
    bars per collection round unless ``show_progress`` is false (``--quiet``); the fits on
    ``fit_threads`` torch threads."""
    from stable_baselines3 import PPO
    from tqdm import tqdm

    from .imitation import dagger
    from .sb3 import make_vec_env

    n = int(n_envs if n_envs is not None else recipe["n_envs"])
    run.update(n_envs=n)
    policy_kwargs = recipe.get("policy_kwargs")
    if isinstance(policy_kwargs, str):
        policy_kwargs = _evaluate_expression(policy_kwargs)
    env = make_vec_env(run["env_id"], n_envs=1, **run["env_kwargs"])
    model = PPO(recipe["policy"], env, policy_kwargs=policy_kwargs, seed=run["seed"], device="cpu")
    from stable_baselines3.common.logger import configure

    logger = configure(str(out / "tensorboard" / "bc_1"), ["tensorboard"])
    recorder = _Recorder(out, config, run, eval_episodes, num_threads, 0.0, say, on_evaluation)
    (out / "run.json").write_text(json.dumps(run, indent=2, default=str))
    env_steps = 0
    bars: dict[str, Any] = {}

    def progress(what: str, done: int, total: int) -> None:
        bar = bars.get(what)
        if bar is None:
            bar = bars[what] = tqdm(total=total, desc=what, unit="ep", leave=False)
        bar.update(done - bar.n)
        if done >= total:
            bar.close()

    def on_round(r: int, data: Any, stats: Any, losses: list[float]) -> None:
        nonlocal env_steps
        env_steps = len(data)
        if r == 0:
            drove = "expert demonstrations"
        elif stats is None:
            drove = "final fit"
        else:
            drove = f"learner drove: success {stats.success_rate:.3f}"
            drove += f", placed {stats.placed_rate:.3f}"
        say(f"round {r}: {len(data):,} labelled states ({drove}); loss {losses[-1]:.4f}")
        logger.record("bc/loss", losses[-1])
        logger.record("bc/labelled_states", len(data))
        if stats is not None:
            logger.record("rollout/success_rate", stats.success_rate)
            logger.record("rollout/placed_rate", stats.placed_rate)
        recorder.evaluate(model, env_steps, logger)
        logger.dump(env_steps)

    data = dagger(
        model,
        config,
        demo_episodes=int(recipe["demo_episodes"]),
        rounds=int(recipe["dagger_rounds"]),
        episodes_per_round=int(recipe["dagger_episodes"]),
        epochs=int(recipe["epochs"]),
        epochs_per_round=int(recipe["dagger_epochs"]),
        final_epochs=int(recipe["final_epochs"]),
        first_seed=run["train_first_seed"],
        batch_size=int(recipe["batch_size"]),
        learning_rate=float(recipe["learning_rate"]),
        num_envs=n,
        num_threads=num_threads,
        fit_threads=fit_threads,
        on_round=on_round,
        progress=progress if show_progress else None,
    )
    run["env_steps"] = len(data)
    run["demonstration_episodes"] = data.num_episodes
    run["wall_time_s"] = round(recorder.wall_time(), 3)
    data.save(out / "demonstrations.npz")
    save_model(model, out / "model.zip", run)
    (out / "run.json").write_text(json.dumps(run, indent=2, default=str))
    return run
