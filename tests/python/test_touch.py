"""Touch (issue 60): the robot API's finger forces and wrist force-torque reading weigh a
held cube and the free hand; the ``+touch`` observation entry holds the same values in its
documented layout, identically in the single env, the native vector env (any threads and
batch) and the SB3 VecEnv; default observations are unchanged; bad modes are typed errors.
The seeds (7401 to 7409) are this file's alone."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import panda_rapier
from panda_rapier import PandaVectorEnv
from panda_rapier.errors import ConfigError
from panda_rapier.pixels import TOUCH_KEY, TOUCH_LAYOUT
from panda_rapier.registration import env_config

ENV_ID = "panda_rapier/PickAndPlace-v0"
G = 9.81
CUBE_MASS = 0.1  # the default task.cube.mass (kg)


def _world_wrist_force(robot: panda_rapier.Robot) -> np.ndarray:
    """The wrist force in the world frame (the reading is in the hand frame)."""
    x, y, z, w = robot.link_state("panda_hand")["orientation"]
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    return rotation @ robot.touch()["wrist_force"]


def test_the_hand_weighs_itself_and_a_held_cube() -> None:
    env = gym.make(ENV_ID)
    robot = env.unwrapped.robot
    obs, _ = env.reset(seed=7401)
    hand_mass = robot.touch()["hand_mass"]
    # A still, empty hand reads its own weight, downward.
    hold = np.array([0.0, 0.0, 0.0, 1.0], dtype=np.float32)
    for _ in range(5):
        obs, *_ = env.step(hold)
    empty = _world_wrist_force(robot)
    assert empty[2] == pytest.approx(-hand_mass * G, rel=0.05)
    assert np.all(robot.touch()["finger_normal_forces"] == 0.0)
    # Grasp and lift with the scripted policy, then hold still, squeezing.
    policy = panda_rapier.ScriptedPolicy(env)
    start = obs["achieved_goal"][2]
    for _ in range(60):
        obs, *_ = env.step(policy.predict(obs)[0])
        if obs["achieved_goal"][2] > start + 0.08:
            break
    assert obs["achieved_goal"][2] > start + 0.08, "the scripted policy did not lift the cube"
    squeeze = np.array([0.0, 0.0, 0.0, -1.0], dtype=np.float32)
    for _ in range(10):
        obs, *_ = env.step(squeeze)
    fingers, wrist = [], []
    for _ in range(5):
        env.step(squeeze)
        touch = robot.touch()
        fingers.append(touch["finger_forces"].sum(axis=0))
        wrist.append(_world_wrist_force(robot))
    finger_z = -np.mean(fingers, axis=0)[2]
    wrist_z = -np.mean(wrist, axis=0)[2]
    print(f"fingers {finger_z:.4f} N, wrist {wrist_z:.4f} N, empty {-empty[2]:.4f} N")
    assert finger_z == pytest.approx(CUBE_MASS * G, rel=0.05)
    assert wrist_z - hand_mass * G == pytest.approx(CUBE_MASS * G, rel=0.05)
    assert np.all(robot.touch()["finger_normal_forces"] > 1.0)
    env.close()


def test_the_entry_is_the_robot_reading_in_its_layout() -> None:
    assert sum(s.stop - s.start for s in TOUCH_LAYOUT.values()) == 14
    env = gym.make(ENV_ID, obs_mode="state+touch")
    obs, _ = env.reset(seed=7402)
    assert set(obs) == {"achieved_goal", "desired_goal", "observation", TOUCH_KEY}
    assert obs[TOUCH_KEY].shape == (14,) and obs[TOUCH_KEY].dtype == np.float32
    robot = env.unwrapped.robot
    policy = panda_rapier.ScriptedPolicy(env)
    for _ in range(25):  # into the grasp: the fingers touch the cube
        obs, *_ = env.step(policy.predict(obs)[0])
        assert obs in env.observation_space
    touch = robot.touch()
    entry = obs[TOUCH_KEY]
    assert np.all(touch["finger_normal_forces"] > 0.0)
    for name, values in [
        ("finger_normal_forces", touch["finger_normal_forces"]),
        ("finger_forces", touch["finger_forces"].ravel()),
        ("wrist_force", touch["wrist_force"]),
        ("wrist_torque", touch["wrist_torque"]),
    ]:
        np.testing.assert_array_equal(entry[TOUCH_LAYOUT[name]], values.astype(np.float32))
    env.close()


@pytest.mark.parametrize("obs_mode", ["state+touch", "proprio+rgb+touch"])
def test_touch_modes_pass_the_env_checker(obs_mode: str) -> None:
    env = gym.make(ENV_ID, obs_mode=obs_mode, image_size=24)
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=7403)
    assert TOUCH_KEY in obs and obs in env.observation_space
    if obs_mode.startswith("proprio"):
        assert set(obs) == {"desired_goal", "proprioception", "rgb", TOUCH_KEY}
    env.close()


def test_default_observations_are_unchanged_by_touch() -> None:
    plain = gym.make(ENV_ID, obs_mode="state+rgb", image_size=32)
    touch = gym.make(ENV_ID, obs_mode="state+rgb+touch", image_size=32)
    obs, _ = plain.reset(seed=7404)
    more, _ = touch.reset(seed=7404)
    actions = np.random.default_rng(7404).uniform(-1, 1, (8, 4)).astype(np.float32)
    for action in actions:
        assert set(more) == {*obs, TOUCH_KEY}
        for key, value in obs.items():
            np.testing.assert_array_equal(more[key], value, err_msg=key)
        obs, *_ = plain.step(action)
        more, *_ = touch.step(action)
    plain.close()
    touch.close()


def test_the_entry_is_the_same_for_any_threads_batch_and_wrapper() -> None:
    config = env_config(ENV_ID)
    options = {"obs_mode": "state+touch"}
    single = gym.make(ENV_ID, **options)
    single_obs, _ = single.reset(seed=7405)
    policy = panda_rapier.ScriptedPolicy(single)
    actions = []
    for _ in range(30):  # the scripted grasp, so that contacts are live
        action = policy.predict(single_obs)[0]
        actions.append(action)
        single_obs, *_ = single.step(action)
    expected = single_obs[TOUCH_KEY]
    assert np.any(expected[TOUCH_LAYOUT["finger_normal_forces"]] > 0)
    runs = []
    for num_envs, threads in [(3, 1), (3, 2), (5, 2)]:
        envs = PandaVectorEnv(num_envs, num_threads=threads, **options, **config)
        obs, _ = envs.reset(seed=[7405] + [7406] * (num_envs - 1))
        seen = [obs[TOUCH_KEY][0].copy()]
        for action in actions:
            batch = np.zeros((num_envs, 4), np.float32)
            batch[0] = action
            obs, *_ = envs.step(batch)
            seen.append(obs[TOUCH_KEY][0].copy())
        runs.append(np.stack(seen))
        envs.close()
    for run in runs[1:]:
        np.testing.assert_array_equal(run, runs[0])
    np.testing.assert_array_equal(runs[0][-1], expected)

    from panda_rapier.sb3 import make_vec_env

    venv = make_vec_env(ENV_ID, n_envs=2, obs_mode="state+touch")
    venv.seed(7405)
    obs = venv.reset()
    for action in actions:
        obs, *_ = venv.step(np.stack([action, np.zeros(4, np.float32)]))
    np.testing.assert_array_equal(obs[TOUCH_KEY][0], expected)
    venv.close()
    single.close()


@pytest.mark.parametrize("obs_mode", ["flat+touch", "touch", "state+touch+rgb", "rgb+touch+touch"])
def test_bad_touch_modes_are_config_errors(obs_mode: str) -> None:
    with pytest.raises(ConfigError, match="obs_mode") as error:
        gym.make(ENV_ID, obs_mode=obs_mode)
    assert "+touch" in str(error.value)


def test_a_camera_cannot_take_the_touch_key() -> None:
    with pytest.raises(ConfigError, match="touch"):
        gym.make(ENV_ID, obs_mode="rgb+touch", cameras={"touch": {}})
