"""Stable-baselines3 model files read as data: nothing in them is unpickled or run.

A model file is a zip of a ``data`` entry (JSON whose pickled fields are left as unread
strings here) and torch entries (``policy.pth``, the optimizers' state, torch variables) in
torch's own zip serialisation. Those are read by an unpickler that resolves only the three
names a state dict uses (``collections.OrderedDict``, ``torch._utils._rebuild_tensor_v2`` and
torch's storage types) and rebuilds each tensor as a numpy array from the raw storage bytes,
so torch is not needed either. :mod:`panda_rapier.agents.inference` acts the policy out from it;
:mod:`panda_rapier.learning.checkpoint` and ``panda-rapier train --init-from`` restore models from
it.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import pickle
import zipfile
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .._deprecated import quiet_moved
from ..errors import ConfigError, InvalidArgumentError

__all__ = [
    "RUN_MEMBER",
    "UnsupportedModelError",
    "model_digest",
    "read_model_file",
    "read_run_info",
    "read_torch_entries",
]

#: Name of the run record ``panda-rapier train`` stores inside a saved model zip.
RUN_MEMBER = "panda_rapier_run.json"


class UnsupportedModelError(InvalidArgumentError):
    """A saved model that :class:`PolicyNetwork` cannot act out (it says why); stable-baselines3
    itself may still load it."""


def read_run_info(model_path: str | Path) -> dict[str, Any] | None:
    """The run record of a model saved by ``panda-rapier train``: the ``panda_rapier_run.json``
    inside the zip, else a ``run.json`` beside it; of a model directory (a LeRobot policy), the
    ``panda_rapier_run.json`` in it; ``None`` if there is none."""
    path = Path(model_path)
    if path.is_dir():
        try:
            return dict(json.loads((path / RUN_MEMBER).read_text()))
        except (OSError, ValueError, TypeError):
            return None
    try:
        with zipfile.ZipFile(path) as archive:
            return dict(json.loads(archive.read(RUN_MEMBER)))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        pass
    try:
        return dict(json.loads((path.parent / "run.json").read_text()))
    except (OSError, ValueError):
        return None


def model_digest(path: str | Path) -> str:
    """The SHA-256 that identifies a model: of the file's bytes, or for a model directory (a
    LeRobot policy) of the sorted list of its files' relative paths and SHA-256s."""
    path = Path(path)
    if not path.is_dir():
        return hashlib.sha256(path.read_bytes()).hexdigest()
    lines = [
        f"{file.relative_to(path).as_posix()} {hashlib.sha256(file.read_bytes()).hexdigest()}\n"
        for file in sorted(path.rglob("*"))
        if file.is_file()
    ]
    return hashlib.sha256("".join(lines).encode()).hexdigest()


