"""Observation normalisation inside the policy network, so a saved model is self-contained.

Gymnasium-Robotics and rl-zoo3 normalise observations with a ``VecNormalize`` wrapper whose
statistics live in a separate file that every user of the model must find and apply.
:class:`NormalizedFlatten` is a stable-baselines3 features extractor instead: it flattens the
goal dict in Gymnasium's order and standardises it with a mean and scale held as buffers of the
network, saved and loaded with the model's weights. The statistics are fitted once, before
training, to the states the scripted expert visits (:func:`expert_statistics`; the whole task,
from reaching to placing), and never change afterwards, so evaluation is deterministic.

In a recipe (rl-zoo3 format)::

    policy_kwargs: "dict(features_extractor_class=NormalizedFlatten)"
    callback: panda_rapier.learning.normalization.FitNormalizerCallback

(``panda-rapier train`` resolves ``NormalizedFlatten``; rl-zoo3 needs the full path
``__import__('panda_rapier.learning.normalization').learning.normalization.NormalizedFlatten``.)

rl-zoo3's own recipes say ``normalize: true`` instead (its panda-gym Reach recipe does): a
``VecNormalize`` wrapper with running statistics of the observations and of the discounted
return. ``panda-rapier train`` runs such a recipe unchanged and still saves a self-contained
model: the observations are standardised inside the network by a :class:`NormalizedFlatten`
whose mean and scale :class:`RunningNormalizer` keeps equal to ``VecNormalize``'s running
statistics at every step (stable-baselines3 stores raw observations and standardises them when
it samples, so this is the same arithmetic), and rewards are scaled by ``VecNormalize`` itself
(``norm_obs=False``). The statistics go into the run's checkpoints as data. A run started
``--init-from`` a model continues that model's statistics (:func:`continued_statistics`)
instead of starting them afresh.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.running_mean_std import RunningMeanStd
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from .. import _common
from .._common import CLIP
from ..agents.inference import STANDARDISING_EXTRACTORS, input_feature_dim, input_features
from ..registration import MAX_EPISODE_STEPS
from ..seeds import FIT_FIRST_SEED
from .rollouts import collect

__all__ = [
    "CubeOrientationFeatures",
    "FitNormalizerCallback",
    "NormalizedFlatten",
    "RunningNormalizer",
    "expert_statistics",
    "fit_normalizers",
]

#: Smallest scale a feature is divided by (:data:`panda_rapier._common.MIN_SCALE`).
MIN_SCALE = _common.MIN_SCALE
#: Episodes of the scripted expert the statistics are taken from, and the seed of the first.
FIT_EPISODES = 64


class NormalizedFlatten(BaseFeaturesExtractor):
    """Flattens a ``Dict`` observation (keys sorted, as ``gymnasium.spaces.flatten`` does) and
    maps each entry to ``clip((x - mean) / scale, -10, 10)``. Until :meth:`fit` is called the
    map is the identity."""

    # Buffers (registered in __init__): saved with the policy and moved with it to a device.
    mean: th.Tensor
    scale: th.Tensor

    #: What the network computes from the flat observation before standardising it: one of
    #: ``panda_rapier._native.INPUT_FEATURES`` (``panda_rapier_policies::InputFeatures``),
    #: which the native network computes the same way.
    input_features = STANDARDISING_EXTRACTORS["NormalizedFlatten"]

    def __init__(self, observation_space: gym.spaces.Dict, clip: float = CLIP) -> None:
        name = type(self).__name__
        if not isinstance(observation_space, gym.spaces.Dict):
            raise TypeError(f"{name} needs a Dict space, got {observation_space}")
        keys = sorted(observation_space.spaces)
        flat_dim = sum(gym.spaces.flatdim(observation_space.spaces[k]) for k in keys)
        dim = input_feature_dim(self.input_features, flat_dim)
        super().__init__(observation_space, features_dim=dim)
        self.keys = keys
        self.clip = float(clip)
        self.register_buffer("mean", th.zeros(dim))
        self.register_buffer("scale", th.ones(dim))

    def features(self, flat: np.ndarray) -> np.ndarray:
        """The features (float32) of rows of flat observations, before standardisation."""
        if self.input_features == "flat":
            return np.asarray(flat)
        return input_features(self.input_features, flat)

    def fit(self, flat: np.ndarray, min_scale: float = MIN_SCALE) -> None:
        """Sets mean and scale (standard deviation, at least ``min_scale``) of the features of
        rows of flat observations."""
        mean, scale = _common.standardisation(self.features(flat), self.features_dim, min_scale)
        self.mean.copy_(th.as_tensor(mean))
        self.scale.copy_(th.as_tensor(scale))

    def forward(self, observations: Mapping[str, th.Tensor]) -> th.Tensor:
        flat = th.cat([observations[k].flatten(start_dim=1) for k in self.keys], dim=1)
        if self.input_features != "flat":
            # Computed natively, as the native network does (no gradient flows into inputs).
            features = self.features(flat.detach().cpu().numpy())
            flat = th.as_tensor(features, dtype=flat.dtype, device=flat.device)
        return ((flat - self.mean) / self.scale).clamp(-self.clip, self.clip)


class CubeOrientationFeatures(NormalizedFlatten):
    """:class:`NormalizedFlatten` for tasks whose goals are the cube's orientation (``Flip``):
    the two goal quaternions become the rotation that turns the cube onto its goal (9 entries
    of its matrix) and the cube's pose up to its 24 symmetries (15 entries of the fourth-order
    tensor of its axes), before the standardisation; the rest of the flat observation follows.

    The quaternions (``w >= 0``) jump to the other sign as a turn passes half a turn, and tell
    apart orientations of the cube that look the same; these features are continuous and the
    same for every labelling of the faces (``panda_rapier_policies::InputFeatures``, computed
    natively, so :class:`~panda_rapier.agents.inference.PolicyNetwork` acts on the same
    numbers). In a recipe::

        policy_kwargs: "dict(features_extractor_class=CubeOrientationFeatures)"
    """

    input_features = STANDARDISING_EXTRACTORS["CubeOrientationFeatures"]

    def __init__(self, observation_space: gym.spaces.Dict, clip: float = CLIP) -> None:
        spaces = observation_space.spaces if isinstance(observation_space, gym.spaces.Dict) else {}
        for key in ("achieved_goal", "desired_goal"):
            shape = getattr(spaces.get(key), "shape", None)
            if spaces and shape != (4,):
                raise TypeError(
                    f"CubeOrientationFeatures needs goals that are orientation quaternions "
                    f"(shape (4,)); {key!r} has shape {shape} (tasks whose goals are positions "
                    f"take NormalizedFlatten)"
                )
        super().__init__(observation_space, clip)


def fit_normalizers(policy: th.nn.Module, flat: np.ndarray) -> int:
    """Fits every :class:`NormalizedFlatten` in ``policy`` (actor and critics of off-policy
    algorithms have their own) to ``flat``; returns how many were fitted."""
    fitted = 0
    for module in policy.modules():
        if isinstance(module, NormalizedFlatten):
            module.fit(flat)
            fitted += 1
    return fitted


def expert_statistics(
    config: Mapping[str, Any],
    episodes: int = FIT_EPISODES,
    first_seed: int = FIT_FIRST_SEED,
) -> np.ndarray:
    """The flat observations of ``episodes`` seeded episodes of the scripted expert in the
    environment ``config`` (deterministic: the same rows every time)."""
    demos, _ = collect(config, episodes, first_seed=first_seed)
    return demos.observations


def _config_of_vec_env(env: Any) -> dict[str, Any]:
    """The configuration of a VecEnv's first environment, with a time limit: environments
    made by ``gym.make`` (rl-zoo3's) leave it to Gymnasium's ``TimeLimit`` (``None`` in
    their own configuration)."""
    config = env.get_attr("config", [0])[0]
    if not isinstance(config, Mapping):  # pragma: no cover - a non-panda_rapier env
        raise TypeError("FitNormalizerCallback needs a panda_rapier environment")
    config = dict(config)
    if config.get("max_episode_steps") is None:
        spec = env.get_attr("spec", [0])[0]
        limit = getattr(spec, "max_episode_steps", None)
        config["max_episode_steps"] = int(limit) if limit else MAX_EPISODE_STEPS
    return config


class FitNormalizerCallback(BaseCallback):
    """At the start of training, fits the model's :class:`NormalizedFlatten` extractors to
    the scripted expert's states in the training environment (unless already fitted, as in a
    resumed run or a cloned policy)."""

    def __init__(self, episodes: int = FIT_EPISODES, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.episodes = int(episodes)

    def _on_training_start(self) -> None:
        extractors = [m for m in self.model.policy.modules() if isinstance(m, NormalizedFlatten)]
        if not extractors or any(bool((m.scale != 1).any()) for m in extractors):
            return
        flat = expert_statistics(_config_of_vec_env(self.training_env), self.episodes)
        fit_normalizers(self.model.policy, flat)
        if self.verbose:
            print(f"observation normaliser fitted to {len(flat)} expert states")

    def _on_step(self) -> bool:
        return True


class RunningNormalizer(BaseCallback):
    """Keeps every :class:`NormalizedFlatten` of the model equal to ``VecNormalize``'s running
    observation statistics (``(x - mean) / sqrt(var + epsilon)``, clipped to ``clip_obs``),
    updated with the training environments' observations at the start of training and after
    every step, as ``VecNormalize`` updates them; :meth:`state` and ``restored`` carry them
    (and the reward statistics of the model's ``VecNormalize``, if it has one) through a
    checkpoint as plain data."""

    def __init__(self, settings: Mapping[str, Any], restored: Mapping[str, Any] | None = None):
        super().__init__(0)
        self.settings = dict(settings)
        self.obs_rms: Any = None
        self._restored = dict(restored) if restored else None
        self._extractors: list[NormalizedFlatten] = []

    def _on_training_start(self) -> None:
        self._extractors = [
            m for m in self.model.policy.modules() if isinstance(m, NormalizedFlatten)
        ]
        if self.settings["norm_obs"] and not self._extractors:
            raise TypeError("RunningNormalizer needs a policy with NormalizedFlatten extractors")
        if self.settings["norm_obs"]:
            self.obs_rms = RunningMeanStd(shape=(self._extractors[0].features_dim,))
        if self._restored is not None:
            self._load(self._restored)
            self._restored = None
        elif self.settings["norm_obs"]:
            self._update(self.model._last_obs)
        self._push()

    def _on_step(self) -> bool:
        if self.settings["norm_obs"]:
            self._update(self.locals["new_obs"])
            self._push()
        return True

    def _update(self, observations: Any) -> None:
        keys = self._extractors[0].keys
        n = len(observations[keys[0]])
        flat = np.concatenate([np.asarray(observations[k]).reshape(n, -1) for k in keys], axis=1)
        self.obs_rms.update(flat)  # in the observations' dtype, as VecNormalize does

    def _push(self) -> None:
        if self.obs_rms is None:
            return
        mean = th.as_tensor(self.obs_rms.mean, dtype=th.float32)
        scale = th.as_tensor(np.sqrt(self.obs_rms.var + self.settings["epsilon"]),
                             dtype=th.float32)  # fmt: skip
        for module in self._extractors:
            module.mean.copy_(mean)
            module.scale.copy_(scale)

    def state(self) -> dict[str, Any]:
        """The running statistics as plain data (for a checkpoint's ``state.json``)."""
        state: dict[str, Any] = {}
        if self.obs_rms is not None:
            state["obs"] = _rms_state(self.obs_rms)
        vec_normalize = self.model.get_vec_normalize_env() if self.model is not None else None
        if vec_normalize is not None:
            state["return"] = _rms_state(vec_normalize.ret_rms)
        return state

    def _load(self, state: Mapping[str, Any]) -> None:
        from ..errors import InvalidArgumentError

        try:
            if self.obs_rms is not None:
                _rms_load(self.obs_rms, state["obs"])
            vec_normalize = self.model.get_vec_normalize_env()
            # A model's own statistics (``continued_statistics``) have no return's.
            if vec_normalize is not None and "return" in state:
                _rms_load(vec_normalize.ret_rms, state["return"])
        except (KeyError, TypeError, ValueError) as error:
            raise InvalidArgumentError(
                f"the checkpoint's normalisation statistics do not fit the recipe: {error}"
            ) from error


def continued_statistics(
    model: Any, steps: float, settings: Mapping[str, Any]
) -> dict[str, Any] | None:
    """The observation statistics ``model``'s :class:`NormalizedFlatten` holds, as
    :meth:`RunningNormalizer.state` gives them (``restored``): its mean, its scale squared less
    ``epsilon`` as the variance, and ``steps`` (the observations they were drawn from: the
    weights' model's env steps) as the count. What a run started ``--init-from`` a model begins
    with, so that the network it takes sees its observations scaled as it was trained to;
    without them, :class:`RunningNormalizer` would start from the new run's first
    observations alone (all episode starts, with almost no spread in most entries) and scale
    the taken network's inputs up by thousands (then clipped). ``None`` when there is nothing
    to continue (no observation statistics in the recipe, or ``steps`` not above 0)."""
    if not settings.get("norm_obs") or steps <= 0:
        return None
    extractors = [m for m in model.policy.modules() if isinstance(m, NormalizedFlatten)]
    if not extractors:
        return None
    mean = extractors[0].mean.detach().cpu().double().numpy()
    scale = extractors[0].scale.detach().cpu().double().numpy()
    var = np.maximum(scale**2 - float(settings["epsilon"]), 0.0)
    return {"obs": {"mean": mean.tolist(), "var": var.tolist(), "count": float(steps)}}


def _rms_state(rms: Any) -> dict[str, Any]:
    return {
        "mean": np.atleast_1d(rms.mean).tolist(),
        "var": np.atleast_1d(rms.var).tolist(),
        "count": float(rms.count),
    }


def _rms_load(rms: Any, state: Mapping[str, Any]) -> None:
    mean = np.asarray(state["mean"], dtype=np.float64).reshape(np.shape(rms.mean))
    var = np.asarray(state["var"], dtype=np.float64).reshape(np.shape(rms.var))
    rms.mean, rms.var, rms.count = mean, var, float(state["count"])
