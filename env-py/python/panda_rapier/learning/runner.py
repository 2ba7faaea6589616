"""The stable-baselines3 runner: what ``panda-rapier train`` runs (:func:`train`).

A run trains one algorithm on one registered id with the native stable-baselines3 ``VecEnv``
and writes everything to its output directory:

- ``model.zip`` (the final model; ``best.zip``: the best periodic evaluation's), loadable by
  stable-baselines3 and by ``panda-rapier eval --policy DIR/model.zip`` with no other flag: the
  env id and every environment option are stored inside the zip (``panda_rapier_run.json``)
  and in ``run.json`` (:mod:`panda_rapier.learning.runs`);
- ``run.json``: versions, seeds, hyperparameters, the command, steps, wall time and the last
  evaluation; for the SB3 algorithms, where the wall time went (``wall_time_split``: seconds
  of env stepping, the policy's forward passes in rollouts, other rollout work and updates,
  :mod:`panda_rapier.learning.phases`);
- ``evaluations.jsonl``: one line per periodic evaluation (env steps, wall time, success rate
  with its 95 % interval, placed rate, mean return) on validation seeds, which neither the
  training episodes nor the final test seeds (``panda-rapier eval``'s default, 0 to 999) use;
- ``tensorboard/`` (``tensorboard --logdir DIR``) and ``checkpoints/`` for ``--resume``
  (:mod:`panda_rapier.learning.checkpoint`: read by data, nothing in it unpickled but a replay
  buffer this user's runs signed);
- for ``bc``: ``demonstrations.npz``, every state gathered with the expert's action in it
  (:func:`panda_rapier.learning.imitation.train_bc`; a student:
  :func:`panda_rapier.learning.student.train_student`).

Hyperparameters come from a recipe file (:mod:`panda_rapier.learning.recipes`).

Seeds (:mod:`panda_rapier.seeds`): the training environments and the expert's demonstrations
are seeded from ``TRAIN_FIRST_SEED + TRAIN_SEED_STRIDE * seed`` (a resumed run's environments
from that plus the steps already done), periodic evaluations use ``VALIDATION_FIRST_SEED``
onwards, and the final test (``panda-rapier eval``) seeds ``0, 1, ...``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecNormalize

from ..agents.model_file import read_model_file, read_run_info
from ..agents.student_model import policy_kwargs, student_architecture
from ..errors import ConfigError, InvalidArgumentError
from ..pixels import plain_observation, split_options
from ..registration import ENV_IDS, env_config
from ..sb3 import make_vec_env
from ..seeds import TRAIN_FIRST_SEED, TRAIN_SEED_STRIDE
from . import checkpoint
from .imitation import train_bc
from .normalization import RunningNormalizer, continued_statistics
from .phases import PhaseClock, describe_split
from .recipes import (
    VALIDATION,
    algorithm_class,
    load_recipe,
    merge_options,
    model_kwargs,
    recipe_callbacks,
    recipe_normalization,
    resolve_validation,
    train_env_kwargs,
)
from .runs import (
    Recorder,
    due,
    finish_run,
    load_weights,
    open_run,
    run_record,
    stop_reason,
    write_run,
)
from .student import train_student
from .threads import UpdateThreads, all_cores

__all__ = ["STUDENT_FINETUNE_POLICY_KWARGS", "train"]


def _sb3_callback(
    recorder: Recorder,
    eval_every: int,
    checkpoint_every: int,
    state: dict[str, Any],
    patience: int | None = None,
    stop_at: float | None = None,
    split: Callable[[], dict[str, float]] | None = None,
    on_checkpoint: Callable[[Path], None] | None = None,
    normalizer: RunningNormalizer | None = None,
) -> Any:
    """The callback that evaluates every ``eval_every`` env steps (stopping early as
    :func:`~panda_rapier.learning.runs.stop_reason` says) and writes a checkpoint every
    ``checkpoint_every``; its ``save_checkpoint()`` writes one at once (with ``normalizer``'s
    statistics, a ``normalize`` recipe's, in its state)."""
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
            if normalizer is not None:
                saved["normalize"] = normalizer.state()
            checkpoint.save(self.model, out / "checkpoints", saved, recorder.run)
            write_run(out, recorder.run)
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
    """Trains ``algo`` on ``env_id`` with its recipe and writes the run to ``out`` (see the module's
    documentation); returns the run record. ``timesteps`` and ``n_envs`` override the recipe's;
    ``env_kwargs`` are added to the recipe's environment options. ``init_from`` (a model saved by
    this algorithm, with the same observation and action spaces) gives the network its starting
    weights, observation normaliser included: fine-tuning. From a cloned policy (a ``bc`` run's
    model, for ``ppo``) only its actor and normaliser are taken
    (:func:`~panda_rapier.learning.runs.load_weights`); the recipe's
    ``panda_rapier.learning.finetune.CriticWarmup`` then lets the new value function catch up before
    the actor changes. The run record keeps that model's own run record, so its training time can be
    added up. ``resume`` goes on from ``out``'s checkpoint with the recipe and options the run
    recorded, reading the checkpoint by data (:mod:`panda_rapier.learning.checkpoint`; ``trust``
    lets it unpickle a replay buffer this user's runs did not write). ``on_evaluation`` is called
    with each periodic evaluation's line of ``evaluations.jsonl`` (env steps, wall time, success and
    placed rate, mean return), after it is written and ``best.zip`` is saved:
    :mod:`panda_rapier.scale.tuning` reports them to Ray Tune; ``on_checkpoint`` with ``out`` after
    each checkpoint is written (``out/checkpoints``, ``run.json`` and ``evaluations.jsonl`` are
    then a resumable whole). torch runs on ``torch_threads`` threads while environments step and on
    ``update_threads`` (``None``: every core) while nothing else runs: PPO's updates and behaviour
    cloning's fits (:mod:`panda_rapier.learning.threads`). PPO is trained by
    :class:`panda_rapier.learning.ppo.PPO` (SB3's algorithm with cheaper loops), or with
    ``stock_sb3`` by ``stable_baselines3.PPO`` itself (``panda-rapier bench-train`` compares the
    two); the run record names the class in ``algorithm_class``. ``overlap_updates`` (ppo with
    :class:`panda_rapier.learning.ppo.PPO` only) runs each update in a learner process while the
    next rollout is collected, by the policy from before that update
    (:mod:`panda_rapier.learning.overlap`); the run record keeps it, and a resumed run keeps what it
    recorded (``None``: that, else ``False``).

    Early stopping, judged on the periodic evaluations: training ends once an evaluation's success
    rate reaches ``stop_at``, or after ``patience`` evaluations in a row that do not beat the best
    (ranked as ``best.zip`` is: placed rate, then success rate); the run record says why in
    ``stopped_early``. ``final`` chooses what ``model.zip`` holds: ``"last"``, the weights training
    ended with, or ``"best"``, the best evaluation's (``best.zip``'s), so that a run's final model
    is never one that fell back after its best evaluation; the run record's ``final_weights`` says
    which evaluation's they are.

    ``eval_every``, ``eval_episodes``, ``patience`` and ``final`` left ``None`` take the recipe
    file's validation entry for ``env_id``
    (:func:`~panda_rapier.learning.recipes.recipe_validation`; a resumed run keeps what it
    recorded), else ``default_eval_every`` (none), 100, none and ``"last"``
    (:func:`~panda_rapier.learning.recipes.resolve_validation`); the run record keeps them under
    ``validation``."""
    if env_id not in ENV_IDS:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS")
    th.set_num_threads(torch_threads)
    out = Path(out)
    recipe = load_recipe(algo, env_id, conf)
    train_seed = TRAIN_FIRST_SEED + TRAIN_SEED_STRIDE * int(seed)
    given = {"every": eval_every, "episodes": eval_episodes, "patience": patience, "final": final}
    settings = resolve_validation(algo, env_id, conf, out, resume, given, stop_at,
                                  default_eval_every)  # fmt: skip
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
    _record_init_from(run, init_from, resume)
    if algo == "bc":
        return _train_cloning(
            run, recipe, config, observation, out, n_envs, num_threads, int(settings["episodes"]),
            say, on_evaluation, progress, init_from, resume, timesteps,
        )  # fmt: skip
    run[VALIDATION] = settings
    model, state, total = _sb3_model(
        run, recipe, options, out, seed, timesteps, n_envs, num_threads, resume, previous,
        student, stock_sb3, overlap_updates, checkpoint_every,
    )  # fmt: skip
    _start_weights(model, out, resume, trust, init_from, say)
    if init_from is not None and run.get("normalize") is not None:
        # The taken network's observation statistics, continued (not started afresh).
        steps = float(read_model_file(init_from)[0].get("num_timesteps") or 0)
        state["normalize"] = continued_statistics(model, steps, run["normalize"])
    recorder = Recorder(
        out,
        config,
        run,
        int(settings["episodes"]),
        num_threads,
        float(state["wall_time_s"]),
        say,
        on_evaluation,
        plain_observation(observation),
    )
    write_run(out, run)
    run["final"] = str(settings["final"])
    return _learn(
        model, recorder, recipe, state, total, settings, checkpoint_every, stop_at, resume,
        torch_threads, progress, on_checkpoint,
    )  # fmt: skip


def _record_init_from(run: dict[str, Any], init_from: str | Path | None, resume: bool) -> None:
    """Checks ``--init-from`` (a new run's, from a model file) and records it in the run."""
    if init_from is None:
        return
    if resume:
        raise InvalidArgumentError("--init-from starts a new run; it cannot be resumed into")
    if not Path(init_from).is_file():
        raise InvalidArgumentError(f"--init-from: no model at {init_from}")
    run["init_from"] = {"path": str(init_from), "run": read_run_info(init_from)}


def _train_cloning(
    run: dict[str, Any],
    recipe: Mapping[str, Any],
    config: Mapping[str, Any],
    observation: Mapping[str, Any],
    out: Path,
    n_envs: int | None,
    num_threads: int | None,
    eval_episodes: int,
    say: Callable[[str], None],
    on_evaluation: Callable[[dict[str, Any]], None] | None,
    progress: bool,
    init_from: str | Path | None,
    resume: bool,
    timesteps: int | None,
) -> dict[str, Any]:
    """A ``bc`` run: cloning the scripted expert into a policy on state observations
    (:func:`~panda_rapier.learning.imitation.train_bc`) or, with a ``student`` recipe, into
    one that sees (:func:`~panda_rapier.learning.student.train_student`)."""
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
            "e.g. models/recipes/bc-pixels.yml), and a student recipe needs an obs_mode with "
            "colour or depth images (proprio+rgb, proprio+depth, proprio+rgbd); got obs_mode "
            f"{observation.get('obs_mode', 'state')!r}"
        )
    if sees:
        recorder = Recorder(out, config, run, eval_episodes, num_threads, 0.0, say,
                            on_evaluation, plain_observation(observation))  # fmt: skip
        return train_student(
            run, recipe, config, observation, out, n_envs, num_threads, recorder, say,
            show_progress=progress, fit_threads=run["update_threads"],
        )  # fmt: skip
    return train_bc(
        run, recipe, config, out, n_envs, num_threads, eval_episodes, say, on_evaluation,
        show_progress=progress, fit_threads=run["update_threads"],
    )  # fmt: skip


