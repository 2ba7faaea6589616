"""Checkpoints of ``panda-rapier train`` (``OUT/checkpoints/``), resumed without running code
from them.

A checkpoint is ``latest.zip`` (stable-baselines3's model file), for off-policy algorithms
``replay_buffer.pkl``, and ``state.json`` (where the run stood). stable-baselines3's own
``load`` unpickles entries of the zip, so a run folder someone else hands over could run code
on ``--resume``. :func:`restore` does not: the model is rebuilt from the run's recorded recipe
(by ``panda-rapier train``), then every torch state dict of the zip (the policy, its
optimizers) and its torch variables are read by data alone
(:func:`panda_rapier.agents.model_file.read_torch_entries`), and the step counters from the plain
fields of its ``data`` entry; the zip's pickled entries (schedules, which come from the recipe;
the last observation and episode statistics, which the fresh environments replace) are never
read.

The replay buffer has no data-only format in stable-baselines3 (its hindsight buffer keeps the
episodes' info dicts), so it stays a pickle, and :func:`save` signs it: an HMAC-SHA256 with a
key kept in the user's cache directory (``$XDG_CACHE_HOME/panda_rapier/checkpoint.key``,
created on first use, readable by the user alone), recorded in ``state.json``. A buffer this
user's runs wrote loads as before; any other (another machine's, or a changed file) needs
``trust=True`` (``panda-rapier train --resume --trust-model-file``) and raises
:class:`~panda_rapier.agents.inference.UntrustedModelError` without it.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import secrets
import warnings
from operator import attrgetter
from pathlib import Path
from typing import Any

import numpy as np
import torch as th

from ..agents.inference import UntrustedModelError
from ..agents.model_file import read_torch_entries, save_model
from ..errors import InvalidArgumentError

__all__ = ["MODEL", "REPLAY_BUFFER", "STATE", "restore", "save", "signing_key"]

#: The files of a checkpoint folder.
MODEL = "latest.zip"
REPLAY_BUFFER = "replay_buffer.pkl"
STATE = "state.json"


def signing_key() -> bytes:
    """This user's checkpoint signing key (32 random bytes, made on first use)."""
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "panda_rapier"
    path = cache / "checkpoint.key"
    try:
        return bytes.fromhex(path.read_text().strip())
    except (OSError, ValueError):
        pass
    cache.mkdir(parents=True, exist_ok=True)
    key = secrets.token_bytes(32)
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "w") as file:
        file.write(key.hex())
    return key


def _signature(path: Path) -> str:
    digest = hmac.new(signing_key(), digestmod=hashlib.sha256)
    with path.open("rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def save(model: Any, folder: Path, state: dict[str, Any], run: dict[str, Any]) -> None:
    """Writes ``model`` (with the run record inside the zip), its replay buffer (signed) and
    ``state`` to ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    save_model(model, folder / MODEL, run)
    state = dict(state)
    state.pop("replay_buffer_hmac", None)
    if hasattr(model, "save_replay_buffer"):
        model.save_replay_buffer(folder / REPLAY_BUFFER)
        state["replay_buffer_hmac"] = _signature(folder / REPLAY_BUFFER)
    (folder / STATE).write_text(json.dumps(state))


def _tensors(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return th.as_tensor(np.array(value))
    if isinstance(value, dict):
        return {k: _tensors(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return type(value)(_tensors(v) for v in value)
    return value


def restore(model: Any, folder: Path, trust: bool = False) -> dict[str, Any]:
    """Restores the checkpoint in ``folder`` into ``model`` (built from the run's recipe, on the
    run's environment) as the module docstring says; returns ``state.json``'s content. A
    checkpoint that does not fit the model is an :class:`InvalidArgumentError`."""
    state = json.loads((folder / STATE).read_text())
    data, entries = read_torch_entries(folder / MODEL)
    names, variables = model._get_torch_save_params()
    try:
        for name in names:
            if name not in entries:
                raise InvalidArgumentError(f"{folder / MODEL} holds no {name} state")
            attrgetter(name)(model).load_state_dict(_tensors(entries[name]))
        saved = entries.get("pytorch_variables") or {}
        for name in variables:
            if name in saved:
                attrgetter(name)(model).data.copy_(_tensors(saved[name]))
    except (RuntimeError, KeyError, ValueError, TypeError) as error:
        raise InvalidArgumentError(
            f"{folder / MODEL} does not fit the run's recipe: {error}"
        ) from error
    for key in ("num_timesteps", "_n_updates", "_episode_num"):
        if isinstance(data.get(key), int):
            setattr(model, key, data[key])
    buffer = folder / REPLAY_BUFFER
    if hasattr(model, "load_replay_buffer") and buffer.is_file():
        recorded = str(state.get("replay_buffer_hmac", ""))
        if not trust and not hmac.compare_digest(recorded, _signature(buffer)):
            raise UntrustedModelError(
                f"{buffer} was not written by this user's runs on this machine (or changed "
                "since): loading it unpickles it, which can run code it carries; pass "
                "--trust-model-file (Python: trust=True) if you trust where it came from"
            )
        # The environments restart with fresh episodes on resume, so the episode that was
        # running at the checkpoint is truncated: what HER's warning recommends here.
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "The last trajectory in the replay buffer")
            model.load_replay_buffer(buffer, truncate_last_traj=True)
    return state
