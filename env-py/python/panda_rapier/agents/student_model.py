"""The network of a student that sees (:mod:`panda_rapier.learning.student`) and its model file.

:class:`PixelEncoder` is a stable-baselines3 features extractor: per camera a small CNN ending
in a spatial soft-argmax (one image keypoint per channel, Levine et al., 2016), next to the
standardised vector entries. A student's zip carries its architecture as data in the run
record (``student``, checked by :func:`student_architecture`); :func:`load_student` rebuilds
the network from that and reads the weights by data
(:func:`~panda_rapier.agents.model_file.read_model_file`), so nothing in the file is unpickled. Kept
apart from the training code so that :mod:`panda_rapier.agents.inference` can load a student without
importing it.

Needs the ``train`` extra (stable-baselines3 and torch).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.policies import MultiInputActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from stable_baselines3.common.vec_env import VecTransposeImage
from torch import nn

from .._common import CLIP, MIN_SCALE, standardisation
from ..errors import ConfigError, InvalidArgumentError
from ..pixels import plain_observation, split_options
from ..registration import ENV_IDS
from ..sb3 import make_vec_env
from .model_file import read_model_file, read_run_info

__all__ = [
    "DEFAULT_ARCHITECTURE",
    "PixelEncoder",
    "SpatialSoftArgmax",
    "StudentModel",
    "is_student",
    "load_student",
    "policy_kwargs",
    "student_architecture",
]


#: The student's network when a recipe does not say: CNN channels and strides (the first
#: convolution 5x5, the others 3x3), the actor's and value function's hidden layers, and
#: whether they share the image encoder (a PPO fine-tune may give the value function its own).
DEFAULT_ARCHITECTURE: dict[str, Any] = {
    "channels": [16, 32, 32, 16],
    "strides": [2, 2, 1, 1],
    "net_arch": {"pi": [256, 256], "vf": [256, 256]},
    "share_features_extractor": True,
    "depth_range": None,
}


#: Depths past this (m) reach a depth student's CNN as this. The default camera sees the
#: robot, the platform and the cube between about 1.1 and 2 m; the floor behind them and the
#: empty distance (:data:`~panda_rapier.pixels.DEPTH_FAR`) would otherwise set the scale.
DEPTH_CLIP = 2.5


def _is_image(space: gym.Space[Any]) -> bool:
    return isinstance(space, gym.spaces.Box) and space.dtype == np.uint8 and len(space.shape) == 3


def _is_depth(space: gym.Space[Any]) -> bool:
    """A depth image: float32 ``(height, width, 1)`` (stable-baselines3 leaves it as it is)."""
    return (
        isinstance(space, gym.spaces.Box)
        and space.dtype == np.float32
        and len(space.shape) == 3
        and space.shape[2] == 1
    )


class SpatialSoftArgmax(nn.Module):
    """Per channel of a ``(batch, channels, height, width)`` map, the expected image
    coordinates (x then y, each in [-1, 1]) under a softmax over the channel's activations
    divided by a learned temperature: ``(batch, 2 * channels)`` keypoints."""

    def __init__(self, height: int, width: int) -> None:
        super().__init__()
        self.register_buffer("xs", th.linspace(-1.0, 1.0, width), persistent=False)
        self.register_buffer("ys", th.linspace(-1.0, 1.0, height), persistent=False)
        self.log_temperature = nn.Parameter(th.zeros(1))

    xs: th.Tensor
    ys: th.Tensor

    def forward(self, x: th.Tensor) -> th.Tensor:
        b, c, h, w = x.shape
        p = th.softmax(x.flatten(2) / self.log_temperature.exp(), dim=-1).view(b, c, h, w)
        return th.cat([(p.sum(2) * self.xs).sum(-1), (p.sum(3) * self.ys).sum(-1)], dim=1)


class PixelEncoder(BaseFeaturesExtractor):
    """The features of a ``Dict`` observation with images: colour (uint8 ``(3, height,
    width)``, as stable-baselines3 passes them on, scaled to [0, 1] by it) and depth (float32
    ``(height, width, 1)`` metres, clamped to :data:`DEPTH_CLIP`, less the mean image
    ``depth_mean`` and divided by ``depth_scale``, one pair per depth image, identity until
    :meth:`fit_depth`: what differs from the usual scene, in units of how much it usually
    differs); or, with ``depth_range`` (metres), less the mean image, clipped to
    ``[-depth_range, depth_range]`` and divided by it: what stands nearer or farther than the
    usual scene by up to ``depth_range``, where a small object and the arm both reach the
    limit. Per image, in key order, a CNN (``channels`` and ``strides``; a 5x5
    first convolution, 3x3 after it, ReLU between) whose last layer's channels become keypoints
    (:class:`SpatialSoftArgmax`); then the other entries flattened in key order and mapped to
    ``clip((x - mean) / scale, -10, 10)`` (identity until :meth:`fit`)."""

    mean: th.Tensor
    scale: th.Tensor
    depth_mean: th.Tensor
    depth_scale: th.Tensor

    def __init__(
        self,
        observation_space: gym.spaces.Dict,
        channels: Sequence[int] = (16, 32, 32, 16),
        strides: Sequence[int] = (2, 2, 1, 1),
        clip: float = CLIP,
        depth_range: float | None = None,
    ) -> None:
        if not isinstance(observation_space, gym.spaces.Dict):
            raise TypeError(f"PixelEncoder needs a Dict space, got {observation_space}")
        channels, strides = [int(c) for c in channels], [int(s) for s in strides]
        if not channels or len(channels) != len(strides):
            raise ConfigError("PixelEncoder needs as many strides as channels, at least one")
        if any(not 1 <= c <= 512 for c in channels) or any(not 1 <= s <= 4 for s in strides):
            raise ConfigError("PixelEncoder channels must be in [1, 512] and strides in [1, 4]")
        keys = sorted(observation_space.spaces)
        image_keys = [
            k
            for k in keys
            if _is_image(observation_space.spaces[k]) or _is_depth(observation_space.spaces[k])
        ]
        depth_keys = [k for k in image_keys if _is_depth(observation_space.spaces[k])]
        vector_keys = [k for k in keys if k not in image_keys]
        if not image_keys:
            raise TypeError(
                "PixelEncoder needs at least one uint8 colour or float32 depth image in the "
                "observation"
            )
        vector_dim = sum(gym.spaces.flatdim(observation_space.spaces[k]) for k in vector_keys)
        cnns = []
        for key in image_keys:
            shape = observation_space.spaces[key].shape
            assert shape is not None
            if key in depth_keys:
                shape = (1, shape[0], shape[1])
            elif shape[0] != 3:
                raise TypeError(f"PixelEncoder needs channels-first images, got {key}: {shape}")
            layers: list[nn.Module] = []
            previous = shape[0]
            for i, (c, s) in enumerate(zip(channels, strides, strict=True)):
                kernel = 5 if i == 0 else 3
                layers += [nn.Conv2d(previous, c, kernel, s, kernel // 2), nn.ReLU()]
                previous = c
            layers.pop()  # the keypoints take the last convolution's raw activations
            with th.no_grad():
                height, width = nn.Sequential(*layers)(th.zeros(1, *shape)).shape[2:]
            cnns.append(nn.Sequential(*layers, SpatialSoftArgmax(int(height), int(width))))
        super().__init__(observation_space, features_dim=2 * channels[-1] * len(cnns) + vector_dim)
        self.image_keys, self.vector_keys = image_keys, vector_keys
        self.depth_keys = depth_keys
        self.cnns = nn.ModuleList(cnns)
        self.clip = float(clip)
        self.depth_range = _depth_range(depth_range)
        self.register_buffer("mean", th.zeros(vector_dim))
        self.register_buffer("scale", th.ones(vector_dim))
        if depth_keys:  # a colour student's weights stay as they were
            height, width = observation_space.spaces[depth_keys[0]].shape[:2]  # type: ignore[index]
            self.register_buffer("depth_mean", th.zeros(len(depth_keys), 1, height, width))
            self.register_buffer("depth_scale", th.ones(len(depth_keys)))

    def fit(self, vectors: np.ndarray, min_scale: float = MIN_SCALE) -> None:
        """Sets the vector entries' mean and scale (standard deviation, at least
        ``min_scale``) from rows of them (the vector keys' values side by side, in key
        order)."""
        mean, scale = standardisation(vectors, int(self.mean.shape[0]), min_scale)
        self.mean.copy_(th.as_tensor(mean))
        self.scale.copy_(th.as_tensor(scale))

    def fit_depth(self, depths: Sequence[np.ndarray]) -> None:
        """Sets each depth image's mean image (per pixel, of the images clamped to
        :data:`DEPTH_CLIP`) and scale (the standard deviation of all pixels' differences
        from it, at least ``MIN_SCALE`` m): one array of ``(n, height, width, 1)`` images per
        depth key, in key order."""
        if len(depths) != len(self.depth_keys):
            raise InvalidArgumentError(
                f"fit_depth needs one array per depth key {self.depth_keys}, got {len(depths)}"
            )
        for i, images in enumerate(depths):
            clamped = np.minimum(np.asarray(images, dtype=np.float64), DEPTH_CLIP)
            mean = clamped.mean(axis=0)  # (height, width, 1)
            scale = float(np.sqrt(np.mean((clamped - mean) ** 2)))
            self.depth_mean[i] = th.as_tensor(mean.transpose(2, 0, 1))
            self.depth_scale[i] = max(scale, MIN_SCALE)

    def _input(self, key: str, value: th.Tensor) -> th.Tensor:
        if key not in self.depth_keys:
            return value
        i = self.depth_keys.index(key)
        depth = value.permute(0, 3, 1, 2).clamp(max=DEPTH_CLIP)
        if self.depth_range is not None:
            r = self.depth_range
            return (depth - self.depth_mean[i]).clamp(-r, r) / r
        return (depth - self.depth_mean[i]) / self.depth_scale[i]

    def forward(self, observations: Mapping[str, th.Tensor]) -> th.Tensor:
        parts = [
            cnn(self._input(k, observations[k]))
            for k, cnn in zip(self.image_keys, self.cnns, strict=True)
        ]
        if self.vector_keys:
            flat = th.cat([observations[k].flatten(start_dim=1) for k in self.vector_keys], dim=1)
            parts.append(((flat - self.mean) / self.scale).clamp(-self.clip, self.clip))
        return th.cat(parts, dim=1)


def _depth_range(value: Any) -> float | None:
    """``depth_range`` checked: ``None`` or metres in ``(0, DEPTH_CLIP]``."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(f"student depth_range must be a number of metres, got {value!r}")
    if not 0.0 < value <= DEPTH_CLIP:
        raise ConfigError(f"student depth_range must be in (0, {DEPTH_CLIP}] m, got {value}")
    return float(value)