def _sb3_model(
    run: dict[str, Any],
    recipe: Mapping[str, Any],
    options: Mapping[str, Any],
    out: Path,
    seed: int,
    timesteps: int | None,
    n_envs: int | None,
    num_threads: int | None,
    resume: bool,
    previous: Mapping[str, Any] | None,
    student: tuple[dict[str, Any], dict[str, Any]] | None,
    stock_sb3: bool,
    overlap_updates: bool | None,
    checkpoint_every: int | None,
) -> tuple[Any, dict[str, Any], int]:
    """The model an SB3 run trains, on its training environments (seeded past the steps a
    resumed run already took), the run's periodic state (``checkpoints/state.json``'s for a
    resumed run) and its total env steps; records the length, the algorithm's class and
    whether updates overlap rollouts."""
    algo, env_id = str(run["algo"]), str(run["env_id"])
    total = int(timesteps if timesteps is not None else recipe.get("n_timesteps", 1_000_000))
    if n_envs is None and resume and previous and previous.get("n_envs"):
        n_envs = int(previous["n_envs"])  # a resumed run keeps its environments (and buffer)
    n = int(n_envs if n_envs is not None else recipe.get("n_envs", 1))
    if resume and previous and previous.get("n_envs") not in (None, n):
        raise InvalidArgumentError(
            f"--n-envs {n}: the run in {out} was trained on {previous['n_envs']} environments "
            "and resumes on as many (its replay buffer and checkpoint are per environment)"
        )
    run.update(n_envs=n, n_timesteps=total)
    algorithm = algorithm_class(algo, stock=stock_sb3)
    run["algorithm_class"] = f"{algorithm.__module__}.{algorithm.__qualname__}"
    if overlap_updates is None:
        overlap_updates = bool((previous or {}).get("overlap_updates", False)) if resume else False
    if overlap_updates and (algo != "ppo" or stock_sb3):
        raise InvalidArgumentError(
            "overlapped updates are for ppo trained by panda_rapier.learning.ppo.PPO (not "
            f"{'stable_baselines3.PPO' if stock_sb3 else algo})"
        )
    run["overlap_updates"] = bool(overlap_updates)
    validation = run[VALIDATION]
    state: dict[str, Any] = {
        "next_eval": validation["every"] or 0,
        "next_checkpoint": checkpoint_every or 0,
        "wall_time_s": 0.0,
        "num_timesteps": 0,
    }
    if resume:
        state.update(json.loads((out / "checkpoints" / "state.json").read_text()))
    # A resumed run's environments start from seeds its first part never used.
    env_seed = int(run["train_first_seed"]) + int(state["num_timesteps"])
    # Training-only options (a curriculum) on top of the run's; evaluations use the run's.
    extra = train_env_kwargs(recipe, algo)
    if extra:
        run["train_env_kwargs"] = extra
    env: Any = make_vec_env(
        env_id, n_envs=n, seed=env_seed, num_threads=num_threads, **merge_options(options, extra)
    )
    normalization = recipe_normalization(recipe)
    if normalization is not None:
        if overlap_updates or student is not None:
            raise ConfigError(
                "recipe key 'normalize' does not combine with overlapped updates or a "
                "student's network"
            )
        run["normalize"] = normalization
        if normalization["norm_reward"]:  # observations: in the network (RunningNormalizer)
            env = VecNormalize(env, norm_obs=False, norm_reward=True, gamma=normalization["gamma"],
                               clip_reward=normalization["clip_reward"],
                               epsilon=normalization["epsilon"])  # fmt: skip
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
    return model, state, total


