"""The native Gymnasium vector environment: shapes, autoreset modes, seeding, threads, fork."""

from __future__ import annotations

import multiprocessing

import gymnasium as gym
import numpy as np
import pytest
from conftest import random_actions
from gymnasium.vector import AutoresetMode

import panda_rapier
from panda_rapier import PandaVectorEnv

ID = "panda_rapier/PickAndPlace-v0"


def test_make_vec_returns_the_native_vector_env() -> None:
    envs = gym.make_vec(ID, num_envs=3, vectorization_mode="vector_entry_point", num_threads=2)
    assert isinstance(envs, PandaVectorEnv)
    assert envs.num_threads == 2
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.observation_space["observation"].shape == (3, 41)
    assert envs.action_space.shape == (3, 4)
    obs, info = envs.reset(seed=0)
    assert envs.observation_space.contains(obs)
    assert info["is_success"].shape == (3,) and info["_is_success"].all()
    obs, rewards, terminated, truncated, info = envs.step(envs.action_space.sample())
    assert rewards.shape == (3,) and rewards.dtype == np.float64
    assert terminated.dtype == np.bool_ and truncated.shape == (3,)
    assert info["goal_distance"].dtype == np.float64
    envs.close()


def test_env_i_matches_a_single_env_and_thread_count_does_not_matter(
    rng: np.random.Generator,
) -> None:
    actions = [random_actions(rng, (4, 4)) for _ in range(30)]
    traces = []
    for threads in (1, 2):
        envs = PandaVectorEnv(4, num_threads=threads)
        obs, _ = envs.reset(seed=21)
        trace = [obs["observation"].copy()]
        for a in actions:
            trace.append(envs.step(a)[0]["observation"].copy())
        traces.append(trace)
    for a, b in zip(*traces, strict=True):
        np.testing.assert_array_equal(a, b)
    single = panda_rapier.PandaEnv()
    obs, _ = single.reset(seed=21)
    np.testing.assert_array_equal(obs["observation"], traces[0][0][0])
    for t, a in enumerate(actions):
        np.testing.assert_array_equal(single.step(a[0])[0]["observation"], traces[0][t + 1][0])


def test_next_step_autoreset() -> None:
    envs = PandaVectorEnv(2, max_episode_steps=3)
    envs.reset(seed=0)
    zeros = np.zeros((2, 4), np.float32)
    for _ in range(2):
        assert not envs.step(zeros)[3].any()
    _, _, _, truncated, info = envs.step(zeros)
    assert truncated.all() and info["elapsed_steps"].tolist() == [3, 3]
    _obs, rewards, _terminated, truncated, info = envs.step(zeros)
    assert rewards.tolist() == [0.0, 0.0] and not truncated.any()
    assert info["elapsed_steps"].tolist() == [0, 0]


def test_same_step_autoreset_reports_final_obs_and_info() -> None:
    envs = PandaVectorEnv(2, max_episode_steps=3, autoreset_mode="same_step")
    assert envs.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    reference = panda_rapier.PandaEnv(max_episode_steps=3)
    envs.reset(seed=4)
    reference.reset(seed=4)
    zeros = np.zeros((2, 4), np.float32)
    for _ in range(2):
        envs.step(zeros)
        reference.step(zeros[0])
    obs, _, _, truncated, info = envs.step(zeros)
    last, *_ = reference.step(zeros[0])
    assert truncated.all() and info["_final_obs"].all()
    np.testing.assert_array_equal(info["final_obs"][0]["observation"], last["observation"])
    assert info["final_info"]["elapsed_steps"].tolist() == [3, 3]
    assert info["elapsed_steps"].tolist() == [0, 0]
    assert not np.array_equal(obs["observation"][0], last["observation"])


def test_disabled_autoreset_needs_a_masked_reset() -> None:
    envs = PandaVectorEnv(2, max_episode_steps=1, autoreset_mode="disabled")
    envs.reset(seed=0)
    zeros = np.zeros((2, 4), np.float32)
    assert envs.step(zeros)[3].all()
    with pytest.raises(panda_rapier.ResetNeededError, match="autoreset is disabled"):
        envs.step(zeros)
    envs.reset(options={"reset_mask": np.array([True, True])})
    envs.step(zeros)


def test_per_env_seeds_and_bad_seeds() -> None:
    envs = PandaVectorEnv(2)
    a, _ = envs.reset(seed=[5, 6])
    b, _ = envs.reset(seed=[5, 6])
    np.testing.assert_array_equal(a["observation"], b["observation"])
    with pytest.raises(panda_rapier.InvalidArgumentError):
        envs.reset(seed=[1, 2, 3])
    with pytest.raises(panda_rapier.InvalidArgumentError):
        envs.reset(seed=-1)


def _step_in_child(envs: PandaVectorEnv, actions: np.ndarray, queue: multiprocessing.Queue) -> None:
    queue.put(envs.step(actions)[0]["observation"])


def test_vector_env_survives_fork() -> None:
    envs = PandaVectorEnv(4, num_threads=2)
    envs.reset(seed=2)
    actions = np.full((4, 4), 0.5, np.float32)
    envs.step(actions)  # the pool's threads exist now; a fork copies none of them
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_step_in_child, args=(envs, actions, queue))
    child.start()
    from_child = queue.get(timeout=60)
    child.join(timeout=60)
    assert child.exitcode == 0
    np.testing.assert_array_equal(from_child, envs.step(actions)[0]["observation"])
