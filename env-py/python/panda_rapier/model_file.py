"""Stable-baselines3 model files read as data: nothing in them is unpickled or run.

A model file is a zip of a ``data`` entry (JSON whose pickled fields are left as unread
strings here) and torch entries (``policy.pth``, the optimizers' state, torch variables) in
torch's own zip serialisation. Those are read by an unpickler that resolves only the three
names a state dict uses (``collections.OrderedDict``, ``torch._utils._rebuild_tensor_v2`` and
torch's storage types) and rebuilds each tensor as a numpy array from the raw storage bytes,
so torch is not needed either. :mod:`panda_rapier.inference` acts the policy out from it;
:mod:`panda_rapier.checkpoint` and ``panda-rapier train --init-from`` restore models from it.
"""

from __future__ import annotations

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

from .errors import InvalidArgumentError

__all__ = [
    "RUN_MEMBER",
    "UnsupportedModelError",
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
    inside the zip, else a ``run.json`` beside it; ``None`` if there is neither."""
    path = Path(model_path)
    try:
        with zipfile.ZipFile(path) as archive:
            return dict(json.loads(archive.read(RUN_MEMBER)))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        pass
    try:
        return dict(json.loads((path.parent / "run.json").read_text()))
    except (OSError, ValueError):
        return None


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
