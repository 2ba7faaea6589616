"""Trained policies acted out the same way on every CPU: :class:`PolicyNetwork`.

torch evaluates a network in float32 with matrix kernels it picks by the CPU's vector width
(AVX-512, AVX2 or none), each summing in its own order, so the same saved model gives slightly
different actions on different machines, and now and then a different episode outcome.
:class:`PolicyNetwork` computes a stable-baselines3 policy's deterministic action with the
native ``PolicyNetwork`` instead: float64, one fixed order of operations, portable ``tanh``,
the same bits on every CPU (``panda_rapier_policies::network``). ``panda-rapier eval`` uses
it for every model it can (``--inference torch`` asks for torch instead).

A model file is read by data alone: the ``data`` entry as JSON (only its plain fields; the
pickled ones are never unpickled) and the weights by :mod:`panda_rapier.agents.model_file` (no torch
needed: a shipped model evaluates with the base install).
Supported: PPO and A2C (``MlpPolicy`` / ``MultiInputPolicy``), SAC and TQC (their actor), TD3
and DDPG, with ReLU or Tanh hidden layers, on state observations, with the default flattening
features extractor, :class:`~panda_rapier.learning.normalization.NormalizedFlatten` or
:class:`~panda_rapier.learning.normalization.CubeOrientationFeatures`. Anything else
(image encoders, gSDE on SAC, other activations) raises :class:`UnsupportedModelError`, and
``panda-rapier eval`` falls back to loading the model with stable-baselines3.
"""

from __future__ import annotations

import ast
import json
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
from gymnasium import spaces

from .. import _common, _native
from ..errors import ConfigError, InvalidArgumentError
from ..pixels import split_options
from ..policy import RandomPolicy, ScriptedPolicy, observation_rows
from ..registration import DEFAULT_ENV_ID, ENV_IDS, env_config
from .model_file import (
    UnsupportedModelError,
    UntrustedModelError,
    load_sb3_model,
    model_observation,
    read_model_file,
    read_run_info,
    saved_spaces,
)

__all__ = [
    "NATIVE",
    "STANDARDISING_EXTRACTORS",
    "TORCH",
    "EvaluatedPolicy",
    "NetworkSpec",
    "PolicyNetwork",
    "UnsupportedModelError",
    "UntrustedModelError",
    "input_feature_dim",
    "input_features",
    "load_policy",
    "resolve_policy",
    "space_mismatch",
]

#: The inference of :class:`PolicyNetwork`: float64, fixed order, CPU-independent.
NATIVE = "native-f64"
#: Bound of a standardised observation entry (:data:`panda_rapier._common.CLIP`).
CLIP = _common.CLIP
#: A stable-baselines3 model's own ``predict``: torch float32, CPU-dependent kernels.
TORCH = "torch-f32"

#: Default hidden activations of stable-baselines3's policies, by family.
_DEFAULT_ACTIVATION = {"actor-critic": "tanh", "sac": "relu", "td3": "relu"}
_ACTIVATIONS = {"ReLU": "relu", "Tanh": "tanh"}
#: The standardising features extractors (``panda_rapier.learning.normalization``) by class
#: name, and the input features each computes first (``_native.INPUT_FEATURES``).
STANDARDISING_EXTRACTORS = {
    "NormalizedFlatten": "flat",
    "CubeOrientationFeatures": "cube_orientation",
}


def input_features(features: str, flat: np.ndarray) -> np.ndarray:
    """The input features ``features`` (one of :data:`STANDARDISING_EXTRACTORS`' values) of
    rows of flat observations, float32, computed as the native network computes them."""
    return _native.input_features(features, np.ascontiguousarray(flat, dtype=np.float32))


def input_feature_dim(features: str, observation_dim: int) -> int:
    """Length of the input features ``features`` of a flat observation of ``observation_dim``."""
    return observation_dim + _native.INPUT_FEATURES[features]