def student_architecture(spec: Any) -> dict[str, Any]:
    """A student's architecture (``channels``, ``strides``, ``net_arch`` with ``pi`` and
    ``vf``; for depth images ``depth_range``, see :class:`PixelEncoder`) from a recipe's or
    a run record's ``student`` entry, checked: plain data only, so a model file's record can
    be read without running anything. Missing entries take :data:`DEFAULT_ARCHITECTURE`'s."""
    if spec is None:
        spec = {}
    if not isinstance(spec, Mapping):
        raise ConfigError(f"student must be a mapping of channels, strides, net_arch: {spec!r}")
    unknown = set(spec) - set(DEFAULT_ARCHITECTURE)
    if unknown:
        raise ConfigError(f"student: unknown entries {sorted(unknown)}")
    arch = {**DEFAULT_ARCHITECTURE, **dict(spec)}

    def ints(value: Any, what: str, low: int, high: int) -> list[int]:
        if (
            not isinstance(value, list | tuple)
            or not value
            or any(
                isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high for v in value
            )
        ):
            raise ConfigError(f"student {what} must be a non-empty list of ints in [{low}, {high}]")
        return [int(v) for v in value]

    net = arch["net_arch"]
    if not isinstance(net, Mapping) or set(net) != {"pi", "vf"}:
        raise ConfigError("student net_arch must be a mapping with pi and vf")
    channels = ints(arch["channels"], "channels", 1, 512)
    strides = ints(arch["strides"], "strides", 1, 4)
    if len(channels) != len(strides):
        raise ConfigError("student channels and strides must have the same length")
    share = arch["share_features_extractor"]
    if not isinstance(share, bool):
        raise ConfigError("student share_features_extractor must be true or false")
    checked = {
        "channels": channels,
        "strides": strides,
        "net_arch": {k: ints(net[k], f"net_arch {k}", 1, 4096) for k in ("pi", "vf")},
        "share_features_extractor": share,
    }
    depth_range = _depth_range(arch["depth_range"])
    if depth_range is not None:  # absent otherwise: earlier records read as they were
        checked["depth_range"] = depth_range
    return checked


