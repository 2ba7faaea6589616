"""The stable-baselines3 PPO recipe on RLlib's side: its network, read from the same recipe.

What made ``panda-rapier train --algo ppo`` solve pick-and-place (``hyperparams/ppo.yml``),
ported to RLlib's new API stack (docs/guide/ray.md):

- **observation standardisation**: the recipe's ``NormalizedFlatten`` fits a mean and scale to
  the scripted expert's states before training and never changes them. Here the same
  statistics (:func:`~panda_rapier.learning.normalization.expert_statistics`, the same 64 episodes)
  are buffers of the RLModule (:class:`RecipePPOTorchRLModule`), applied to the flat
  observation before the actor and critic encoders, so a checkpoint is self-contained;
- **the gripper's exploration floor**: the recipe's ``MinActionStd`` callback raises the
  gripper's ``log_std`` to ``log(0.3)`` before every rollout. Here the module's free
  ``log_std`` is floored inside its forward pass (sampling and the loss see the same
  distribution);
- **the ``release`` term**: an environment option, passed through ``env_kwargs``.

The model configuration (:func:`recipe_model_config`) is a plain dict of RLlib's
``DefaultModelConfig`` plus ``observation_mean``, ``observation_scale``, ``log_std_init``,
``min_action_std`` and ``action_std_dims``. :func:`export_policy` writes a trained module as
a stable-baselines3 PPO zip of the recipe's own policy (``NormalizedFlatten`` with the same
statistics, the same layers), which ``panda-rapier eval --policy`` and the benchmark table
read like every other model. ``panda-rapier train --backend rllib`` trains with
it (:mod:`panda_rapier.scale.rllib_training`).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

from .._common import CLIP, standardisation
from .._deprecated import same_class
from ..agents.model_file import save_model
from ..errors import ConfigError
from ..learning.normalization import NormalizedFlatten, expert_statistics
from ..learning.recipes import model_kwargs

__all__ = [
    "RecipePPOTorchRLModule",
    "as_sb3",
    "export_policy",
    "recipe_model_config",
    "trained_module",
]

#: The recipe's activation names (``activation_fn=nn.ReLU``) as RLlib spells them.
_ACTIVATIONS = {"ReLU": "relu", "Tanh": "tanh", "SiLU": "silu"}

#: The recipe callbacks that set up the RLlib module (their recorded paths, old or new, match).
FIT_NORMALIZER = "panda_rapier.learning.normalization.FitNormalizerCallback"
MIN_ACTION_STD = "panda_rapier.learning.exploration.MinActionStd"


class RecipePPOTorchRLModule(DefaultPPOTorchRLModule):
    """RLlib's default PPO module (separate actor and critic MLPs, a state-independent
    ``log_std``) with the recipe's observation standardisation and exploration floor.

    Reads from ``model_config``: ``observation_mean`` / ``observation_scale`` (each observation
    becomes ``clip((x - mean) / scale, -10, 10)``, as ``NormalizedFlatten``), ``log_std_init``
    (the free ``log_std``'s initial value, as SB3's ``log_std_init``), ``min_action_std`` and
    ``action_std_dims`` (the listed action dimensions' standard deviation is at least
    ``min_action_std``; ``None`` for no floor)."""

    def setup(self) -> None:
        """Builds the default module, then the recipe's buffers."""
        super().setup()
        model_config: Any = self.model_config or {}
        if isinstance(model_config, DefaultModelConfig):
            model_config = dataclasses.asdict(model_config)
        config: Mapping[str, Any] = dict(model_config)
        dim = int(np.prod(getattr(self.observation_space, "shape", ())))
        mean = np.asarray(config.get("observation_mean") or np.zeros(dim), dtype=np.float32)
        scale = np.asarray(config.get("observation_scale") or np.ones(dim), dtype=np.float32)
        if mean.shape != (dim,) or scale.shape != (dim,) or not (scale > 0).all():
            raise ConfigError(
                f"observation_mean and observation_scale must be {dim} values (scales > 0)"
            )
        self.register_buffer("observation_mean", torch.from_numpy(mean))
        self.register_buffer("observation_scale", torch.from_numpy(scale))
        actions = int(np.prod(getattr(self.action_space, "shape", ())))
        floor = torch.full((actions,), -math.inf)
        min_std = config.get("min_action_std")
        if min_std is not None:
            for d in config.get("action_std_dims") or [-1]:
                if not -actions <= int(d) < actions:
                    raise ConfigError(f"action dimension {d} out of range for {actions}")
                floor[int(d)] = math.log(float(min_std))
        self.register_buffer("log_std_floor", floor)
        log_std = getattr(self.pi, "log_std", None)
        if log_std is None:
            raise ConfigError("RecipePPOTorchRLModule needs free_log_std=True")
        with torch.no_grad():
            log_std.fill_(float(config.get("log_std_init", 0.0)))

    def _standardised(self, batch: dict[str, Any]) -> dict[str, Any]:
        out = dict(batch)
        obs = batch[Columns.OBS]
        out[Columns.OBS] = ((obs - self.observation_mean) / self.observation_scale).clamp(
            -CLIP, CLIP
        )
        return out

    def _floored(self, output: dict[str, Any]) -> dict[str, Any]:
        inputs = output[Columns.ACTION_DIST_INPUTS]
        mean, log_std = torch.chunk(inputs, 2, dim=-1)
        output[Columns.ACTION_DIST_INPUTS] = torch.cat(
            (mean, torch.maximum(log_std, self.log_std_floor)), dim=-1
        )
        return output

    @functools.cached_property
    def _acts_the_same_in_eval(self) -> bool:
        """No layer acts differently under ``eval()`` (no dropout, no batch normalisation)."""
        return not any(
            isinstance(m, torch.nn.Dropout | torch.nn.modules.batchnorm._BatchNorm)
            for m in self.modules()
        )

    def forward_exploration(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        """RLlib's, without switching every layer to ``eval()`` and back around each call
        (3 % of a runner's sampling) when no layer acts differently under ``eval()``."""
        if self._acts_the_same_in_eval:
            return self._forward_exploration(batch, **kwargs)
        return super().forward_exploration(batch, **kwargs)

    def forward_inference(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        """RLlib's, without the ``eval()`` switches (see :meth:`forward_exploration`)."""
        if self._acts_the_same_in_eval:
            return self._forward_inference(batch, **kwargs)
        return super().forward_inference(batch, **kwargs)

    def _forward(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        return self._floored(super()._forward(self._standardised(batch), **kwargs))

    def _forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        return self._floored(super()._forward_train(self._standardised(batch), **kwargs))

    def compute_values(self, batch: dict[str, Any], embeddings: Any = None) -> Any:
        """The critic's values (of the standardised observations when no embeddings are
        given)."""
        if embeddings is None:
            batch = self._standardised(batch)
        return super().compute_values(batch, embeddings)


def _policy_kwargs(recipe: Mapping[str, Any]) -> dict[str, Any]:
    return dict(model_kwargs("ppo", recipe).get("policy_kwargs") or {})


@functools.lru_cache(maxsize=8)
def _expert_standardisation(
    env_config: str, episodes: int
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Mean and scale of the expert's flat observations in an environment (its configuration
    as JSON), as ``FitNormalizerCallback`` fits them; the same every time, so kept."""
    flat = expert_statistics(json.loads(env_config), episodes)
    mean, scale = standardisation(flat, flat.shape[1])
    return tuple(float(v) for v in mean), tuple(float(v) for v in scale)


def recipe_model_config(
    recipe: Mapping[str, Any], env_config: Mapping[str, Any], *, fit_episodes: int = 64
) -> dict[str, Any]:
    """The RLlib ``model_config`` of a PPO recipe (``hyperparams/ppo.yml``'s format) for the
    environment ``env_config``: its ``net_arch`` (the same for actor and critic) and
    activation, its ``log_std_init``; the expert's observation statistics if the recipe
    normalises (``NormalizedFlatten`` with ``FitNormalizerCallback``), the exploration floor
    if it has ``MinActionStd``."""
    kwargs = _policy_kwargs(recipe)
    arch = kwargs.get("net_arch", [64, 64])
    if isinstance(arch, Mapping):
        if list(arch.get("pi", [])) != list(arch.get("vf", [])):
            raise ConfigError("the RLlib port needs the same net_arch for pi and vf")
        arch = arch["pi"]
    activation = getattr(kwargs.get("activation_fn"), "__name__", "Tanh")
    if activation not in _ACTIVATIONS:
        raise ConfigError(f"activation {activation} has no RLlib name here")
    config: dict[str, Any] = dataclasses.asdict(
        DefaultModelConfig(
            fcnet_hiddens=[int(h) for h in arch],
            fcnet_activation=_ACTIVATIONS[activation],
            free_log_std=True,
            vf_share_layers=False,
        )
    )
    config["log_std_init"] = float(kwargs.get("log_std_init", 0.0))
    callbacks = recipe.get("callback") or []
    callbacks = callbacks if isinstance(callbacks, list) else [callbacks]
    names = {next(iter(c)) if isinstance(c, Mapping) else str(c): c for c in callbacks}
    extractor = kwargs.get("features_extractor_class")
    if isinstance(extractor, type) and issubclass(extractor, NormalizedFlatten):
        if extractor is not NormalizedFlatten:
            raise ConfigError(
                f"RLlib recipes standardise the flat observation (NormalizedFlatten); "
                f"{extractor.__name__} is for panda-rapier train's stable-baselines3 algorithms"
            )
        if not any(same_class(n, FIT_NORMALIZER) for n in names):
            raise ConfigError("NormalizedFlatten without FitNormalizerCallback is not fitted")
        mean, scale = _expert_standardisation(json.dumps(dict(env_config), sort_keys=True),
                                              fit_episodes)  # fmt: skip
        config["observation_mean"] = list(mean)
        config["observation_scale"] = list(scale)
    floor = next((c for n, c in names.items() if same_class(n, MIN_ACTION_STD)), None)
    if floor is not None:
        settings = dict(next(iter(floor.values())) or {}) if isinstance(floor, Mapping) else {}
        config["min_action_std"] = float(settings.get("min_std", 0.3))
        config["action_std_dims"] = [int(d) for d in settings.get("dims", [-1])]
    return config


def trained_module(algo: Any) -> RecipePPOTorchRLModule:
    """The whole module (actor and critic) with the learner's current weights; the
    EnvRunners' copies (``algo.get_module()``) are inference-only, without the critic."""
    from ray.rllib.core import DEFAULT_MODULE_ID

    runner = algo.get_module()  # the local EnvRunner's: it knows the (flattened) spaces
    spaces = {DEFAULT_MODULE_ID: (runner.observation_space, runner.action_space)}
    module = algo.config.get_rl_module_spec(spaces=spaces, inference_only=False).build()
    if not isinstance(module, RecipePPOTorchRLModule):
        raise ConfigError(f"not a recipe module: {type(module).__name__}")
    weights = algo.learner_group.get_weights(module_ids=[DEFAULT_MODULE_ID])
    module.set_state(weights[DEFAULT_MODULE_ID])
    return module


def _linears(module: torch.nn.Module) -> list[torch.nn.Linear]:
    return [m for m in module.modules() if isinstance(m, torch.nn.Linear)]


def as_sb3(
    module: RecipePPOTorchRLModule,
    recipe: Mapping[str, Any],
    env_id: str,
    env_kwargs: Mapping[str, Any] | None = None,
) -> Any:
    """The RLlib ``module`` as a stable-baselines3 ``PPO`` of ``recipe``'s policy
    (``NormalizedFlatten`` holding the module's statistics, the same actor and critic layers,
    ``log_std`` floored as the module floors it): the same deterministic actions."""
    import gymnasium as gym
    from stable_baselines3 import PPO

    kwargs = model_kwargs("ppo", recipe)
    env = gym.make(env_id, **dict(env_kwargs or {}))
    try:
        keep = ("policy_kwargs", "gamma", "gae_lambda")
        model = PPO(
            str(kwargs.get("policy", "MultiInputPolicy")),
            env,
            device="cpu",
            **{k: v for k, v in kwargs.items() if k in keep},
        )
    finally:
        env.close()
    policy = model.policy
    extractors = [m for m in policy.modules() if isinstance(m, NormalizedFlatten)]
    with torch.no_grad():
        for extractor in extractors:
            extractor.mean.copy_(module.observation_mean)
            extractor.scale.copy_(module.observation_scale)
        encoder = module.encoder
        pairs: list[tuple[list[torch.nn.Linear], list[torch.nn.Linear]]] = [
            (_linears(encoder.actor_encoder), _linears(policy.mlp_extractor.policy_net)),
            (_linears(encoder.critic_encoder), _linears(policy.mlp_extractor.value_net)),
            (_linears(module.pi), _linears(policy.action_net)),
            (_linears(module.vf), _linears(policy.value_net)),
        ]
        for source, target in pairs:
            if len(source) != len(target):
                raise ConfigError("the RLlib module and the recipe's policy differ in layers")
            for a, b in zip(source, target, strict=True):
                if a.weight.shape != b.weight.shape:
                    raise ConfigError(
                        f"layer shapes differ: {tuple(a.weight.shape)} vs {tuple(b.weight.shape)}"
                    )
                b.weight.copy_(a.weight)
                b.bias.copy_(a.bias)
        policy.log_std.copy_(torch.maximum(module.pi.log_std, module.log_std_floor))
    return model


def export_policy(
    module: RecipePPOTorchRLModule,
    path: str | Path,
    *,
    recipe: Mapping[str, Any],
    run: Mapping[str, Any],
) -> Path:
    """Writes the RLlib ``module`` as a stable-baselines3 PPO zip (:func:`as_sb3`) with the
    run record ``run`` inside (``panda_rapier_run.json``: ``env_id``, ``env_kwargs`` and
    ``config`` at least), so ``panda-rapier eval --policy PATH`` evaluates it like any other
    model."""
    model = as_sb3(module, recipe, str(run["env_id"]), run.get("env_kwargs"))
    out = Path(path)
    save_model(model, out, run)
    return out