#: Policy modules (``data["policy_class"]["__module__"]``) and the family each belongs to.
_FAMILIES = {
    "stable_baselines3.common.policies": "actor-critic",
    "stable_baselines3.sac.policies": "sac",
    "sb3_contrib.tqc.policies": "sac",
    "stable_baselines3.td3.policies": "td3",
}

#: ``policy_kwargs`` that leave the deterministic action's computation as built here (the
#: others change the network: refused rather than guessed).
_KNOWN_POLICY_KWARGS = {
    "net_arch", "activation_fn", "features_extractor_class", "features_extractor_kwargs",
    "share_features_extractor", "ortho_init", "log_std_init", "optimizer_class",
    "optimizer_kwargs", "normalize_images", "n_critics", "n_quantiles", "squash_output",
    # gSDE's: they change only the exploration noise of PPO and A2C (SAC's is refused).
    "use_sde", "use_expln", "full_std", "clip_mean",
}  # fmt: skip


@dataclass(frozen=True)
class NetworkSpec:
    """What the native network is built from (float32 arrays, torch's layout)."""

    observation_dim: int
    #: ``(weight, bias)`` per layer (``weight``: outputs x inputs), the output layer last.
    layers: list[tuple[np.ndarray, np.ndarray]]
    #: ``relu`` or ``tanh``, between hidden layers.
    activation: str
    #: ``clip`` (to the bounds) or ``squash`` (tanh, then scaled to the bounds).
    output: str
    low: np.ndarray
    high: np.ndarray
    #: ``(mean, scale, clip)`` of :class:`~panda_rapier.learning.normalization.NormalizedFlatten`.
    standardizer: tuple[np.ndarray, np.ndarray, float] | None = None
    #: What the network computes from the flat observation first (``_native.INPUT_FEATURES``).
    features: str = "flat"


