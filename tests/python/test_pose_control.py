"""``control_mode="ee_pose"`` and ``ee_controller="osc"`` (issue 58) from Python: the 7-D
action space comes out of the native schema in the single, vector and stable-baselines3
environments, the operational-space controller holds the arm, bad options are
``ConfigError``s naming the option, and the scripted expert refuses the mode."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import panda_rapier
from panda_rapier import ConfigError
from panda_rapier.sb3 import make_vec_env
from panda_rapier.vector import PandaVectorEnv


@pytest.mark.parametrize("frame", ["base", "hand"])
def test_pose_actions_have_seven_entries_everywhere(frame: str) -> None:
    env = gym.make("panda_rapier/Flip-v0", control_mode="ee_pose", ee_frame=frame)
    assert env.action_space.shape == (7,)
    env.reset(seed=5807)
    turn = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0], dtype=np.float32)
    for _ in range(3):
        env.step(turn)
    env.close()
    vector = PandaVectorEnv(2, control_mode="ee_pose", ee_frame=frame, num_threads=1)
    assert vector.single_action_space.shape == (7,)
    assert vector.action_space.shape == (2, 7)
    vector.reset(seed=5807)
    vector.step(np.zeros((2, 7), dtype=np.float32))
    vector.close()
    sb3 = make_vec_env("panda_rapier/Reach-v0", n_envs=2, control_mode="ee_pose", ee_frame=frame)
    assert sb3.action_space.shape == (7,)
    sb3.reset()
    sb3.step(np.zeros((2, 7), dtype=np.float32))
    sb3.close()


def test_the_ids_keep_their_action_spaces() -> None:
    assert gym.make("panda_rapier/PickAndPlace-v0").action_space.shape == (4,)
    assert gym.make("panda_rapier/PickAndPlaceJoints-v0").action_space.shape == (8,)


@pytest.mark.parametrize(
    ("options", "name"),
    [
        ({"ee_frame": "tool"}, "ee_frame"),
        ({"ee_rot_step": 0.0}, "ee_rot_step"),
        ({"ee_rot_step": float("nan")}, "ee_rot_step"),
    ],
)
def test_bad_pose_options_name_themselves(options: dict[str, Any], name: str) -> None:
    with pytest.raises(ConfigError, match=name):
        panda_rapier.PandaEnv(control_mode="ee_pose", **options)


@pytest.mark.parametrize("frame", ["base", "hand"])
def test_the_scripted_expert_acts_in_pose_control(frame: str) -> None:
    # It steers the hand to `hand_down` (the orientation `ee` control holds) through the
    # rotation entries, in either frame, and places as it does in `ee` control.
    from panda_rapier.agents.evaluation import evaluate
    from panda_rapier.registration import env_config

    config = env_config("panda_rapier/PickAndPlace-v0", control_mode="ee_pose", ee_frame=frame)
    policy = panda_rapier.ScriptedPolicy(config)
    report = evaluate(policy, config, 20, num_envs=4)
    assert report.placed_rate >= 0.9, report.placed_rate


@pytest.mark.parametrize("mode", ["ee", "ee_pose"])
def test_the_operational_space_controller_holds_the_arm(mode: str) -> None:
    env = panda_rapier.PandaEnv(control_mode=mode, ee_controller="osc", osc={"damping_ratio": 1.0})
    env.reset(seed=5816)
    hold = np.zeros(7 if mode == "ee_pose" else 4, dtype=np.float32)
    hold[-1] = 1.0
    for _ in range(25):
        obs, *_ = env.step(hold)
    velocities = obs["observation"][9:16]  # the arm's seven joint velocities
    assert np.abs(velocities).max() < 0.05


@pytest.mark.parametrize(
    ("options", "name"),
    [
        ({"ee_controller": "mpc"}, "ee_controller"),
        ({"ee_controller": "osc", "control_mode": "joints"}, "ee_controller"),
        ({"ee_controller": "osc", "osc": {"position_stiffness": -1.0}}, "osc.position_stiffness"),
        ({"osc": {"stiffness": 1.0}}, "stiffness"),
    ],
)
def test_bad_controller_options_name_themselves(options: dict[str, Any], name: str) -> None:
    with pytest.raises(ConfigError, match=name):
        panda_rapier.PandaEnv(**options)