def read_model_file(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """A stable-baselines3 model file read by data alone: the ``data`` entry's JSON (its
    pickled fields stay unread strings) and the policy's state dict as numpy arrays (through an
    unpickler that resolves only the names a state dict uses). Nothing in the file is run."""
    data, entries = _read(Path(path), lambda name: name == "policy.pth")
    if "policy" not in entries:
        raise InvalidArgumentError(f"{path} is not a stable-baselines3 model file: no policy.pth")
    return data, entries["policy"]


def read_torch_entries(path: str | Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """Every torch entry of a stable-baselines3 model file (``policy.pth``, the optimizers'
    ``*.optimizer.pth``, ``pytorch_variables.pth``), each read by data alone as
    :func:`read_model_file` reads the policy, keyed by its name without ``.pth``, with the
    ``data`` entry's JSON."""
    return _read(Path(path), lambda name: name.endswith(".pth"))


def _read(path: Path, wanted: Callable[[str], bool]) -> tuple[dict[str, Any], dict[str, Any]]:
    """The ``data`` JSON and the ``wanted`` torch entries of a model file, in one pass."""
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
            raw = {n: archive.read(n) for n in archive.namelist() if wanted(n)}
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as error:
        raise InvalidArgumentError(
            f"{path} is not a stable-baselines3 model file: {error}"
        ) from error
    if not isinstance(data, dict):
        raise InvalidArgumentError(f"{path} is not a stable-baselines3 model file: no data")
    return data, {name[: -len(".pth")]: _load_weights(content) for name, content in raw.items()}


def _load_weights(raw: bytes) -> dict[str, np.ndarray]:
    """The state dict of a ``policy.pth`` (torch's zip serialisation), read without torch:
    its pickle names only ``collections.OrderedDict``, ``torch._utils._rebuild_tensor_v2`` and
    torch's storage types, and an unpickler that resolves those three and nothing else (no
    other callable can be named, so nothing in the file can run) rebuilds each tensor as a
    numpy array from the archive's raw storage bytes."""
    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as archive:
            pickles = [n for n in archive.namelist() if n.endswith("/data.pkl")]
            if len(pickles) != 1:
                raise InvalidArgumentError("policy.pth is not torch's zip serialisation")
            prefix = pickles[0][: -len("data.pkl")]
            order: Literal["<", ">"] = "<"
            if f"{prefix}byteorder" in archive.namelist():
                order = ">" if archive.read(f"{prefix}byteorder").strip() == b"big" else "<"
            unpickler = _WeightsUnpickler(io.BytesIO(archive.read(pickles[0])), archive,
                                          prefix, order)  # fmt: skip
            state = unpickler.load()
    except (InvalidArgumentError, UnsupportedModelError):
        raise
    except Exception as error:  # a damaged pickle raises many unrelated types
        raise InvalidArgumentError(f"unreadable policy weights: {error}") from error
    if not isinstance(state, Mapping):
        raise InvalidArgumentError("policy.pth holds no state dict")
    return dict(state)


#: Far above any policy's layer; guards the reader against a file that claims a huge tensor.
_MAX_TENSOR_ELEMENTS = 1 << 28
#: The storage types of torch's serialisation that the weights reader accepts, as numpy dtypes.

_STORAGE_DTYPES = {
    "FloatStorage": "f4",
    "DoubleStorage": "f8",
    "HalfStorage": "f2",
    "LongStorage": "i8",
    "IntStorage": "i4",
    "ShortStorage": "i2",
    "CharStorage": "i1",
    "ByteStorage": "u1",
    "BoolStorage": "b1",
}


@dataclass(frozen=True)
class _StorageType:
    """A torch storage type named by the pickle (data, not callable)."""

    dtype: str


class _WeightsUnpickler(pickle.Unpickler):
    """Resolves the three names a state dict's pickle uses; any other name is refused."""

    def __init__(
        self, file: io.BytesIO, archive: zipfile.ZipFile, prefix: str, order: Literal["<", ">"]
    ) -> None:
        super().__init__(file)
        self._archive, self._prefix, self._order = archive, prefix, order

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) == ("collections", "OrderedDict"):
            return OrderedDict
        if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
            return _rebuild_tensor
        if module == "torch" and name in _STORAGE_DTYPES:
            return _StorageType(_STORAGE_DTYPES[name])
        raise UnsupportedModelError(
            f"policy.pth names {module}.{name}, which a file of weights does not"
        )

    def persistent_load(self, pid: Any) -> np.ndarray:
        if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage"):
            raise InvalidArgumentError(f"policy.pth: unknown persistent id {pid!r:.80}")
        _, storage_type, key, _location, count = pid
        if (
            not isinstance(storage_type, _StorageType)
            or storage_type.dtype not in _STORAGE_DTYPES.values()
            or not isinstance(key, str)
            or not isinstance(count, int)
        ):
            raise InvalidArgumentError("policy.pth: malformed storage reference")
        data = self._archive.read(f"{self._prefix}data/{key}")
        dtype = np.dtype(storage_type.dtype).newbyteorder(self._order)
        return np.frombuffer(data, dtype=dtype, count=count)


def _rebuild_tensor(storage: Any, offset: Any, size: Any, stride: Any, *_: Any) -> np.ndarray:
    """``torch._utils._rebuild_tensor_v2`` for a CPU tensor, as a numpy array gathered
    from the storage by index (bounds-checked; no view of raw memory is made)."""
    if not isinstance(storage, np.ndarray) or storage.ndim != 1 or storage.dtype.kind not in "fiub":
        raise InvalidArgumentError("policy.pth: malformed tensor storage")
    if not isinstance(offset, int):
        raise InvalidArgumentError("policy.pth: malformed tensor")
    if not (isinstance(size, tuple) and isinstance(stride, tuple) and len(size) == len(stride)):
        raise InvalidArgumentError("policy.pth: malformed tensor shape")
    if not all(isinstance(n, int) and n >= 0 for n in size + stride) or offset < 0:
        raise InvalidArgumentError("policy.pth: negative tensor shape")
    if math.prod(size) > _MAX_TENSOR_ELEMENTS:
        raise InvalidArgumentError("policy.pth: a tensor too large for a policy")
    extent = sum((n - 1) * s for n, s in zip(size, stride, strict=True))
    if math.prod(size) and offset + extent >= storage.size:
        raise InvalidArgumentError("policy.pth: a tensor reaches past its storage")
    index = np.full(size, offset, dtype=np.int64)
    for axis, (n, s) in enumerate(zip(size, stride, strict=True)):
        index += (np.arange(n, dtype=np.int64) * s).reshape((-1,) + (1,) * (len(size) - axis - 1))
    return storage[index].astype(storage.dtype.newbyteorder("="))


class UntrustedModelError(UnsupportedModelError):
    """Acting a model file out would unpickle (and so may run) code from it, and the caller
    did not say the file is trusted."""


def save_model(model: Any, path: Path, run: Mapping[str, Any]) -> None:
    """Saves a stable-baselines3 ``model`` to ``path`` with the run record inside the zip
    (:data:`RUN_MEMBER`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    model.save(path)
    with zipfile.ZipFile(path, "a") as archive:
        archive.writestr(RUN_MEMBER, json.dumps(run, indent=2, default=str))


#: stable-baselines3 / sb3-contrib algorithms ``load_sb3_model`` knows.
SB3_ALGORITHMS = ("a2c", "ddpg", "ppo", "sac", "td3", "tqc")


def _algorithm_of(path: Path) -> str | None:
    """The algorithm a stable-baselines3 zip was saved by, read from its policy class."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return None
    module = str(data.get("policy_class", {}).get("__module__", ""))
    parts = module.split(".")
    if len(parts) >= 2 and parts[1] in SB3_ALGORITHMS:  # sac, td3 (and ddpg), tqc
        return parts[1]
    if module == "stable_baselines3.common.policies":  # the actor-critic of PPO and A2C
        return "ppo" if "clip_range" in data else "a2c"
    return None


def load_sb3_model(
    path: str | Path, env: Any = None, algo: str | None = None, *, trust: bool = False
) -> Any:
    """Loads a saved stable-baselines3 (or sb3-contrib) model on the CPU. The algorithm is read
    from the file unless ``algo`` names it. A model saved with a hindsight replay buffer
    (``HerReplayBuffer``) needs a VecEnv with its spaces: without ``env``, one environment of the
    id and options its run record names (:func:`read_run_info`) is made for it; a file without
    a record raises :class:`~panda_rapier.errors.InvalidArgumentError`. stable-baselines3
    unpickles entries of the file, which can run code a hostile file carries: without
    ``trust=True`` this raises
    :class:`~panda_rapier.agents.inference.UntrustedModelError` (to act a model out without trusting
    it, use :class:`~panda_rapier.agents.inference.PolicyNetwork`)."""
    path = Path(path)
    _require_trust(path, trust)
    if not path.is_file():
        raise InvalidArgumentError(f"no model file at {path}")
    algo = (algo or _algorithm_of(path) or "").lower()
    if algo not in SB3_ALGORITHMS:
        raise InvalidArgumentError(
            f"cannot tell which algorithm saved {path}; pass one of {SB3_ALGORITHMS}"
        )
    try:
        algorithm: Any
        if algo == "tqc":
            from sb3_contrib import TQC

            algorithm = TQC
        else:
            import stable_baselines3

            algorithm = getattr(stable_baselines3, algo.upper())
    except ImportError as error:
        raise ImportError(
            f"evaluating a {algo.upper()} model needs stable-baselines3"
            f"{' and sb3-contrib' if algo == 'tqc' else ''}: pip install 'panda-rapier[train]'"
        ) from error
    if env is None:
        env = _her_env(path)
    with quiet_moved():  # zips saved before 0.2 name the old class paths in their data
        try:
            return algorithm.load(path, env=env, device="cpu")
        except AssertionError as error:  # stable-baselines3's check, as an assert
            if "HerReplayBuffer" not in str(error):
                raise
            raise InvalidArgumentError(
                f"{path} was saved with a hindsight replay buffer (HerReplayBuffer) and has no "
                "run record naming its environment: pass env=, a VecEnv with its spaces"
            ) from None


def _her_env(path: Path) -> Any:
    """One environment of the run record's id and options, for a model its record says was
    trained with ``HerReplayBuffer`` (stable-baselines3 needs one to load it); else ``None``."""
    run = read_run_info(path) or {}
    recipe = run.get("recipe")
    her = isinstance(recipe, Mapping) and "HerReplayBuffer" in str(
        recipe.get("replay_buffer_class", "")
    )
    if not her or not isinstance(run.get("env_id"), str):
        return None
    from ..sb3 import make_vec_env  # stable-baselines3: only for models that need an env

    return make_vec_env(run["env_id"], n_envs=1, **dict(run.get("env_kwargs") or {}))


def saved_spaces(model_path: str | Path, *, trust: bool = False) -> tuple[Any, Any]:
    """The observation and action spaces saved in a stable-baselines3 model file (``None``
    each where absent), read without building the model; they are pickled in the file, so
    this needs ``trust=True`` as :func:`load_sb3_model` does."""
    # stable-baselines3 only here and in load_sb3_model: the agents load without it.
    from stable_baselines3.common.save_util import load_from_zip_file

    _require_trust(Path(model_path), trust)
    with quiet_moved():  # as in load_sb3_model
        data, _, _ = load_from_zip_file(Path(model_path), load_data=True, device="cpu")
    data = data or {}
    return data.get("observation_space"), data.get("action_space")


def _require_trust(path: Path, trust: bool) -> None:
    if not trust:
        raise UntrustedModelError(
            f"{path}: loading it with stable-baselines3 unpickles entries of the file, which "
            "can run code it carries; pass trust=True (--trust-model-file) if you trust where "
            "it came from"
        )


def model_observation(space: Any) -> dict[str, Any]:
    """The observation options (``obs_mode``, ``image_size``) of a model trained on the
    observation ``space`` (as :func:`saved_spaces` reads it): none for state dicts,
    ``obs_mode="flat"`` for a float vector. Images under keys other than the default camera's
    ``rgb`` need their cameras, which only the Python API takes."""
    from gymnasium import spaces

    if isinstance(space, spaces.Box) and space.dtype == np.float32 and len(space.shape) == 1:
        return {"obs_mode": "flat"}
    if not isinstance(space, spaces.Dict):
        return {}
    images = {
        k: v for k, v in space.spaces.items() if isinstance(v, spaces.Box) and v.dtype == np.uint8
    }
    # Depth, segmentation and point clouds (their float32 entries included) are camera
    # entries too: only the default camera's colour alone is read off a space.
    state = ("achieved_goal", "desired_goal", "observation", "proprioception")
    cameras = sorted(set(images) | {k for k in space.spaces if k not in state})
    if not cameras:
        return {}
    if cameras != ["rgb"]:
        raise ConfigError(
            f"the model observes the cameras {cameras}: evaluate it from Python with "
            "panda_rapier.agents.evaluation.evaluate(..., obs_mode=..., cameras=...)"
        )
    shape = images["rgb"].shape
    assert shape is not None
    # Saved as SB3's VecTransposeImage passed it on: channels first.
    height, width = (shape[1], shape[2]) if shape[0] == 3 else (shape[0], shape[1])
    return {
        "obs_mode": (
            "state+rgb"
            if "observation" in space.spaces
            else "proprio+rgb"
            if "proprioception" in space.spaces
            else "rgb"
        ),
        "image_size": (int(height), int(width)),
    }