class PolicyNetwork:
    """A stable-baselines3 policy's deterministic action, computed by the native
    ``PolicyNetwork`` (float64, fixed order: the same bits on every CPU).

    Build it with :meth:`from_zip` (a saved model, read without unpickling anything) or
    :meth:`from_sb3` (a model in memory). :meth:`act` maps flat observation rows (Gymnasium's
    ``spaces.flatten`` order of the goal dict: ``achieved_goal``, ``desired_goal``,
    ``observation``) to action rows; :meth:`predict` takes the dict, as stable-baselines3's
    does, so :func:`~panda_rapier.agents.evaluation.evaluate` and user code can use either.
    """

    inference = NATIVE

    def __init__(self, spec: NetworkSpec, algorithm: str, source: str) -> None:
        self.spec = spec
        self.network = _native.PolicyNetwork(
            spec.observation_dim,
            spec.layers,
            spec.activation,
            spec.output,
            spec.low,
            spec.high,
            spec.standardizer,
            spec.features,
        )
        #: ``actor-critic`` (PPO, A2C), ``sac`` (SAC, TQC) or ``td3`` (TD3, DDPG).
        self.algorithm = algorithm
        #: Where the weights came from.
        self.source = source

    @property
    def observation_dim(self) -> int:
        return self.network.observation_dim

    @property
    def action_dim(self) -> int:
        return self.network.action_dim

    def act(self, observations: Any) -> np.ndarray:
        """Actions (``n x action_dim`` float32) for observations (flat rows ``n x
        observation_dim`` or the goal dict, finite); one observation gives one action."""
        rows, single = observation_rows(observations, self.observation_dim, "the network")
        actions = self.network.act(rows)
        return actions[0] if single else actions

    def predict(
        self,
        observation: Mapping[str, Any] | np.ndarray,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, None]:
        """stable-baselines3's ``predict``: the deterministic action(s) for a goal dict or flat
        rows, single or batched; ``deterministic=False`` is refused (the network holds no
        noise)."""
        if not deterministic:
            raise InvalidArgumentError("PolicyNetwork acts deterministically only")
        return self.act(observation), None

    def __repr__(self) -> str:
        return (
            f"PolicyNetwork({self.algorithm}, {self.observation_dim} -> "
            f"{self.network.hidden_sizes} -> {self.action_dim}, from {self.source})"
        )

    @classmethod
    def from_zip(cls, path: str | Path) -> PolicyNetwork:
        """Reads a stable-baselines3 model file by data alone (nothing in it is unpickled or
        run); :class:`UnsupportedModelError` says why a file cannot be acted out natively."""
        data, state = read_model_file(path)
        module = str(data.get("policy_class", {}).get("__module__", ""))
        family = _FAMILIES.get(module)
        if family is None:
            raise UnsupportedModelError(f"policy class from {module or '?'}")
        kwargs = data.get("policy_kwargs") or {}
        if not isinstance(kwargs, Mapping):
            raise UnsupportedModelError("unreadable policy_kwargs")
        kwargs = {k: v for k, v in kwargs.items() if k not in (":type:", ":serialized:")}
        activation, extractor, clip = _options(family, kwargs, data.get("use_sde"))
        space = data.get("observation_space") or {}
        if "uint8" in str(space.get("spaces", "")) + str(space.get("dtype", "")):
            raise UnsupportedModelError("image observations (a CNN encoder)")
        low, high = _bounds(data.get("action_space") or {})
        return cls(_build(state, family, activation, extractor, clip, low, high), family, str(path))

    @classmethod
    def from_sb3(cls, model: Any) -> PolicyNetwork:
        """The same network as a stable-baselines3 model in memory (its policy's weights, read
        once: later training does not change this copy)."""
        policy = model.policy
        module = type(policy).__module__
        family = _FAMILIES.get(module)
        if family is None:
            raise UnsupportedModelError(f"policy class {type(policy).__name__} from {module}")
        kwargs = getattr(model, "policy_kwargs", {}) or {}
        activation, extractor, clip = _options(family, kwargs, getattr(model, "use_sde", False))
        space = model.action_space
        state = {k: v.detach().cpu() for k, v in policy.state_dict().items()}
        low, high = np.asarray(space.low, np.float32), np.asarray(space.high, np.float32)
        spec = _build(state, family, activation, extractor, clip, low, high)
        return cls(spec, family, type(model).__name__)

    def save(self, path: str | Path) -> None:
        """Writes the network as a ``.npz`` of plain arrays (no pickle, no torch needed to
        read it back with :meth:`load`)."""
        spec = self.spec
        arrays: dict[str, np.ndarray] = {"low": spec.low, "high": spec.high}
        for i, (weight, bias) in enumerate(spec.layers):
            arrays[f"layer{i}_weight"], arrays[f"layer{i}_bias"] = weight, bias
        if spec.standardizer is not None:
            arrays["mean"], arrays["scale"] = spec.standardizer[0], spec.standardizer[1]
        meta = {"format": "panda_rapier.PolicyNetwork/1", "algorithm": self.algorithm,
                "source": self.source, "observation_dim": spec.observation_dim,
                "layers": len(spec.layers), "activation": spec.activation, "output": spec.output,
                "clip": None if spec.standardizer is None else spec.standardizer[2]}  # fmt: skip
        arrays["meta"] = np.array(json.dumps(meta))
        with open(path, "wb") as file:
            np.savez(file, **cast(Any, arrays))

    @classmethod
    def load(cls, path: str | Path) -> PolicyNetwork:
        """Reads what :meth:`save` wrote (arrays only: ``allow_pickle=False``)."""
        try:
            with np.load(path, allow_pickle=False) as archive:
                meta = json.loads(str(archive["meta"]))
                if meta.get("format") != "panda_rapier.PolicyNetwork/1":
                    raise InvalidArgumentError(f"{path}: not a saved PolicyNetwork")
                layers = [
                    (archive[f"layer{i}_weight"], archive[f"layer{i}_bias"])
                    for i in range(int(meta["layers"]))
                ]
                standardizer = None
                if meta["clip"] is not None:
                    standardizer = (archive["mean"], archive["scale"], float(meta["clip"]))
                spec = NetworkSpec(int(meta["observation_dim"]), layers, str(meta["activation"]),
                                   str(meta["output"]), archive["low"], archive["high"],
                                   standardizer)  # fmt: skip
        except (OSError, KeyError, ValueError) as error:
            raise InvalidArgumentError(
                f"cannot read a PolicyNetwork from {path}: {error}"
            ) from error
        return cls(spec, str(meta["algorithm"]), str(meta["source"]))


