"""CubeOrientationFeatures: Flip's goal quaternions as the rotation to the goal and the cube's
pose up to its symmetry, the same numbers in torch and in the native network, refused where
the goals are not orientations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th
from stable_baselines3 import PPO

from panda_rapier import ConfigError, InvalidArgumentError, _native
from panda_rapier.agents.inference import PolicyNetwork
from panda_rapier.learning.imitation import collect
from panda_rapier.learning.normalization import (
    CubeOrientationFeatures,
    NormalizedFlatten,
    fit_normalizers,
)
from panda_rapier.learning.recipes import evaluate_expression
from panda_rapier.registration import env_config
from panda_rapier.sb3 import make_vec_env

th.set_num_threads(1)

FLIP = "panda_rapier/Flip-v0"


def _multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products of x, y, z, w quaternions, row by row."""
    ax, ay, az, aw = a.T
    bx, by, bz, bw = b.T
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=1)  # fmt: skip


def _canonical(q: np.ndarray) -> np.ndarray:
    """The observation's sign: w >= 0."""
    return np.where(q[:, 3:4] < 0, -q, q)


def _flip_rows() -> np.ndarray:
    demos, _ = collect(env_config(FLIP), 2, first_seed=11)
    return demos.observations


def test_the_features_are_the_same_for_every_labelling_of_the_cube() -> None:
    rows = _flip_rows()[::25].astype(np.float32)
    features = _native.input_features("cube_orientation", rows)
    assert features.shape == (len(rows), rows.shape[1] + 16)
    assert _native.INPUT_FEATURES == {"cube_orientation": 16, "flat": 0}
    # The rest of the row follows the 24 features unchanged.
    np.testing.assert_array_equal(features[:, 24:], rows[:, 8:])
    # A quarter turn about the cube's own x axis, and a third about its diagonal: symmetries
    # of the cube, applied to the cube and the goal alike.
    h = np.sqrt(0.5)
    for s in ([h, 0, 0, h], [0.5, 0.5, 0.5, 0.5]):
        turned = rows.copy()
        for goal in (slice(0, 4), slice(4, 8)):
            turned[:, goal] = _canonical(_multiply(rows[:, goal], np.tile(s, (len(rows), 1))))
        assert np.abs(turned[:, :8] - rows[:, :8]).max() > 0.5
        again = _native.input_features("cube_orientation", turned)
        np.testing.assert_allclose(again, features, atol=2e-6)
    # The flat features are the rows themselves.
    np.testing.assert_array_equal(_native.input_features("flat", rows), rows)


def test_bad_rows_and_names_are_refused_by_name() -> None:
    rows = np.zeros((2, 49), np.float32)
    rows[:, 3] = rows[:, 7] = 1
    with pytest.raises(ConfigError, match="cube_orientation"):
        _native.input_features("quaternion", rows)
    with pytest.raises(InvalidArgumentError, match="at least 9 columns"):
        _native.input_features("cube_orientation", rows[:, :8])
    rows[1, 20] = np.nan
    with pytest.raises(InvalidArgumentError, match="finite"):
        _native.input_features("cube_orientation", rows)


def _flip_model() -> PPO:
    kwargs = evaluate_expression(
        "dict(features_extractor_class=CubeOrientationFeatures, net_arch=[32, 32])"
    )
    assert kwargs["features_extractor_class"] is CubeOrientationFeatures
    model = PPO("MultiInputPolicy", make_vec_env(FLIP), policy_kwargs=kwargs, seed=0,
                device="cpu")  # fmt: skip
    extractor = model.policy.features_extractor
    assert isinstance(extractor, CubeOrientationFeatures) and extractor.features_dim == 65
    fit_normalizers(model.policy, _flip_rows())
    return model


def test_the_native_network_acts_as_the_torch_policy(tmp_path: Path) -> None:
    model = _flip_model()
    rows = _flip_rows()
    obs = {"achieved_goal": rows[:, :4], "desired_goal": rows[:, 4:8], "observation": rows[:, 8:]}
    torch_actions, _ = model.predict(obs, deterministic=True)
    for native in (PolicyNetwork.from_sb3(model), None):
        if native is None:
            model.save(tmp_path / "flip.zip")
            native = PolicyNetwork.from_zip(tmp_path / "flip.zip")
        assert native.spec.features == "cube_orientation"
        assert native.observation_dim == 49
        np.testing.assert_allclose(native.act(rows), torch_actions, atol=1e-4)
    # The features differ from the flat standardisation's: not a NormalizedFlatten in disguise.
    flat = NormalizedFlatten(model.observation_space)
    assert flat.features_dim == 49


def test_goals_that_are_positions_are_refused() -> None:
    shape = r"orientation quaternions.*'achieved_goal' has shape \(3,\)"
    with pytest.raises(TypeError, match=shape):
        CubeOrientationFeatures(make_vec_env("panda_rapier/Push-v0").observation_space)