def _start_weights(
    model: Any,
    out: Path,
    resume: bool,
    trust: bool,
    init_from: str | Path | None,
    say: Callable[[str], None],
) -> None:
    """Fills a resumed run's model from its checkpoint (by data alone), or a new run's from
    ``--init-from``'s model; a new run without it keeps the recipe's initial weights."""
    if resume:
        # Rebuilt from the recorded recipe, then filled from the checkpoint by data alone.
        checkpoint.restore(model, out / "checkpoints", trust=trust)
        say(f"resuming {out} at {model.num_timesteps:,} steps")
    elif init_from is not None:
        kept = load_weights(model, Path(init_from))
        say(f"starting from the weights of {init_from}")
        if kept:
            say(
                "a cloned policy: its actor and observation normaliser are taken; the "
                "value function and action noise start as the recipe makes them"
            )


def _learn(
    model: Any,
    recorder: Recorder,
    recipe: Mapping[str, Any],
    state: dict[str, Any],
    total: int,
    settings: Mapping[str, Any],
    checkpoint_every: int | None,
    stop_at: float | None,
    resume: bool,
    torch_threads: int,
    progress: bool,
    on_checkpoint: Callable[[Path], None] | None,
) -> dict[str, Any]:
    """Trains ``model`` up to ``total`` env steps with the periodic evaluations, checkpoints,
    the recipe's callbacks, the update threads and the phase clock; then a last evaluation
    and checkpoint, and :func:`~panda_rapier.learning.runs.finish_run`."""
    run, out, say = recorder.run, recorder.out, recorder.say
    eval_every, patience = settings["every"], settings["patience"]
    clock = PhaseClock(lambda: recorder.eval_time + recorder.checkpoint_time)
    earlier: Mapping[str, Any] = state.get("wall_time_split") or {}  # a resumed run's first part

    def split() -> dict[str, float]:
        return {
            phase: round(float(earlier.get(phase, 0.0)) + seconds, 3)
            for phase, seconds in clock.split().items()
        }

    normalization = run.get("normalize")
    normalizer = None
    if normalization is not None:  # first: the step's statistics before evaluations
        # A resumed run's statistics, or those an --init-from run continues (`train`).
        normalizer = RunningNormalizer(normalization, state.get("normalize"))
    periodic = _sb3_callback(
        recorder, eval_every or 0, checkpoint_every or 0, state, patience, stop_at, split,
        on_checkpoint, normalizer,
    )  # fmt: skip
    callbacks = [*recipe_callbacks(recipe.get("callback")), periodic]
    if normalizer is not None:
        callbacks.insert(0, normalizer)
    if (
        isinstance(model, OnPolicyAlgorithm) and not run["overlap_updates"]
    ):  # rollouts, updates take turns
        callbacks.append(UpdateThreads(run["update_threads"], rollout=torch_threads))
    callbacks.append(clock)
    remaining = total - int(model.num_timesteps)
    if remaining > 0:
        model.learn(
            remaining,
            callback=callbacks,
            progress_bar=progress,
            reset_num_timesteps=not resume,
            tb_log_name=str(run["algo"]),
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
    return finish_run(model, out, run, str(settings["final"]))


#: The ``policy_kwargs`` a recipe may set when it fine-tunes a student: the rest of the
#: network is the student's (:func:`_student_network`).
STUDENT_FINETUNE_POLICY_KWARGS = ("log_std_init", "ortho_init", "share_features_extractor")


def _student_source(
    algo: str, previous: Mapping[str, Any] | None, init_from: str | Path | None
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """For an RL run that fine-tunes a student (:mod:`panda_rapier.learning.student`, a policy that
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
    arch = student_architecture(source["student"])
    options = source.get("env_kwargs")
    if not isinstance(options, Mapping):
        raise InvalidArgumentError("the student's run record has no environment options")
    return arch, split_options(options)[1]


def _student_network(
    arch: Mapping[str, Any], recipe: Mapping[str, Any] | None
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The architecture (as the run record keeps it, for :func:`~panda_rapier.agents.student_model.
    load_student`) and ``policy_kwargs`` of a fine-tuned student: its own network (``arch``),
    with the recipe's :data:`STUDENT_FINETUNE_POLICY_KWARGS` (the action noise's start;
    ``share_features_extractor=False`` gives the value function its own copy of the image
    encoder, so the value loss no longer moves the actor's); any other entry in the recipe's
    would contradict the student's and is a ConfigError."""
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