def _options(family: str, kwargs: Mapping[str, Any], use_sde: Any) -> tuple[str, str | None, float]:
    """The activation, features extractor and standardisation clip of a policy's
    ``policy_kwargs`` (objects of a model in memory, or the printed values a saved file keeps
    in plain JSON); :class:`UnsupportedModelError` for options the network does not build."""
    unknown = set(kwargs) - _KNOWN_POLICY_KWARGS
    if unknown:
        raise UnsupportedModelError(f"policy_kwargs {sorted(unknown)}")
    if str(kwargs.get("squash_output", False)) == "True":
        raise UnsupportedModelError("squash_output")
    if family == "sac" and (str(use_sde) == "True" or str(kwargs.get("use_sde")) == "True"):
        raise UnsupportedModelError("gSDE exploration (use_sde) in a SAC/TQC actor")
    activation = _activation_of(kwargs.get("activation_fn"), family)
    extractor = _class_name(kwargs.get("features_extractor_class"))
    return activation, extractor, _clip_of(kwargs.get("features_extractor_kwargs"))


def _class_name(value: Any) -> str | None:
    """``Foo`` of ``"<class 'a.b.Foo'>"``, of a class, or ``None``."""
    if value is None:
        return None
    if isinstance(value, type):
        return value.__name__
    match = re.fullmatch(r"<class '(?:[\w.]+\.)?(\w+)'>", str(value))
    if match is None:
        raise UnsupportedModelError(f"unreadable class {value!r}")
    return match.group(1)


def _activation_of(value: Any, family: str) -> str:
    name = _class_name(value)
    if name is None:
        return _DEFAULT_ACTIVATION[family]
    if name not in _ACTIVATIONS:
        raise UnsupportedModelError(f"activation {name} (only ReLU and Tanh)")
    return _ACTIVATIONS[name]


def _clip_of(value: Any) -> float:
    """The ``clip`` of ``features_extractor_kwargs`` (saved as its repr: read as a literal)."""
    if value is None:
        return CLIP
    try:
        kwargs = ast.literal_eval(str(value)) if not isinstance(value, Mapping) else value
    except (ValueError, SyntaxError) as error:
        raise UnsupportedModelError(f"unreadable features_extractor_kwargs {value!r}") from error
    if not isinstance(kwargs, Mapping) or set(kwargs) - {"clip"}:
        raise UnsupportedModelError(f"features_extractor_kwargs {value!r}")
    return float(kwargs.get("clip", CLIP))


