"""Shared fixtures for the Python test suite."""

from __future__ import annotations

import base64
import json
import pickle
import zipfile
from pathlib import Path

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