def policy_kwargs(arch: Mapping[str, Any]) -> dict[str, Any]:
    """stable-baselines3 ``policy_kwargs`` of a student of architecture ``arch``."""
    return {
        "features_extractor_class": PixelEncoder,
        "features_extractor_kwargs": {
            "channels": arch["channels"],
            "strides": arch["strides"],
            **({"depth_range": arch["depth_range"]} if arch.get("depth_range") else {}),
        },
        "net_arch": {"pi": arch["net_arch"]["pi"], "vf": arch["net_arch"]["vf"]},
        "activation_fn": nn.ReLU,
        "share_features_extractor": bool(arch.get("share_features_extractor", True)),
    }


@dataclass
class StudentModel:
    """A student read from its model file: the stable-baselines3 policy (``policy``), with
    ``predict`` as stable-baselines3 models have it and the observation options the
    environment must be made with (``observation``: ``obs_mode``, ``image_size``,
    ``cameras``)."""

    policy: Any
    observation: dict[str, Any]
    run: dict[str, Any]
    device: th.device = field(default_factory=lambda: th.device("cpu"))

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """As stable-baselines3's ``predict``: actions for a (batched) observation dict."""
        return self.policy.predict(observation, state, episode_start, deterministic)


def is_student(run: Mapping[str, Any] | None) -> bool:
    """Whether a run record is a student's (it carries the ``student`` architecture)."""
    return isinstance(run, Mapping) and isinstance(run.get("student"), Mapping)


