"""Shared fixtures for the Python test suite."""

from __future__ import annotations

import numpy as np
import pytest

import panda_rapier  # noqa: F401  (registers the ids)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


def random_actions(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, size=shape).astype(np.float32)
