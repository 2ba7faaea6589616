"""panda_rapier.ScriptedPolicy: SB3-style predict on single and batched observations."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import panda_rapier
from panda_rapier import InvalidArgumentError, ScriptedPolicy

PHASES = {"approach", "descend", "close", "lift", "carry", "lower", "release", "retreat", "hold"}


def stack(observations: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    return {key: np.stack([o[key] for o in observations]) for key in observations[0]}


@pytest.mark.parametrize(
    ("env_id", "action_dim"),
    [("panda_rapier/PickAndPlace-v0", 4), ("panda_rapier/PickAndPlaceJointsDense-v0", 8)],
)
def test_single_and_batched_predictions_agree(env_id: str, action_dim: int) -> None:
    env = gym.make(env_id)
    policy = ScriptedPolicy(env)
    observations = []
    for seed in range(5):
        obs, _ = env.reset(seed=seed)
        for _ in range(seed * 7):  # different phases
            obs, *_ = env.step(policy.predict(obs)[0])
        observations.append(obs)
    singles = [policy.predict(obs, deterministic=True) for obs in observations]
    for action, state in singles:
        assert action.shape == (action_dim,) and action.dtype == np.float32
        assert state is None
        assert env.action_space.contains(action)
    batch, state = policy.predict(stack(observations))
    assert state is None and batch.shape == (5, action_dim) and batch.dtype == np.float32
    np.testing.assert_array_equal(batch, np.stack([a for a, _ in singles]))
    flat = np.stack([np.concatenate([o["achieved_goal"], o["desired_goal"], o["observation"]])
                     for o in observations])  # fmt: skip
    np.testing.assert_array_equal(policy.predict(flat)[0], batch)
    np.testing.assert_array_equal(policy.predict(stack(observations), deterministic=False)[0],
                                  batch)  # fmt: skip
    np.testing.assert_array_equal(policy(observations[0]), singles[0][0])
    phases = policy.phases(stack(observations))
    assert len(phases) == 5 and set(phases) <= PHASES
    assert phases[0] == "approach"


@pytest.mark.parametrize("env_id", ["panda_rapier/PickAndPlace-v0",
                                    "panda_rapier/PickAndPlaceJoints-v0"])  # fmt: skip
def test_places_the_cube_from_a_vector_env(env_id: str) -> None:
    envs = gym.make_vec(env_id, num_envs=10, vectorization_mode="vector_entry_point")
    policy = ScriptedPolicy(envs)
    obs, _ = envs.reset(seed=100)
    placed = np.zeros(10, dtype=bool)
    for _ in range(panda_rapier.MAX_EPISODE_STEPS):
        actions, _ = policy.predict(obs)
        obs, _, _, _, infos = envs.step(actions)
        placed |= infos["is_placed"]
    assert placed.sum() >= 9, placed
    envs.close()


def test_sources_of_the_configuration() -> None:
    pytest.importorskip("stable_baselines3")
    from panda_rapier.sb3 import make_vec_env

    joints = "panda_rapier/PickAndPlaceJoints-v0"
    for source in (
        joints,
        gym.make(joints),
        gym.make(joints).unwrapped,
        make_vec_env(joints, n_envs=2),
        spaces.Box(-1, 1, (8,), np.float32),
        {"control_mode": "joints"},
    ):
        policy = ScriptedPolicy(source)
        assert policy.action_space.shape == (8,), source
    assert ScriptedPolicy().action_space.shape == (4,)
    assert ScriptedPolicy(joints, control_mode="ee").action_space.shape == (4,)


def test_bad_inputs_raise_typed_errors() -> None:
    policy = ScriptedPolicy()
    obs, _ = gym.make("panda_rapier/PickAndPlace-v0").reset(seed=0)
    with pytest.raises(InvalidArgumentError, match="action space"):
        ScriptedPolicy(spaces.Box(-1, 1, (5,), np.float32))
    with pytest.raises(InvalidArgumentError):
        ScriptedPolicy(object())
    with pytest.raises(panda_rapier.ConfigError):
        ScriptedPolicy(control_mode="teleport")
    with pytest.raises(InvalidArgumentError, match="lacks"):
        policy.predict({"observation": obs["observation"]})
    with pytest.raises(InvalidArgumentError, match="entries per environment"):
        policy.predict(np.zeros((2, 5), dtype=np.float32))
    with pytest.raises(InvalidArgumentError, match="entries per environment"):
        policy.predict(np.zeros((2, 3, 40), dtype=np.float32))
    broken = dict(obs)
    broken["achieved_goal"] = np.array([np.nan, 0, 0], dtype=np.float32)
    with pytest.raises(InvalidArgumentError, match=r"finite|NaN"):
        policy.predict(broken)
    with pytest.raises(InvalidArgumentError):
        policy.predict("not an observation")
