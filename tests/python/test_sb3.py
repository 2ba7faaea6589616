"""The stable-baselines3 VecEnv: checkers, conventions, HER, seeding, real training runs."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import gymnasium as gym
from stable_baselines3 import PPO, SAC, HerReplayBuffer
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.vec_env import SubprocVecEnv, VecEnv

import panda_rapier
from panda_rapier.sb3 import PandaVecEnv, make_vec_env


@pytest.mark.parametrize("env_id", panda_rapier.ENV_IDS)
def test_sb3_check_env(env_id: str) -> None:
    # Gymnasium 1.x wrappers do not forward attributes, so the checker gets the env itself.
    check_env(gym.make(env_id).unwrapped, warn=True)


def test_make_vec_env_conventions() -> None:
    venv = make_vec_env("panda_rapier/PickAndPlace-v0", n_envs=3, seed=0, max_episode_steps=4)
    assert isinstance(venv, VecEnv) and isinstance(venv, PandaVecEnv)
    assert venv.get_attr("dt") == [pytest.approx(0.04)] * 3
    assert venv.get_attr("render_mode", indices=[1]) == [None]
    venv.set_attr("tag", "x", indices=0)
    assert venv.get_attr("tag", indices=[0]) == ["x"]
    assert venv.env_is_wrapped(gym.Wrapper) == [False, False, False]
    obs = venv.reset()
    assert obs["observation"].shape == (3, 41)
    zeros = np.zeros((3, 4), np.float32)
    for _ in range(3):
        _, _, dones, infos = venv.step(zeros)
        assert not dones.any() and "terminal_observation" not in infos[0]
    obs, _rewards, dones, infos = venv.step(zeros)
    assert dones.all()
    for info in infos:
        assert info["TimeLimit.truncated"] is True
        assert info["episode"]["l"] == 4
        assert set(info["terminal_observation"]) == {"achieved_goal", "desired_goal", "observation"}
        assert isinstance(info["is_success"], bool)
    # The observation returned is the new episode's first one.
    assert venv.reset_infos[0]["elapsed_steps"] == 0
    assert not np.array_equal(
        infos[0]["terminal_observation"]["observation"], obs["observation"][0]
    )
    venv.close()
    with pytest.raises(panda_rapier.ResetNeededError, match="closed"):
        venv.step(zeros)


def test_env_method_compute_reward_is_batched() -> None:
    venv = make_vec_env("panda_rapier/PickAndPlaceDense-v0", n_envs=2, seed=1)
    venv.reset()
    achieved, desired, infos, rewards = [], [], [], []
    for _ in range(10):
        obs, reward, _, info = venv.step(
            np.random.default_rng(0).uniform(-1, 1, (2, 4)).astype(np.float32)
        )
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        infos.extend(info)
        rewards.append(reward)
    batch = venv.env_method(
        "compute_reward",
        np.concatenate(achieved),
        np.concatenate(desired),
        np.array(infos),
        indices=[0],
    )[0]
    np.testing.assert_array_equal(batch, np.concatenate(rewards))


def test_seeded_vec_env_gives_the_same_rollouts_twice() -> None:
    traces = []
    for _ in range(2):
        venv = make_vec_env(
            "panda_rapier/PickAndPlaceJoints-v0", n_envs=2, seed=123, max_episode_steps=5
        )
        rng = np.random.default_rng(9)
        trace = [venv.reset()["observation"]]
        for _ in range(12):
            obs, _rewards, _dones, _infos = venv.step(rng.uniform(-1, 1, (2, 8)).astype(np.float32))
            trace.append(obs["observation"])
        traces.append(trace)
    for a, b in zip(*traces, strict=True):
        np.testing.assert_array_equal(a, b)


def test_ppo_trains_on_the_native_vec_env() -> None:
    venv = make_vec_env("panda_rapier/PickAndPlaceDense-v0", n_envs=4, seed=0)
    model = PPO(
        "MultiInputPolicy", venv, n_steps=512, batch_size=256, n_epochs=2, seed=0, device="cpu"
    )
    model.learn(total_timesteps=2048)
    assert model.num_timesteps >= 2048
    assert len(model.ep_info_buffer) == 4 * (2048 // 4 // panda_rapier.MAX_EPISODE_STEPS)
    actions, _ = model.predict(venv.reset(), deterministic=True)
    assert actions.shape == (4, 4)


@pytest.mark.parametrize("vectorised", [False, True])
def test_sac_with_her_trains_on_the_goal_env(vectorised: bool) -> None:
    if vectorised:
        env = make_vec_env("panda_rapier/PickAndPlaceDense-v0", n_envs=2, seed=0)
    else:
        env = gym.make("panda_rapier/PickAndPlace-v0")
    model = SAC(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        # The dense reward reads the step infos, which the buffer keeps only when asked to.
        replay_buffer_kwargs={
            "n_sampled_goal": 4,
            "goal_selection_strategy": "future",
            "copy_info_dict": vectorised,
        },
        learning_starts=200,
        batch_size=64,
        policy_kwargs={"net_arch": [64, 64]},
        seed=0,
        device="cpu",
    )
    model.learn(total_timesteps=1000)
    assert model.num_timesteps >= 1000
    assert model.replay_buffer.size() > 0


@pytest.mark.parametrize("start_method", ["fork", "spawn"])
def test_subproc_vec_env_over_gym_make(start_method: str) -> None:
    # A spawned worker starts a fresh interpreter: "module:id" makes gym.make import
    # panda_rapier (which registers the ids) there.
    venv = SubprocVecEnv(
        [lambda: gym.make("panda_rapier:panda_rapier/PickAndPlace-v0")] * 2,
        start_method=start_method,
    )
    venv.seed(3)
    obs = venv.reset()
    assert obs["observation"].shape == (2, 41)
    for _ in range(3):
        obs, rewards, _dones, _infos = venv.step(np.zeros((2, 4), np.float32))
    assert rewards.shape == (2,)
    venv.close()
