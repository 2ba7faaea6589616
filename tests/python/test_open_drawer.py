"""OpenDrawer: a cabinet with a drawer (an articulated object from the shipped URDF) in front
of the robot; what the observation says about it, the expert opening it in both action modes
and both joint models, the reward read back from the goals, and clear errors for bad
options."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from panda_rapier import ConfigError
from panda_rapier.agents.evaluation import evaluate
from panda_rapier.agents.inference import resolve_policy

#: Where the task's slots sit in `observation` (after the robot's 25 entries).
OPENING, VELOCITY, HANDLE, RELATIVE, DIRECTION = 25, 26, slice(27, 30), slice(30, 33), slice(33, 36)


def test_the_observation_describes_the_cabinet_and_its_drawer() -> None:
    env = gym.make("panda_rapier/OpenDrawer-v0")
    for seed in range(8):
        obs, info = env.reset(seed=seed)
        o = obs["observation"]
        assert obs["achieved_goal"].shape == (1,) and obs["desired_goal"].shape == (1,)
        # The drawer starts nearly shut, the goal wider open; both within the defaults.
        assert 0.0 <= obs["achieved_goal"][0] <= 0.05 + 1e-5
        assert 0.15 <= obs["desired_goal"][0] <= 0.2
        assert o[OPENING] == obs["achieved_goal"][0] and abs(o[VELOCITY]) < 1e-6
        # The knob's stem, 23.5 cm up, in front of the robot; the drawer opens towards it.
        assert o[HANDLE][2] == pytest.approx(0.235, abs=1e-4)
        assert 0.45 < o[HANDLE][0] < 0.62
        direction = o[DIRECTION]
        assert np.linalg.norm(direction) == pytest.approx(1.0, abs=1e-5) and direction[0] < -0.9
        np.testing.assert_allclose(o[RELATIVE], o[HANDLE] - o[18:21], atol=1e-6)
        assert not info["is_success"] and info["is_grasped"] is False
    env.close()


IDS = ["panda_rapier/OpenDrawer-v0", "panda_rapier/OpenDrawerJoints-v0"]


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("joints", ["multibody", "impulse"])
def test_the_expert_pulls_the_drawer_open(env_id: str, joints: str) -> None:
    overrides = {"task": {"name": "open_drawer", "joints": joints}}
    resolved = resolve_policy("scripted", env_id, overrides=overrides)
    report = evaluate(resolved.policy, resolved.config, 16, num_envs=8, first_seed=5000)
    stats = report.statistics()
    assert stats["success_rate"] == 1.0, stats["success_by_episode"]
    assert stats["mean_steps_to_success"] < 40


def test_the_dense_reward_is_recomputed_from_the_goals_and_the_info() -> None:
    env = gym.make("panda_rapier/OpenDrawerDense-v0")
    _, _ = env.reset(seed=3)
    resolved = resolve_policy("scripted", "panda_rapier/OpenDrawerDense-v0")
    policy = resolved.policy
    obs, _ = env.reset(seed=3)
    rewards, achieved, desired, infos = [], [], [], []
    for _ in range(40):
        action, _ = policy.predict(obs, deterministic=True)
        obs, reward, _, _, info = env.step(action)
        rewards.append(reward)
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        infos.append(info)
    unwrapped = env.unwrapped
    recomputed = unwrapped.compute_reward(np.array(achieved), np.array(desired), infos)  # type: ignore[attr-defined]
    np.testing.assert_allclose(recomputed, rewards, rtol=1e-6)
    # Grasped at some point, and the open term paid in full by the end.
    assert any(i["is_grasped"] for i in infos)
    assert infos[-1]["reward_open"] == pytest.approx(5.0)
    assert infos[-1]["is_success"]
    env.close()


@pytest.mark.parametrize(
    ("task", "match"),
    [
        ({"drawer_start": [0.0, 0.2]}, r"task.drawer_start.*start\s+solved"),
        ({"goal_opening": [0.2, 0.3]}, r"task.goal_opening.*travel"),
        ({"joints": "hinge"}, r"task.joints"),
        ({"cabinet_yaw_range": [0.5, -0.5]}, r"task.cabinet_yaw_range"),
    ],
)
def test_bad_options_are_clear_errors(task: dict[str, object], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        gym.make("panda_rapier/OpenDrawer-v0", task={"name": "open_drawer", **task})