def load_student(path: str | Path) -> StudentModel:
    """A student saved by ``panda-rapier train --algo bc`` with image observations, rebuilt
    from its run record's architecture and environment options and filled with its weights,
    all read by data: nothing in the file is unpickled or run."""
    path = Path(path)
    run = read_run_info(path)
    if run is None or not is_student(run):
        raise InvalidArgumentError(f"{path} is not a student's model file (no student record)")
    arch = student_architecture(run["student"])
    env_id, options = run.get("env_id"), run.get("env_kwargs")
    if env_id not in ENV_IDS or not isinstance(options, Mapping):
        raise InvalidArgumentError(f"{path}: its run record names no panda_rapier environment")
    _, state = read_model_file(path)
    env = make_vec_env(str(env_id), n_envs=1, **options)
    try:
        assert isinstance(env.observation_space, gym.spaces.Dict)
        spaces = {
            k: VecTransposeImage.transpose_space(v)
            if isinstance(v, gym.spaces.Box) and _is_image(v)
            else v
            for k, v in env.observation_space.spaces.items()
        }
        policy = MultiInputActorCriticPolicy(
            gym.spaces.Dict(spaces), env.action_space, lambda _: 0.0, **policy_kwargs(arch)
        )
    finally:
        env.close()
    try:
        policy.load_state_dict({k: th.as_tensor(np.array(v)) for k, v in state.items()})
    except (RuntimeError, TypeError) as error:
        raise InvalidArgumentError(f"{path}: weights unfit for the student: {error}") from None
    policy.set_training_mode(False)
    return StudentModel(policy, plain_observation(split_options(options)[1]), dict(run))