def _bounds(space: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """An action ``Box``'s ``low`` and ``high``, from their printed arrays."""
    if "gymnasium.spaces.box.Box" not in str(space.get(":type:", "")):
        raise UnsupportedModelError("the action space is not a Box")
    try:
        bounds = [
            np.array(str(space[k]).strip("[]").split(), dtype=np.float32) for k in ("low", "high")
        ]
    except (KeyError, ValueError) as error:
        raise UnsupportedModelError(f"unreadable action bounds: {error}") from error
    return bounds[0], bounds[1]


def space_mismatch(
    data: Mapping[str, Any], observation_space: Any, action_space: Any
) -> str | None:
    """What differs between the spaces a model file's ``data`` (as :func:`read_model_file` reads
    it) records and the given ones, from the recorded text alone; ``None`` if nothing does."""
    saved = data.get("observation_space") or {}
    if isinstance(observation_space, spaces.Dict):
        if saved.get("spaces") != str(observation_space.spaces):
            return f"observation space {saved.get('spaces')} is not {observation_space.spaces}"
    elif list(saved.get("_shape") or []) != list(observation_space.shape or ()):
        return f"observation shape {saved.get('_shape')} is not {observation_space.shape}"
    try:
        low, high = _bounds(data.get("action_space") or {})
    except UnsupportedModelError as error:
        return str(error)
    if not (
        low.shape == action_space.shape
        and np.array_equal(low, action_space.low)
        and np.array_equal(high, action_space.high)
    ):
        return f"action space Box({low}, {high}) is not {action_space}"
    return None


def _linear_layers(state: Mapping[str, Any], prefix: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """The ``Linear`` layers of the ``nn.Sequential`` at ``prefix``, in order."""
    indices = sorted(
        int(m.group(1))
        for key in state
        if (m := re.fullmatch(re.escape(prefix) + r"\.(\d+)\.weight", key)) is not None
    )
    return [_linear(state, f"{prefix}.{i}") for i in indices]


def _linear(state: Mapping[str, Any], prefix: str) -> tuple[np.ndarray, np.ndarray]:
    try:
        weight, bias = state[f"{prefix}.weight"], state[f"{prefix}.bias"]
    except KeyError as error:
        raise UnsupportedModelError(f"no layer {prefix} in the weights") from error
    return _array(weight, 2), _array(bias, 1)


def _array(tensor: Any, ndim: int) -> np.ndarray:
    array = np.ascontiguousarray(tensor.numpy() if hasattr(tensor, "numpy") else tensor)
    if array.ndim != ndim or array.dtype != np.float32:
        raise UnsupportedModelError(f"a float32 tensor of {ndim} dimensions, got {array.dtype}")
    return array


def _build(
    state: Mapping[str, Any],
    family: str,
    activation: str,
    extractor: str | None,
    clip: float,
    low: np.ndarray,
    high: np.ndarray,
) -> NetworkSpec:
    extractors: tuple[str, ...]
    if family == "actor-critic":
        extractors = ("pi_features_extractor", "features_extractor")
        layers = [*_linear_layers(state, "mlp_extractor.policy_net"), _linear(state, "action_net")]
        output = "clip"
    elif family == "sac":
        extractors = ("actor.features_extractor",)
        layers = [*_linear_layers(state, "actor.latent_pi"), _linear(state, "actor.mu")]
        output = "squash"
    else:  # td3: mu ends with its output layer and a Tanh
        extractors = ("actor.features_extractor",)
        layers = _linear_layers(state, "actor.mu")
        output = "squash"
    if not layers:
        raise UnsupportedModelError("no layers found in the weights")
    standardizer = None
    features = "flat"
    if extractor in STANDARDISING_EXTRACTORS:
        prefix = next((p for p in extractors if f"{p}.mean" in state), None)
        if prefix is None:
            raise UnsupportedModelError(f"{extractor} without its mean and scale")
        mean, scale = (_array(state[f"{prefix}.{k}"], 1) for k in ("mean", "scale"))
        standardizer = (mean, scale, float(clip))
        features = STANDARDISING_EXTRACTORS[extractor]
    elif extractor not in (None, "CombinedExtractor", "FlattenExtractor"):
        raise UnsupportedModelError(f"features extractor {extractor}")
    observation_dim = int(layers[0][0].shape[1]) - _native.INPUT_FEATURES[features]
    return NetworkSpec(
        observation_dim, layers, activation, output, low, high, standardizer, features
    )


#: ``panda-rapier eval --inference`` choices.
INFERENCE_CHOICES = ("auto", "native", "torch")


def _control_mode_of(action_shape: Any) -> str:
    """The action mode a policy acts in, from its action shape (the native schema's action
    lengths: for the Panda 4 ``ee``, 7 ``ee_pose``, 8 ``joints``); ``ee`` for any other."""
    from ..policy import _control_by_action_dim

    shape = tuple(action_shape or ())
    return _control_by_action_dim().get(shape[0], "ee") if len(shape) == 1 else "ee"


def load_policy(
    path: str | Path,
    env_id: str,
    overrides: Mapping[str, Any],
    algo: str | None = None,
    inference: str = "auto",
    trust: bool = False,
) -> tuple[Any, dict[str, Any], dict[str, Any], str | None]:
    """The policy of a saved model as ``panda-rapier eval`` runs it: a :class:`PolicyNetwork`
    where the file allows (``inference="auto"`` or ``"native"``; ``"native"`` raises
    :class:`UnsupportedModelError` otherwise), else the stable-baselines3 model (``"torch"``,
    or the fallback). Loading with stable-baselines3 unpickles entries of the file, which can
    run code a hostile file carries: it needs ``trust=True`` (``--trust-model-file``), and
    raises :class:`UntrustedModelError` without it. Returns the policy, ``overrides`` with the
    control mode the model acts in (unless they set one), the image options of its
    observation and, for a fallback, why the native network could not be used."""
    if inference not in INFERENCE_CHOICES:
        raise InvalidArgumentError(
            f"inference must be one of {INFERENCE_CHOICES}, got {inference!r}"
        )
    overrides = dict(overrides)
    fallback = None
    run = read_run_info(path)
    if isinstance(run, Mapping) and isinstance(run.get("student"), Mapping):
        # A policy that sees (panda_rapier.learning.student): rebuilt and filled by data, in torch.
        if inference == "native":
            raise UnsupportedModelError(f"{path} is a student acting on images: torch only")
        try:
            from .student_model import load_student  # torch: only for a student
        except ImportError as error:
            raise ImportError(
                "evaluating a policy that sees needs torch and stable-baselines3: "
                "pip install 'panda-rapier[train]'"
            ) from error
        student = load_student(path)
        shape = getattr(student.policy.action_space, "shape", None)
        overrides.setdefault("control_mode", _control_mode_of(shape))
        return student, overrides, student.observation, None
    if inference != "torch":
        try:
            policy = PolicyNetwork.from_zip(path)
        except UnsupportedModelError as why:
            if inference == "native":
                raise
            fallback = str(why)
        else:
            overrides.setdefault("control_mode", _control_mode_of((policy.action_dim,)))
            return policy, overrides, {}, None
    if not trust:
        reason = f"the native network cannot act it out ({fallback}); " if fallback else ""
        raise UntrustedModelError(
            f"{path}: {reason}loading it with stable-baselines3 unpickles entries of the file, "
            "which can run code it carries; pass --trust-model-file (Python: trust=True) if "
            "you trust where it came from"
        )
    from ..sb3 import make_vec_env  # stable-baselines3: only for the torch inference

    observation_space, action_space = saved_spaces(path, trust=True)
    # The action mode the model acts in, from its action space.
    shape = getattr(action_space, "shape", None)
    overrides.setdefault("control_mode", _control_mode_of(shape))
    observation = model_observation(observation_space)
    # Loaded with an environment of the evaluation's spaces: a mismatch is reported by
    # stable-baselines3, and hindsight replay buffers need one.
    env = make_vec_env(env_id, n_envs=1, **overrides, **observation)
    model = load_sb3_model(path, env=env, algo=algo, trust=True)
    return model, overrides, observation, fallback


@dataclass
class EvaluatedPolicy:
    """What ``panda-rapier eval --policy SPEC`` evaluates: the policy, the environment
    configuration it acts in (id, recorded options, overrides), the image options of its
    observation, its label in reports and, for a model the native network could not act out,
    why (the model was loaded with stable-baselines3 instead)."""

    policy: Any
    env_id: str
    config: dict[str, Any]
    observation: dict[str, Any]
    label: str
    fallback: str | None = None


def resolve_policy(
    spec: str | Path,
    env_id: str | None = None,
    overrides: Mapping[str, Any] | None = None,
    algo: str | None = None,
    inference: str = "auto",
    trust: bool = False,
) -> EvaluatedPolicy:
    """The policy ``spec`` names, as ``panda-rapier eval --policy SPEC`` evaluates it:
    ``"scripted"`` (the task's expert), ``"random"`` (uniform actions, seeded by episode), a
    model file (:func:`load_policy`) or a LeRobot policy's directory
    (:class:`~panda_rapier.agents.lerobot_policy.LeRobotPolicy`; its environment is ``env_id``,
    else the id its training dataset was recorded on). A model runs in the environment
    recorded with it (its id and options; ``env_id`` replaces the id, and then the recorded
    options are dropped);
    ``overrides`` (options such as ``control_mode``, ``arm``, ``max_episode_steps``) apply last.
    """
    overrides = dict(overrides or {})
    if str(spec) in ("scripted", "random"):
        chosen = env_id or DEFAULT_ENV_ID
        config = env_config(chosen, **overrides)
        policy: Any = ScriptedPolicy(config) if spec == "scripted" else RandomPolicy(config)
        return EvaluatedPolicy(policy, chosen, config, {}, str(spec))
    path = Path(spec)
    if path.is_dir():
        return _resolve_lerobot_policy(path, env_id, overrides, inference, trust)
    if not path.is_file():
        raise InvalidArgumentError(
            f"--policy must be 'scripted', 'random', a model file or a LeRobot policy "
            f"directory; {path} does not exist"
        )
    run = read_run_info(path) or {}
    recorded_id = run.get("env_id") if run.get("env_id") in ENV_IDS else None
    options = run.get("env_kwargs")
    recorded: dict[str, Any] = dict(options) if isinstance(options, dict) else {}
    chosen = env_id or recorded_id or DEFAULT_ENV_ID
    overrides = {**(recorded if chosen == recorded_id else {}), **overrides}
    # The observation options (obs_mode, ...) come from the model itself (load_policy).
    overrides = split_options(overrides)[0]
    policy, overrides, observation, fallback = load_policy(
        path, chosen, overrides, algo, inference, trust
    )
    return EvaluatedPolicy(
        policy, chosen, env_config(chosen, **overrides), observation, str(path), fallback
    )


def _resolve_lerobot_policy(
    path: Path,
    env_id: str | None,
    overrides: Mapping[str, Any],
    inference: str,
    trust: bool,
) -> EvaluatedPolicy:
    """A LeRobot policy's directory as ``panda-rapier eval`` evaluates it."""
    from .lerobot_policy import LeRobotPolicy, is_lerobot_policy, lerobot_policy_env_id

    if not is_lerobot_policy(path):
        raise InvalidArgumentError(
            f"--policy {path} is a directory but not a LeRobot policy (config.json and "
            "model.safetensors, as lerobot-train saves them under checkpoints/*/pretrained_model)"
        )
    if inference == "native":
        raise UnsupportedModelError(f"{path} is a LeRobot policy: torch only (--inference)")
    chosen = env_id or lerobot_policy_env_id(path)
    if chosen is None:
        raise ConfigError(
            f"--env is needed for the LeRobot policy {path}: its training dataset (from "
            "train_config.json) is not a panda-rapier demos dataset at hand to read the id from"
        )
    config = env_config(chosen, **split_options(dict(overrides))[0])
    policy = LeRobotPolicy(path, config, trust=trust)
    return EvaluatedPolicy(policy, chosen, config, policy.observation, str(path))
