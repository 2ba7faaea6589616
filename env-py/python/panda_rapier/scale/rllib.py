"""RLlib (Ray's new API stack) on the native vector environment: configuration builders.

Needs the ``rllib`` extra (``pip install "panda-rapier[rllib]"``, Ray 2.60)::

    import ray
    from panda_rapier.scale.rllib import ppo_config

    ray.init()  # on a cluster: ray.init(address="auto")
    algo = ppo_config("panda_rapier/PickAndPlaceDense-v0", num_env_runners=4).build_algo()
    for _ in range(100):
        result = algo.train()
    algo.stop()

:func:`ppo_config`, :func:`sac_config` and :func:`tqc_config` return ordinary RLlib
``AlgorithmConfig`` objects, ready to ``build_algo()`` or to hand to ``ray.tune.Tuner``, and to
change further with RLlib's own methods. Each sets the same environment side (see
:func:`configure_env_runners`):

- every EnvRunner builds one :class:`~panda_rapier.PandaVectorEnv` with
  ``gym.make_vec(..., vectorization_mode="vector_entry_point")``: ``num_envs_per_env_runner``
  environments stepped in Rust on ``num_threads`` = the runner's CPUs
  (``num_cpus_per_env_runner``), not one Python env object per environment;
- Gymnasium's ``next_step`` autoreset, which RLlib's EnvRunner assumes (it treats the
  observation after an episode's last step as the next episode's first);
- flat observations (RLlib's default encoders refuse ``Dict`` spaces): the state comes from
  the env as one vector (``obs_mode="flat"``: ``achieved_goal``, ``desired_goal``,
  ``observation``, the layout RLlib's ``FlattenObservations`` would give the state dict, at no
  cost per observation), handed to the module and the actions back by two batched
  connectors (:class:`FlatObservationsToModule`, :class:`SampledActionsToEnv`) in place of
  RLlib's per-environment defaults; the image modes' dicts are flattened by that connector;
- actions clipped to ``[-1, 1]`` by the env itself (RLlib's ``normalize_actions`` and
  ``clip_actions`` are off: they would clip the same way, one action at a time in Python);
  episodes keep the sampled, unclipped actions, as stable-baselines3's buffers do;
- seeds: see :func:`runner_seed`;
- :class:`EpisodeOutcomes` adds ``success_rate`` and ``placed_rate`` to the EnvRunners'
  metrics (``result["env_runners"]``), and ``result["fault_tolerance"]``
  (:func:`fault_tolerance`: runners lost and recreated, env steps lost).

:func:`ppo_config` is the stable-baselines3 PPO recipe of ``panda-rapier train`` (the same
file, every setting mapped, its observation standardisation and gripper exploration floor in
:class:`~panda_rapier.scale.rllib_recipe.RecipePPOTorchRLModule`); ``panda-rapier train --backend
rllib`` trains it (:mod:`panda_rapier.scale.rllib_training`).

RLlib has no hindsight experience replay, so :func:`sac_config` and :func:`tqc_config` take
the dense-reward ids only; TQC with HER on the sparse ids is stable-baselines3's recipe
(``panda-rapier train --algo tqc``, swept on Ray by :mod:`panda_rapier.scale.tuning`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from gymnasium.vector import AutoresetMode

try:
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.algorithms.sac import SACConfig
    from ray.rllib.algorithms.tqc import TQCConfig
    from ray.rllib.callbacks.callbacks import RLlibCallback
    from ray.rllib.connectors.connector_v2 import ConnectorV2
    from ray.rllib.connectors.env_to_module import FlattenObservations
    from ray.rllib.connectors.module_to_env import GetActions
    from ray.rllib.core.columns import Columns
except ImportError as error:  # pragma: no cover - exercised only without the extra
    raise ImportError(
        "panda_rapier.scale.rllib needs Ray RLlib: pip install 'panda-rapier[rllib]'"
    ) from error

from ..errors import ConfigError, InvalidArgumentError
from ..learning.recipes import load_recipe
from ..registration import ENV_IDS, env_config
from ..seeds import MAX_RUN_SEED, RLLIB_FIRST_SEED, RLLIB_SEED_STRIDE
from ..vector import PandaVectorEnv, as_autoreset_mode

if TYPE_CHECKING:
    from ray.rllib.algorithms.algorithm_config import AlgorithmConfig

__all__ = [
    "MAX_RUN_SEED",
    "OUTCOME_WINDOW",
    "RLLIB_FIRST_SEED",
    "RLLIB_SEED_STRIDE",
    "EpisodeOutcomes",
    "FlatObservationsToModule",
    "SampledActionsToEnv",
    "configure_env_runners",
    "fault_tolerance",
    "flat_observations_to_module",
    "flatten_observations",
    "ppo_config",
    "recipe_training",
    "rllib_seed",
    "runner_seed",
    "sac_config",
    "sampled_actions_to_env",
    "tqc_config",
]

#: What RLlib adds to an evaluation EnvRunner's seed.
_EVALUATION_OFFSET = 1_000_000


def rllib_seed(seed: int) -> int:
    """RLlib's ``config.seed`` for run seed ``seed`` (``0 <= seed < MAX_RUN_SEED``):
    ``RLLIB_FIRST_SEED + RLLIB_SEED_STRIDE * seed``."""
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < MAX_RUN_SEED:
        raise InvalidArgumentError(f"seed must be an int in [0, {MAX_RUN_SEED}), got {seed!r}")
    return RLLIB_FIRST_SEED + RLLIB_SEED_STRIDE * seed


def runner_seed(seed: int, worker_index: int, *, evaluation: bool = False) -> int:
    """The seed that EnvRunner ``worker_index`` of run seed ``seed`` resets its vector
    environment with, once, before its first sample: RLlib's ``config.seed + worker_index``
    (``+ 1_000_000`` for evaluation runners).

    Environment ``i`` of that runner then draws from the random stream ``(runner_seed, i)``
    (ChaCha8 keyed by the seed, stream ``i``; see :class:`~panda_rapier.PandaVectorEnv`) and
    every later episode continues it (autoresets do not re-seed). Distinct ``(runner, i)``
    pairs are distinct keys or streams, so no two environments of a run share a stream,
    whatever the number of runners and environments per runner; Gymnasium's own vector envs,
    which seed sub-environment ``i`` with ``seed + i``, would give runner 1's environment 1
    the stream of runner 2's environment 0. Remote runners have ``worker_index`` 1, 2, ...;
    the local runner (index 0) has an environment only with ``num_env_runners=0``.

    RLlib re-seeds, with the same seed, whenever a runner samples by episodes
    (``sample(num_episodes=...)``, as evaluation with ``evaluation_duration_unit="episodes"``
    does): such evaluations replay the same starts every time, like the fixed validation
    seeds of ``panda-rapier train``. Training runners sample by timesteps and are seeded once.
    """
    if isinstance(worker_index, bool) or not isinstance(worker_index, int) or worker_index < 0:
        raise InvalidArgumentError(f"worker_index must be an int >= 0, got {worker_index!r}")
    if worker_index >= _EVALUATION_OFFSET:
        raise InvalidArgumentError(
            f"worker_index must be below {_EVALUATION_OFFSET} (RLlib's evaluation offset), "
            f"got {worker_index}"
        )
    return rllib_seed(seed) + worker_index + (_EVALUATION_OFFSET if evaluation else 0)


def _check_stateless(rl_module: Any) -> None:
    if rl_module.is_stateful():
        raise ConfigError(
            "the flat-observation connectors serve stateless modules only; for a recurrent "
            "module, set config.env_runners(add_default_connectors_to_env_to_module_pipeline="
            "True, add_default_connectors_to_module_to_env_pipeline=True)"
        )


class FlatObservationsToModule(ConnectorV2):
    """The env-to-module connector of flat observations (``obs_mode="flat"``): every
    environment's latest observation, stacked into one float tensor for the module, in place
    of RLlib's default pipeline (which gathers, batches and converts them one environment at
    a time: about 7 % of a runner's sampling here). The module's input is the same, to the
    bit, on ``device`` (the runner's, as RLlib passes it to the connector's factory; ``None``:
    the CPU). Stateless modules only (:class:`~panda_rapier.ConfigError` otherwise)."""

    def __init__(self, *args: Any, device: Any = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._device = device

    def __call__(
        self, *, rl_module: Any, batch: dict[str, Any], episodes: list[Any], **kwargs: Any
    ) -> Any:
        _check_stateless(rl_module)
        observations = torch.from_numpy(
            np.stack([episode.get_observations(-1) for episode in episodes])
        )
        batch[Columns.OBS] = observations if self._device is None else observations.to(self._device)
        return batch


class SampledActionsToEnv(ConnectorV2):
    """The module-to-env connector paired with :class:`FlatObservationsToModule`: RLlib's
    ``GetActions`` (actions drawn from the module's exploration distribution, or its
    deterministic actions when not exploring, and their log-probabilities), handed to the
    vector env and the episodes as numpy arrays with one row per environment, in place of the
    default pipeline's per-environment unbatching and listing (about 11 % of a runner's
    sampling). RLlib's own ``GetActions`` draws them, so the same actions to the bit. The env
    clips actions itself (see :func:`configure_env_runners`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._get_actions = GetActions()

    def __call__(
        self, *, rl_module: Any, batch: dict[str, Any], episodes: list[Any], **kwargs: Any
    ) -> Any:
        _check_stateless(rl_module)
        batch = self._get_actions(rl_module=rl_module, batch=batch, episodes=episodes, **kwargs)
        return {
            key: value.detach().cpu().numpy() if isinstance(value, torch.Tensor) else value
            for key, value in batch.items()
        }


def flat_observations_to_module(env: Any = None, spaces: Any = None, device: Any = None) -> Any:
    """The env-to-module connector of flat observations (for ``config.env_runners(
    env_to_module_connector=...)``, which calls it with the runner's env, spaces and device):
    :class:`FlatObservationsToModule` on that device."""
    return FlatObservationsToModule(device=device)


def sampled_actions_to_env(env: Any = None, spaces: Any = None, device: Any = None) -> Any:
    """The module-to-env connector paired with it: :class:`SampledActionsToEnv`."""
    return SampledActionsToEnv()


#: Episodes the ``success_rate`` / ``placed_rate`` metrics average over (per EnvRunner).
OUTCOME_WINDOW = 100


class EpisodeOutcomes(RLlibCallback):
    """An RLlib callback the builders install: when an episode ends, logs its last step's
    ``is_success`` (and ``is_placed`` where the task has it) to the EnvRunner's metrics, so
    ``algo.train()``'s result has ``result["env_runners"]["success_rate"]`` and
    ``["placed_rate"]``: means over each runner's last :data:`OUTCOME_WINDOW` episodes,
    averaged over runners."""

    def on_episode_end(self, *, episode: Any, metrics_logger: Any = None, **kwargs: Any) -> None:
        """Logs the ended episode's outcome."""
        if metrics_logger is None:
            return
        info = episode.get_infos(-1)
        for key, metric in (("is_success", "success_rate"), ("is_placed", "placed_rate")):
            if key in info:
                value = float(bool(info[key]))
                metrics_logger.log_value(metric, value, reduce="mean", window=OUTCOME_WINDOW)

    def on_train_result(self, *, algorithm: Any, result: dict[str, Any], **kwargs: Any) -> None:
        """Adds ``result["fault_tolerance"]`` (:func:`fault_tolerance`)."""
        result["fault_tolerance"] = fault_tolerance(algorithm)


def fault_tolerance(algorithm: Any) -> dict[str, int]:
    """What lost EnvRunners have cost ``algorithm`` so far: ``healthy_env_runners`` (of
    ``env_runners``), ``env_runner_restarts`` (RLlib recreates a failed runner, on any node
    with room, when ``restart_failed_env_runners`` is on, as by default), ``failures`` (restarts
    plus runners still down) and ``env_steps_lost_at_most``: a runner that dies loses the
    fragment it was sampling (``rollout_fragment_length x num_envs_per_env_runner`` env steps)
    and nothing else. PPO then fills its train batch from the healthy runners, so every
    iteration still trains ``train_batch_size_per_learner`` steps; what a failure costs is
    that fragment's time."""
    group = algorithm.env_runner_group
    config = algorithm.config
    runners = int(config.num_env_runners)
    healthy = int(group.num_healthy_remote_workers()) if runners else 0
    restarts = int(group.num_remote_worker_restarts()) if runners else 0
    failures = restarts + (runners - healthy)
    fragment = int(config.get_rollout_fragment_length(1)) * int(config.num_envs_per_env_runner)
    return {
        "env_runners": runners,
        "healthy_env_runners": healthy,
        "env_runner_restarts": restarts,
        "failures": failures,
        "env_steps_lost_at_most": failures * fragment,
    }


def flatten_observations(env: Any = None, spaces: Any = None, device: Any = None) -> Any:
    """The env-to-module connector the builders install for observations with images
    (``config.env_runners(env_to_module_connector=...)`` calls it with the runner's env, spaces
    and device): RLlib's ``FlattenObservations``, which turns the observation dict into one
    float vector. State observations need none: they come flat from the env."""
    return FlattenObservations()


def _check_count(name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise InvalidArgumentError(f"{name} must be an int >= {minimum}, got {value!r}")
    return int(value)


def configure_env_runners(
    config: AlgorithmConfig,
    env_id: str,
    *,
    seed: int = 0,
    num_env_runners: int = 2,
    num_envs_per_env_runner: int = 16,
    num_cpus_per_env_runner: int = 1,
    env_kwargs: Mapping[str, Any] | None = None,
) -> AlgorithmConfig:
    """Sets ``config``'s environment, EnvRunners and seed for ``env_id`` (any id in
    ``panda_rapier.ENV_IDS``) and returns it (the builders below call it; call it yourself on
    any other RLlib algorithm's config).

    ``env_kwargs``: environment options, as ``gym.make(env_id, **env_kwargs)`` takes them
    (checked here by building one environment); ``obs_mode`` ``"state"`` (the default) becomes
    ``"flat"``, the same values in one vector. ``num_threads`` of each runner's vector env is
    ``num_cpus_per_env_runner`` (at most ``num_envs_per_env_runner``); ``autoreset_mode`` is
    ``next_step`` and cannot be changed. ``seed`` is the run seed (:func:`rllib_seed`,
    :func:`runner_seed`). Sets ``config.callbacks(EpisodeOutcomes)`` (subclass it to add
    your own).
    """
    if env_id not in ENV_IDS:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS")
    num_env_runners = _check_count("num_env_runners", num_env_runners, 0)
    num_envs = _check_count("num_envs_per_env_runner", num_envs_per_env_runner, 1)
    num_cpus = _check_count("num_cpus_per_env_runner", num_cpus_per_env_runner, 1)
    options = dict(env_kwargs or {})
    for key in ("num_envs", "num_threads", "render_mode"):
        if key in options:
            raise ConfigError(
                f"env_kwargs cannot set {key!r}: "
                + {
                    "num_envs": "use num_envs_per_env_runner",
                    "num_threads": "it follows num_cpus_per_env_runner",
                    "render_mode": "EnvRunners do not render",
                }[key]
            )
    obs_mode = options.pop("obs_mode", "state")
    mode = options.pop("autoreset_mode", "next_step")
    if as_autoreset_mode(mode) != AutoresetMode.NEXT_STEP:
        raise ConfigError(
            f"autoreset_mode must be next_step for RLlib (its EnvRunner assumes it), got {mode!r}"
        )
    # Bad options fail here, in the driver, with the option's name, not in every runner.
    # The state comes flat from the env (obs_mode="flat": no flattening per observation and
    # episode) and goes to the module and back by two batched connectors instead of RLlib's
    # per-environment defaults; observations with images are flattened by RLlib's connector.
    flat = obs_mode in ("state", "flat")
    options["obs_mode"] = "flat" if flat else obs_mode
    PandaVectorEnv(1, num_threads=1, **env_config(env_id, **options)).close()
    runners: dict[str, Any] = (
        {
            "env_to_module_connector": flat_observations_to_module,
            "module_to_env_connector": sampled_actions_to_env,
            "add_default_connectors_to_env_to_module_pipeline": False,
            "add_default_connectors_to_module_to_env_pipeline": False,
        }
        if flat
        else {"env_to_module_connector": flatten_observations}
    )
    return (
        config.environment(
            f"panda_rapier:{env_id}",  # "module:" makes every runner import panda_rapier
            env_config={
                **options,
                "num_threads": min(num_cpus, num_envs),
                "autoreset_mode": "next_step",
            },
            # The env clips actions to [-1, 1] itself, as RLlib's clipping would (episodes
            # keep the sampled actions either way): no copy and clip per action in Python.
            normalize_actions=False,
            clip_actions=False,
        )
        .env_runners(
            num_env_runners=num_env_runners,
            num_envs_per_env_runner=num_envs,
            num_cpus_per_env_runner=num_cpus,
            gym_env_vectorize_mode="vector_entry_point",
            **runners,
        )
        .callbacks(EpisodeOutcomes)
        .debugging(seed=rllib_seed(seed))
    )


def ppo_config(
    env_id: str = "panda_rapier/PickAndPlaceDense-v0",
    *,
    seed: int = 0,
    num_env_runners: int = 2,
    num_envs_per_env_runner: int = 32,
    num_cpus_per_env_runner: int = 1,
    env_kwargs: Mapping[str, Any] | None = None,
    conf: str | Path | None = None,
    **training: Any,
) -> PPOConfig:
    """A ``PPOConfig`` for ``env_id`` on the native vector env (:func:`configure_env_runners`)
    that follows the stable-baselines3 recipe of ``panda-rapier train --algo ppo`` for it
    (``conf``: a recipe file in rl-zoo3's format, default the package's ``hyperparams/ppo.yml``;
    an id without a recipe there is a :class:`~panda_rapier.ConfigError`).

    The recipe's settings map one to one (:func:`recipe_training`): ``n_envs x n_steps``
    env steps per iteration (``train_batch_size_per_learner``; 64 x 64 = 4,096), minibatches
    of ``batch_size``, ``n_epochs`` epochs, ``gamma``, ``gae_lambda``, the learning rate
    (``lin_X``: a linear decay to 0 over ``n_timesteps``), ``clip_range``, ``ent_coef``,
    ``vf_coef``, ``max_grad_norm`` (global norm), no value clipping, and ``target_kl`` as
    RLlib's adaptive KL penalty aimed at it (none without one). Its network, observation
    standardisation and gripper exploration floor are the module's
    (:class:`~panda_rapier.scale.rllib_recipe.RecipePPOTorchRLModule`, statistics fitted to 64
    episodes of the scripted expert here, in the driver), its ``env_kwargs`` (the dense
    pick-and-place's ``release`` term) the environment's unless ``env_kwargs`` sets them.
    ``training`` overrides any ``PPOConfig.training`` argument.
    """
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    from .rllib_recipe import RecipePPOTorchRLModule, recipe_model_config

    if env_id not in ENV_IDS:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS")
    recipe = load_recipe("ppo", env_id, conf)
    if recipe.get("train_env_kwargs"):
        raise ConfigError(
            "recipe key 'train_env_kwargs' is for stable-baselines3's runs (--backend sb3): "
            "the RLlib recipe's environment runners and evaluations share env_kwargs"
        )
    options = {**dict(recipe.get("env_kwargs") or {}), **dict(env_kwargs or {})}
    settings = recipe_training(recipe)
    settings.update(training)
    config = configure_env_runners(
        PPOConfig(),
        env_id,
        seed=seed,
        num_env_runners=num_env_runners,
        num_envs_per_env_runner=num_envs_per_env_runner,
        num_cpus_per_env_runner=num_cpus_per_env_runner,
        env_kwargs=options,
    )
    model_config = recipe_model_config(recipe, env_config(env_id, **options))
    config = config.training(**settings)
    assert isinstance(config, PPOConfig)
    return config.rl_module(
        rl_module_spec=RLModuleSpec(module_class=RecipePPOTorchRLModule),
        model_config=model_config,
    )


def recipe_training(recipe: Mapping[str, Any]) -> dict[str, Any]:
    """``PPOConfig.training`` arguments of a stable-baselines3 PPO recipe (see
    :func:`ppo_config`)."""
    batch = int(recipe.get("n_envs", 1)) * int(recipe.get("n_steps", 2048))
    rate = recipe.get("learning_rate", 3e-4)
    if isinstance(rate, str) and rate.startswith("lin_"):
        lr: Any = [[0, float(rate[4:])], [int(float(recipe["n_timesteps"])), 0.0]]
    elif isinstance(rate, (int, float)):
        lr = float(rate)
    else:
        raise ConfigError(f"learning_rate {rate!r}: a number or lin_X")
    clip = recipe.get("clip_range", 0.2)
    if not isinstance(clip, (int, float)):
        raise ConfigError(f"clip_range {clip!r}: the RLlib port takes a number")
    target_kl = recipe.get("target_kl")
    return {
        "train_batch_size_per_learner": batch,
        "minibatch_size": int(recipe.get("batch_size", 64)),
        "num_epochs": int(recipe.get("n_epochs", 10)),
        "gamma": float(recipe.get("gamma", 0.99)),
        "lambda_": float(recipe.get("gae_lambda", 0.95)),
        "lr": lr,
        "clip_param": float(clip),
        "entropy_coeff": float(recipe.get("ent_coef", 0.0)),
        "vf_loss_coeff": float(recipe.get("vf_coef", 0.5)),
        "grad_clip": float(recipe.get("max_grad_norm", 0.5)),
        "grad_clip_by": "global_norm",
        "vf_clip_param": float("inf"),
        "use_kl_loss": target_kl is not None,
        **({"kl_target": float(target_kl)} if target_kl is not None else {}),
    }


def _off_policy(config: Any, env_id: str, training: Mapping[str, Any], **runners: Any) -> Any:
    """What SAC and TQC share: dense ids only, the off-policy settings."""
    if env_id in ENV_IDS and "Dense" not in env_id:
        raise ConfigError(
            f"{env_id} has the sparse reward and RLlib has no hindsight experience replay: use "
            f"its Dense id, or stable-baselines3's TQC + HER recipe (panda-rapier train --algo "
            f"tqc, swept on Ray with panda_rapier.scale.tuning)"
        )
    settings: dict[str, Any] = {
        "gamma": 0.95,
        "actor_lr": 3e-4,
        "critic_lr": 3e-4,
        "alpha_lr": 3e-4,
        "tau": 0.005,
        "train_batch_size_per_learner": 256,
        "num_steps_sampled_before_learning_starts": 1000,
        # Uniform sampling, as stable-baselines3's (RLlib's default is prioritised).
        "replay_buffer_config": {"type": "EpisodeReplayBuffer", "capacity": 1_000_000},
    }
    settings.update(training)
    runners["env_kwargs"] = _recipe_env_kwargs(env_id, runners.get("env_kwargs"))
    config = configure_env_runners(config, env_id, **runners).training(**settings)
    return _with_networks(config, [256, 256])


def sac_config(
    env_id: str = "panda_rapier/PickAndPlaceDense-v0",
    *,
    seed: int = 0,
    num_env_runners: int = 2,
    num_envs_per_env_runner: int = 4,
    num_cpus_per_env_runner: int = 1,
    env_kwargs: Mapping[str, Any] | None = None,
    **training: Any,
) -> SACConfig:
    """A ``SACConfig`` for a dense-reward ``env_id`` on the native vector env
    (:func:`configure_env_runners`): gamma 0.95, learning rates 3e-4, tau 0.005, batches of
    256 drawn uniformly from a 1 M-step replay buffer once 1,000 steps are in, 2x256 ReLU
    networks; on the dense pick-and-place ids ``reward_weights={"release": 1.0}`` as for
    :func:`ppo_config`.
    ``training`` overrides any ``SACConfig.training`` argument. A sparse id is a
    :class:`~panda_rapier.ConfigError` (RLlib has no HER)."""
    return _off_policy(
        SACConfig(),
        env_id,
        training,
        seed=seed,
        num_env_runners=num_env_runners,
        num_envs_per_env_runner=num_envs_per_env_runner,
        num_cpus_per_env_runner=num_cpus_per_env_runner,
        env_kwargs=env_kwargs,
    )


def tqc_config(
    env_id: str = "panda_rapier/PickAndPlaceDense-v0",
    *,
    seed: int = 0,
    num_env_runners: int = 2,
    num_envs_per_env_runner: int = 4,
    num_cpus_per_env_runner: int = 1,
    env_kwargs: Mapping[str, Any] | None = None,
    **training: Any,
) -> TQCConfig:
    """A ``TQCConfig`` for a dense-reward ``env_id``: :func:`sac_config`'s settings plus
    TQC's 2 critics of 25 quantiles, the top 2 of each dropped (``training`` overrides any
    ``TQCConfig.training`` argument, ``n_quantiles`` and friends included)."""
    settings = {"n_quantiles": 25, "n_critics": 2, "top_quantiles_to_drop_per_net": 2}
    settings.update(training)
    return _off_policy(
        TQCConfig(),
        env_id,
        settings,
        seed=seed,
        num_env_runners=num_env_runners,
        num_envs_per_env_runner=num_envs_per_env_runner,
        num_cpus_per_env_runner=num_cpus_per_env_runner,
        env_kwargs=env_kwargs,
    )


def _recipe_env_kwargs(env_id: str, env_kwargs: Mapping[str, Any] | None) -> dict[str, Any]:
    """The SB3 recipes' environment option on dense pick-and-place: the ``release`` term."""
    options = dict(env_kwargs or {})
    if env_id.startswith("panda_rapier/PickAndPlace") and "Dense" in env_id:
        options.setdefault("reward_weights", {"release": 1.0})
    return options


def _with_networks(config: Any, hidden: list[int]) -> Any:
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    return config.rl_module(
        model_config=DefaultModelConfig(fcnet_hiddens=hidden, fcnet_activation="relu")
    )
