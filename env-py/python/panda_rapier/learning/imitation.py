"""Learning from the scripted expert: demonstrations, behaviour cloning and DAgger.

The scripted policy (:class:`~panda_rapier.ScriptedPolicy`) places the cube in 99 % of seeded
episodes and reads nothing but the observation, so it can label any state. This module

- records its episodes as a dataset (:func:`collect`, :class:`Demonstrations`; flat
  observations in Gymnasium's ``spaces.flatten`` order and the expert's actions; defined in
  :mod:`panda_rapier.learning.rollouts` and re-exported here),
- clones it into a stable-baselines3 policy by regression of the policy's mean action onto the
  expert's (:func:`behaviour_cloning`), and
- runs DAgger (Ross et al., 2011): the cloned policy drives, the expert labels every state it
  visits, the labels join the dataset and the policy is refitted (:func:`dagger`). Plain
  cloning only ever sees the expert's states; the learner's own small errors take it to states
  the expert never visited, and DAgger teaches it what to do there.

The learner is an SB3 PPO ``MultiInputPolicy`` (with :class:`NormalizedFlatten` as its
features extractor), so the result is an ordinary PPO zip: ``panda-rapier eval`` evaluates
it, and PPO can fine-tune it.

Needs the ``train`` extra (stable-baselines3 and torch).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.logger import configure
from tqdm import tqdm

from .. import _common
from ..agents.model_file import save_model
from ..errors import ConfigError, InvalidArgumentError
from ..policy import ScriptedPolicy
from ..sb3 import make_vec_env
from .normalization import fit_normalizers
from .recipes import BC_LEARNING_RATES, bc_learning_rate, dagger_beta, evaluate_expression
from .recipes import phase_keep as check_phase_keep
from .recipes import phase_weights as check_phase_weights
from .rollouts import Demonstrations, RolloutStats, collect, row_uniforms
from .runs import Recorder, write_run
from .threads import torch_threads

__all__ = [
    "Demonstrations",
    "RolloutStats",
    "behaviour_cloning",
    "collect",
    "dagger",
    "phase_row_keep",
    "phase_row_weights",
    "train_bc",
]


def behaviour_cloning(
    model: Any,
    demos: Demonstrations,
    *,
    epochs: int,
    batch_size: int = 256,
    learning_rate: float = 1e-3,
    final_lr_fraction: float = 0.05,
    seed: int = 0,
    progress: Callable[[int, float], None] | None = None,
    weights: np.ndarray | None = None,
) -> list[float]:
    """Fits the mean action of ``model``'s policy (an SB3 actor-critic, e.g. PPO's
    ``MultiInputPolicy``) to the expert's actions in ``demos`` by mean squared error, with Adam,
    for ``epochs`` passes over the data in shuffled mini-batches, the learning rate falling
    linearly to ``final_lr_fraction`` of ``learning_rate``. The observation normaliser
    (:class:`NormalizedFlatten`) must already be fitted. ``weights`` (one per row, >= 0) make
    the loss a weighted mean over each mini-batch's rows (:func:`phase_row_weights`); without
    them every row counts alike. Returns the mean loss of each epoch; ``progress(epoch, loss)``
    is called after each."""
    if len(demos) == 0:
        raise InvalidArgumentError("behaviour cloning needs at least one demonstration row")
    row_weights = None
    if weights is not None:
        weights = np.asarray(weights, dtype=np.float32)
        if weights.shape != (len(demos),) or not np.all(np.isfinite(weights)) or weights.min() < 0:
            raise InvalidArgumentError(
                f"weights must be {len(demos)} finite numbers >= 0, one per row; got shape "
                f"{weights.shape}"
            )
        row_weights = th.as_tensor(weights)
    policy = model.policy
    policy.set_training_mode(True)
    generator = np.random.default_rng(seed)
    # Split by the layout of the task the rows came from (Stack's goals are 6-D).
    schema = _common.Schema.of(_common.config_json(demos.config))
    rows = _common.split_observation(demos.observations, schema)
    obs = {k: th.as_tensor(v) for k, v in rows.items()}
    target = th.as_tensor(demos.actions)
    parameters = [p for name, p in policy.named_parameters() if not name.startswith("value_net")]
    optimizer = th.optim.Adam(parameters, lr=learning_rate)
    losses = []
    n = len(demos)
    batches = epochs * ((n + batch_size - 1) // batch_size)
    schedule = th.optim.lr_scheduler.LinearLR(
        optimizer, 1.0, final_lr_fraction, total_iters=max(1, batches - 1)
    )
    for epoch in range(epochs):
        order = th.as_tensor(generator.permutation(n))
        total = 0.0
        for start in range(0, n, batch_size):
            index = order[start : start + batch_size]
            batch = {k: v[index] for k, v in obs.items()}
            mean = policy.get_distribution(batch).distribution.mean
            if row_weights is None:
                loss = th.nn.functional.mse_loss(mean, target[index])
            else:
                w = row_weights[index]
                per_row = ((mean - target[index]) ** 2).mean(dim=1)
                loss = (per_row * w).sum() / w.sum().clamp_min(1e-12)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            schedule.step()
            total += float(loss.detach()) * len(index)
        losses.append(total / n)
        if progress is not None:
            progress(epoch + 1, losses[-1])
    policy.set_training_mode(False)
    return losses


def phase_row_weights(
    config: Mapping[str, Any], observations: np.ndarray, phase_weights: Mapping[str, float]
) -> tuple[np.ndarray, set[str]]:
    """The cloning loss's weight of each flat observation row: the weight ``phase_weights``
    gives the phase the scripted expert of ``config`` recognises in it
    (:meth:`~panda_rapier.ScriptedPolicy.phases`), 1 for phases it does not list. Returns the
    weights and the set of phases seen."""
    phases = ScriptedPolicy(config).phases(observations)
    weights = np.array([phase_weights.get(p, 1.0) for p in phases], dtype=np.float32)
    return weights, set(phases)


#: The salt of :func:`phase_row_keep`'s draws (a row's draw is a function of the row alone).
KEEP_SALT = 0x6B656570


def phase_row_keep(
    config: Mapping[str, Any], observations: np.ndarray, phase_keep: Mapping[str, float]
) -> tuple[np.ndarray, set[str]]:
    """Which flat observation rows the fits use: of the rows whose phase (the scripted expert
    of ``config``'s, :meth:`~panda_rapier.ScriptedPolicy.phases`) ``phase_keep`` lists, each
    is kept with that probability, drawn from the row itself
    (:func:`~panda_rapier.learning.rollouts.row_uniforms`); rows of other phases are all
    kept. A phase that fills most rows but asks little (Slide's wait above the sliding cube,
    72 % of them) then costs the fits less time. Returns the mask and the set of phases seen."""
    phases = ScriptedPolicy(config).phases(observations)
    fractions = np.array([phase_keep.get(p, 1.0) for p in phases], dtype=np.float64)
    return row_uniforms(observations, KEEP_SALT) < fractions, set(phases)


def dagger(
    model: Any,
    config: Mapping[str, Any],
    *,
    demo_episodes: int,
    rounds: int,
    episodes_per_round: int,
    epochs: int,
    epochs_per_round: int,
    first_seed: int,
    final_epochs: int = 0,
    batch_size: int = 256,
    learning_rate: float = 1e-3,
    dagger_learning_rate: float | None = None,
    final_learning_rate: float | None = None,
    num_envs: int = 32,
    num_threads: int | None = None,
    fit_threads: int | None = None,
    on_round: Callable[[int, Demonstrations, RolloutStats | None, list[float]], None] | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    phase_weights: Mapping[str, float] | None = None,
    beta: float = 0.0,
    phase_keep: Mapping[str, float] | None = None,
) -> Demonstrations:
    """Behaviour cloning from ``demo_episodes`` expert episodes, then ``rounds`` of DAgger, each
    driving ``episodes_per_round`` episodes with the learner, labelling them with the expert and
    refitting on everything gathered, and finally ``final_epochs`` more passes over all of it
    (a last fit whose learning rate decays over more steps). Each fit's learning rate starts at
    ``learning_rate`` (the first fit), ``dagger_learning_rate`` (the rounds') or
    ``final_learning_rate`` (the last; those two are ``learning_rate`` when ``None``) and
    decays linearly to 5 % of it. Episode seeds count up from
    ``first_seed`` without repeats. The normaliser is fitted to the expert's states. torch
    runs the fits on ``fit_threads`` threads (``None``: as it is set; no environment steps
    during a fit, so every core can go to it) and everything else as it is set.
    ``on_round(r, data, stats, losses)`` is called after each fit (``stats``: how the learner
    drove in round ``r``; ``None`` for round 0, the expert's demonstrations, and for the final
    fit). ``phase_weights`` weigh each state's row in every fit by the expert's phase in it
    (:func:`phase_row_weights`; a recipe's ``phase_weights``, checked by
    :func:`~panda_rapier.learning.recipes.phase_weights`); every name must be a phase the
    expert enters in its demonstrations. In round ``r`` the expert takes each of the learner's
    steps with probability ``beta ** r`` (DAgger's mixed policy, its beta_i = p^i; a recipe's
    ``dagger_beta``, :func:`~panda_rapier.learning.recipes.dagger_beta`): the early rounds,
    when the learner is weakest, stay nearer the states the expert visits. ``0``: the learner
    drives alone. ``phase_keep`` thins the rows every fit uses by the expert's phase in them
    (:func:`phase_row_keep`; a recipe's ``phase_keep``, checked by
    :func:`~panda_rapier.learning.recipes.phase_keep`); every name must be a phase the expert
    enters in its demonstrations. Returns all the data gathered, every row."""
    seed = first_seed
    weights: np.ndarray | None = None
    round_rate = learning_rate if dagger_learning_rate is None else dagger_learning_rate
    final_rate = learning_rate if final_learning_rate is None else final_learning_rate

    def tick(what: str, total: int) -> Callable[[int], None] | None:
        if progress is None:
            return None
        return lambda done: progress(what, done, total)

    data, _ = collect(
        config,
        demo_episodes,
        first_seed=seed,
        num_envs=num_envs,
        num_threads=num_threads,
        progress=tick("demonstrations", demo_episodes),
    )
    seed += demo_episodes
    keep: np.ndarray | None = None
    if phase_weights:
        weights, seen = phase_row_weights(config, data.observations, phase_weights)
        _check_phases("phase_weights", phase_weights, seen, demo_episodes)
    if phase_keep:
        keep, seen = phase_row_keep(config, data.observations, phase_keep)
        _check_phases("phase_keep", phase_keep, seen, demo_episodes)

    def fitted() -> tuple[Demonstrations, np.ndarray | None]:
        """The rows the next fit uses, and their weights."""
        if keep is None:
            return data, weights
        return data.rows(keep), None if weights is None else weights[keep]

    fit_normalizers(model.policy, data.observations)
    rows, row_weights = fitted()
    with torch_threads(fit_threads):
        losses = behaviour_cloning(
            model,
            rows,
            epochs=epochs,
            batch_size=batch_size,
            learning_rate=learning_rate,
            seed=0,
            weights=row_weights,
        )
    if on_round is not None:
        on_round(0, data, None, losses)
    for r in range(1, rounds + 1):
        new, stats = collect(
            config,
            episodes_per_round,
            first_seed=seed,
            actor=model,
            num_envs=num_envs,
            num_threads=num_threads,
            progress=tick(f"dagger round {r}", episodes_per_round),
            expert_share=beta**r,
        )
        seed += episodes_per_round
        data.extend(new)
        if weights is not None and phase_weights:
            more, _ = phase_row_weights(config, new.observations, phase_weights)
            weights = np.concatenate([weights, more])
        if keep is not None and phase_keep:
            kept, _ = phase_row_keep(config, new.observations, phase_keep)
            keep = np.concatenate([keep, kept])
        rows, row_weights = fitted()
        with torch_threads(fit_threads):
            losses = behaviour_cloning(
                model,
                rows,
                epochs=epochs_per_round,
                batch_size=batch_size,
                learning_rate=round_rate,
                seed=r,
                weights=row_weights,
            )
        if on_round is not None:
            on_round(r, data, stats, losses)
    if final_epochs > 0:
        rows, row_weights = fitted()
        with torch_threads(fit_threads):
            losses = behaviour_cloning(
                model,
                rows,
                epochs=final_epochs,
                batch_size=batch_size,
                learning_rate=final_rate,
                seed=rounds + 1,
                weights=row_weights,
            )
        if on_round is not None:
            on_round(rounds + 1, data, None, losses)
    return data


def _check_phases(key: str, named: Mapping[str, float], seen: set[str], episodes: int) -> None:
    """Refuses a recipe key that names phases the expert never entered in its demonstrations."""
    missing = sorted(set(named) - seen)
    if missing:
        raise ConfigError(
            f"recipe key {key!r} names {missing}, which the expert never enters in its "
            f"{episodes} demonstrations; its phases there: {sorted(seen)}"
        )


def train_bc(
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
    """A ``bc`` run (:func:`panda_rapier.learning.runner.train`): behaviour cloning and DAgger
    from the scripted expert (:func:`dagger`), the run written to ``out``; progress
    bars per collection round unless ``show_progress`` is false (``--quiet``); the fits on
    ``fit_threads`` torch threads."""
    n = int(n_envs if n_envs is not None else recipe["n_envs"])
    run.update(n_envs=n)
    policy_kwargs = recipe.get("policy_kwargs")
    if isinstance(policy_kwargs, str):
        policy_kwargs = evaluate_expression(policy_kwargs)
    env = make_vec_env(run["env_id"], n_envs=1, **run["env_kwargs"])
    model = PPO(recipe["policy"], env, policy_kwargs=policy_kwargs, seed=run["seed"], device="cpu")
    logger = configure(str(out / "tensorboard" / "bc_1"), ["tensorboard"])
    recorder = Recorder(out, config, run, eval_episodes, num_threads, 0.0, say, on_evaluation)
    write_run(out, run)
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
            who = "learner drove"
            if beta > 0.0:
                who += f", the expert {beta**r:.3g} of its steps"
            drove = f"{who}: success {stats.success_rate:.3f}, placed {stats.placed_rate:.3f}"
        say(f"round {r}: {len(data):,} labelled states ({drove}); loss {losses[-1]:.4f}")
        logger.record("bc/loss", losses[-1])
        logger.record("bc/labelled_states", len(data))
        if stats is not None:
            logger.record("rollout/success_rate", stats.success_rate)
            logger.record("rollout/placed_rate", stats.placed_rate)
        recorder.evaluate(model, env_steps, logger)
        logger.dump(env_steps)

    weights = recipe.get("phase_weights")
    weights = check_phase_weights(weights) if weights is not None else None
    rates = {key: bc_learning_rate(key, recipe[key]) for key in BC_LEARNING_RATES if key in recipe}
    beta = dagger_beta(recipe.get("dagger_beta", 0.0))
    keep = recipe.get("phase_keep")
    keep = check_phase_keep(keep) if keep is not None else None
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
        learning_rate=rates["learning_rate"],
        num_envs=n,
        num_threads=num_threads,
        fit_threads=fit_threads,
        on_round=on_round,
        progress=progress if show_progress else None,
        phase_weights=weights,
        dagger_learning_rate=rates.get("dagger_learning_rate"),
        final_learning_rate=rates.get("final_learning_rate"),
        beta=beta,
        phase_keep=keep,
    )
    run["env_steps"] = len(data)
    run["demonstration_episodes"] = data.num_episodes
    run["wall_time_s"] = round(recorder.wall_time(), 3)
    data.save(out / "demonstrations.npz")
    save_model(model, out / "model.zip", run)
    write_run(out, run)
    return run
