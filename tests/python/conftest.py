"""Shared fixtures for the Python test suite."""

from __future__ import annotations

import base64
import json
import pickle
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import panda_rapier  # noqa: F401  (registers the ids)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


def random_actions(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, size=shape).astype(np.float32)


class WritesAFile:
    """Pickles to a call that creates a file: what a hostile model file would hold."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


def hostile_payload(marker: Path) -> str:
    """A base64 pickle that creates ``marker`` when unpickled (as SB3 stores pickled fields)."""
    return base64.b64encode(pickle.dumps(WritesAFile(marker))).decode()


def poisoned(source: Path, hostile: Path, payload: str) -> Path:
    """The model file ``source`` with every pickled data entry replaced by ``payload``, written
    to ``hostile`` (which may be ``source`` itself)."""
    with zipfile.ZipFile(source) as archive:
        entries = [(item, archive.read(item)) for item in archive.infolist()]
    with zipfile.ZipFile(hostile, "w") as out:
        for item, raw in entries:
            if item.filename == "data":
                data = json.loads(raw)
                for value in data.values():
                    if isinstance(value, dict) and ":serialized:" in value:
                        value[":serialized:"] = payload
                raw = json.dumps(data).encode()
            out.writestr(item, raw)
    return hostile


#: The id the bc recipe files of :func:`bc_recipe` list.
BC_RECIPE_ID = "panda_rapier/Slide-v0"


@pytest.fixture
def bc_recipe(tmp_path: Path) -> Callable[[dict[str, Any]], Path]:
    """Writes a bc recipe file whose only entry, ``BC_RECIPE_ID``'s, is the given mapping, and
    returns its path."""
    yaml = pytest.importorskip("yaml")

    def write(entry: dict[str, Any]) -> Path:
        path = tmp_path / "bc.yml"
        path.write_text(yaml.safe_dump({BC_RECIPE_ID: entry}))
        return path

    return write


@pytest.fixture
def dagger_arguments(
    bc_recipe: Callable[[dict[str, Any]], Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> Callable[[dict[str, Any]], dict[str, Any]]:
    """The keyword arguments ``panda-rapier train --algo bc`` (``train_bc``) hands ``dagger``
    for a recipe entry (loaded and checked as ``load_recipe`` does), without training."""
    pytest.importorskip("stable_baselines3")
    from panda_rapier.learning import imitation
    from panda_rapier.learning.recipes import load_recipe
    from panda_rapier.registration import env_config

    seen: dict[str, Any] = {}

    class Stop(Exception):
        pass

    def dagger(model: Any, config: Any, **kwargs: Any) -> None:
        seen.update(kwargs)
        raise Stop

    monkeypatch.setattr(imitation, "dagger", dagger)

    def arguments(entry: dict[str, Any]) -> dict[str, Any]:
        recipe = load_recipe("bc", BC_RECIPE_ID, bc_recipe(entry))
        run = {"env_id": BC_RECIPE_ID, "env_kwargs": {}, "seed": 0, "train_first_seed": 0}
        seen.clear()
        with pytest.raises(Stop):
            imitation.train_bc(
                run, recipe, env_config(BC_RECIPE_ID), tmp_path / "out", 2, 1, 0,
                lambda _: None, show_progress=False,
            )  # fmt: skip
        return dict(seen)

    return arguments


def tiny_bc_model(env_id: str) -> Any:
    """A PPO ``MultiInputPolicy`` with one 8-unit layer on ``env_id``: a learner for tests of
    DAgger's bookkeeping, whose fits are replaced or too short to matter."""
    from stable_baselines3 import PPO

    from panda_rapier.learning.normalization import NormalizedFlatten
    from panda_rapier.sb3 import make_vec_env

    kwargs = {"features_extractor_class": NormalizedFlatten, "net_arch": [8]}
    return PPO("MultiInputPolicy", make_vec_env(env_id), policy_kwargs=kwargs, seed=0, device="cpu")
