"""The single environment against Gymnasium's contract: checkers, spaces, determinism,
time limit, compute_reward, pickling."""

from __future__ import annotations

import copy
import json
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from conftest import random_actions
from gymnasium.utils.env_checker import check_env

import panda_rapier
from panda_rapier.registration import TASK_NAMES
from panda_rapier.registration import TASKS as REGISTRY


@pytest.mark.parametrize("env_id", panda_rapier.ENV_IDS)
def test_gymnasium_check_env(env_id: str) -> None:
    env = gym.make(env_id)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=True)
    assert [str(w.message) for w in caught] == []
    env.close()


#: Each task's id prefix, goal size, observation size and episode length.
TASKS = {
    "PickAndPlace": (3, 41, 70),
    "Reach": (3, 25, 50),
    "Lift": (3, 41, 70),
    "Stack": (6, 57, 150),
    "Push": (3, 41, 70),
    "Slide": (3, 41, 100),
    "Flip": (4, 41, 200),
    "PegInsertion": (6, 56, 100),
    "PickObject": (3, 54, 100),
    "OpenDrawer": (1, 40, 100),
}

#: The action size of each task's end-effector ids where it is not 4 (``ee``): the tasks whose
#: hand must turn take ``ee_pose`` actions.
EE_ACTIONS = {"PegInsertion": 7, "PickObject": 7, "OpenDrawer": 7}


def test_env_ids_and_spaces() -> None:
    assert panda_rapier.ENV_IDS == tuple(
        f"panda_rapier/{task}{variant}-v0"
        for task in TASKS
        for variant in ("", "Dense", "Joints", "JointsDense")
    )
    for task, (goal, observation, steps) in TASKS.items():
        for variant, action in (("", EE_ACTIONS.get(task, 4)), ("JointsDense", 8)):
            env = gym.make(f"panda_rapier/{task}{variant}-v0")
            assert env.action_space.shape == (action,)
            assert env.spec is not None and env.spec.max_episode_steps == steps
            shapes = {k: s.shape for k, s in env.observation_space.spaces.items()}  # type: ignore[attr-defined]
            assert shapes == {
                "achieved_goal": (goal,),
                "desired_goal": (goal,),
                "observation": (observation,),
            }, task
            obs, _ = env.reset(seed=0)
            assert env.observation_space.contains(obs)
    ee = gym.make("panda_rapier/PickAndPlace-v0")
    joints = gym.make("panda_rapier/PickAndPlaceJoints-v0")
    assert ee.action_space.shape == (4,) and joints.action_space.shape == (8,)
    assert ee.spec is not None and ee.spec.max_episode_steps == 70 == panda_rapier.MAX_EPISODE_STEPS
    space = ee.observation_space
    assert isinstance(space, gym.spaces.Dict)
    assert {k: s.shape for k, s in space.spaces.items()} == {
        "achieved_goal": (3,),
        "desired_goal": (3,),
        "observation": (41,),
    }
    assert ee.unwrapped.dt == pytest.approx(0.04)
    obs, info = ee.reset(seed=0)
    assert space.contains(obs)
    assert info["is_success"] is False and info["elapsed_steps"] == 0
    np.testing.assert_array_equal(obs["desired_goal"], ee.unwrapped.goal.astype(np.float32))
    assert panda_rapier.__version__ == "0.1.0"


def rollout(env: gym.Env, seed: int, steps: int) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    trace = [np.concatenate([obs[k] for k in sorted(obs)])]
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        trace.append(np.concatenate([obs[k] for k in sorted(obs)] + [np.float32([reward])]))
        if terminated or truncated:
            obs, _ = env.reset()
            trace.append(np.concatenate([obs[k] for k in sorted(obs)]))
    return trace


@pytest.mark.parametrize(
    "env_id", ["panda_rapier/PickAndPlace-v0", "panda_rapier/PickAndPlaceJointsDense-v0"]
)
def test_equal_seeds_give_bit_identical_trajectories(env_id: str) -> None:
    first = rollout(gym.make(env_id), seed=7, steps=120)
    second = rollout(gym.make(env_id), seed=7, steps=120)
    assert len(first) == len(second)
    for a, b in zip(first, second, strict=True):
        np.testing.assert_array_equal(a, b)
    other = rollout(gym.make(env_id), seed=8, steps=5)
    assert not np.array_equal(first[0], other[0])


def test_time_limit_comes_from_gym_make() -> None:
    env = gym.make("panda_rapier/PickAndPlace-v0", max_episode_steps=7)
    env.reset(seed=1)
    flags = [env.step(np.zeros(4, np.float32))[3] for _ in range(7)]
    assert flags == [False] * 6 + [True]
    direct = panda_rapier.PandaEnv(max_episode_steps=3)
    direct.reset(seed=1)
    assert [direct.step(np.zeros(4, np.float32))[3] for _ in range(3)] == [False, False, True]
    unlimited = panda_rapier.PandaEnv()
    unlimited.reset(seed=1)
    assert not any(unlimited.step(np.zeros(4, np.float32))[3] for _ in range(60))


@pytest.mark.parametrize("env_id", panda_rapier.ENV_IDS)
def test_compute_reward_matches_step_reward(env_id: str, rng: np.random.Generator) -> None:
    env = gym.make(env_id)
    obs, _ = env.reset(seed=3)
    achieved, desired, infos, rewards = [], [], [], []
    for _ in range(60):
        obs, reward, _, _, info = env.step(random_actions(rng, env.action_space.shape))
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        infos.append(info)
        rewards.append(reward)
        assert (
            env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info) == reward
        )
    batch = env.unwrapped.compute_reward(np.stack(achieved), np.stack(desired), infos)
    assert batch.shape == (60,)
    np.testing.assert_array_equal(batch, np.array(rewards))
    # Relabelled goal: the cube's own position is a success.
    relabelled = env.unwrapped.compute_reward(
        np.stack(achieved), np.stack(achieved), np.array(infos)
    )
    assert np.all(relabelled >= np.array(rewards))
    # Leading shape is kept (n_envs, batch, goal size).
    goal = obs["achieved_goal"].shape[-1]
    shaped = env.unwrapped.compute_reward(
        np.stack(achieved).reshape(6, 10, goal),
        np.stack(desired).reshape(6, 10, goal),
        np.array(infos).reshape(6, 10),
    )
    np.testing.assert_array_equal(shaped.reshape(-1), batch)


def test_reward_weights_are_options_and_release_pays_for_opening_on_the_goal() -> None:
    """The scripted expert places the cube: with default weights its dense rewards carry no
    release term; with ``release`` and ``place`` weighted, the same episode's rewards change by
    exactly the reweighted terms, and ``compute_reward`` reproduces them from the infos."""
    weights = {"place": 7.0, "release": 2.0}
    default = gym.make("panda_rapier/PickAndPlaceDense-v0")
    weighted = gym.make("panda_rapier/PickAndPlaceDense-v0", reward_weights=weights)
    assert weighted.unwrapped.config["reward_weights"]["grasp"] == 1.0
    policy = panda_rapier.ScriptedPolicy(default)
    obs, _ = default.reset(seed=5)
    weighted.reset(seed=5)
    released = []
    for _ in range(panda_rapier.MAX_EPISODE_STEPS):
        action, _ = policy.predict(obs)
        obs, reward, _, _, info = default.step(action)
        wobs, wreward, _, _, winfo = weighted.step(action)
        np.testing.assert_array_equal(wobs["observation"], obs["observation"])
        assert info["reward_release"] == 0.0
        assert winfo["gripper_opening"] == info["gripper_opening"]
        expected = reward - info["reward_place"] + winfo["reward_place"] + winfo["reward_release"]
        assert wreward == pytest.approx(expected, abs=1e-5)
        assert weighted.unwrapped.compute_reward(
            wobs["achieved_goal"], wobs["desired_goal"], winfo
        ) == pytest.approx(wreward, abs=0)
        if winfo["reward_release"] > 0:
            assert winfo["is_success"]
            assert winfo["reward_release"] == pytest.approx(2.0 * winfo["gripper_opening"], 1e-6)
            released.append(winfo["gripper_opening"])
    assert info["is_placed"] and winfo["reward_place"] == 7.0
    assert released and max(released) == 1.0
    for bad, message in (
        ({"release": -1.0}, r"reward_weights\.release.*>= 0"),
        ({"place": float("nan")}, r"reward_weights\.place must be a finite number"),
        ({"drop": 1.0}, r"reward_weights\.drop.*no \"drop\" term"),
    ):
        with pytest.raises(panda_rapier.ConfigError, match=message):
            gym.make("panda_rapier/PickAndPlaceDense-v0", reward_weights=bad)


def test_dense_compute_reward_needs_the_info() -> None:
    env = gym.make("panda_rapier/PickAndPlaceDense-v0")
    obs, _ = env.reset(seed=0)
    with pytest.raises(panda_rapier.InvalidArgumentError, match="reward_reach"):
        env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], {})
    sparse = gym.make("panda_rapier/PickAndPlace-v0")
    obs, _ = sparse.reset(seed=0)
    assert sparse.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], None) == -1.0


def test_reset_options_override_the_draw() -> None:
    env = gym.make("panda_rapier/PickAndPlace-v0")
    obs, _ = env.reset(
        seed=0, options={"cube_position": [0.5, -0.1, 0.02], "goal": [0.5, 0.3, 0.12]}
    )
    np.testing.assert_allclose(obs["desired_goal"], [0.5, 0.3, 0.12], atol=1e-6)
    np.testing.assert_allclose(obs["achieved_goal"][:2], [0.5, -0.1], atol=2e-3)
    with pytest.raises(panda_rapier.InvalidArgumentError, match="unknown field") as error:
        env.reset(options={"cube_colour": "red"})
    # The message names the option and what is expected, not a place in a JSON text.
    assert "cube_colour" in str(error.value) and "column" not in str(error.value)


def test_pickle_and_deepcopy_round_trip() -> None:
    env = gym.make("panda_rapier/PickAndPlaceDense-v0", success_threshold=0.04)
    clone = pickle.loads(pickle.dumps(env))
    duplicate = copy.deepcopy(env.unwrapped)
    assert clone.unwrapped.config["success_threshold"] == 0.04
    assert clone.unwrapped.config["reward_type"] == "dense"
    for other in (clone, duplicate):
        a, _ = env.reset(seed=11)
        b, _ = other.reset(seed=11)
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
        action = np.full(env.action_space.shape, 0.3, np.float32)
        np.testing.assert_array_equal(
            env.step(action)[0]["observation"], other.step(action)[0]["observation"]
        )


def test_save_and_restore_state_continue_identically(rng: np.random.Generator) -> None:
    env = panda_rapier.PandaEnv()
    env.reset(seed=5)
    for _ in range(10):
        env.step(random_actions(rng, (4,)))
    state = env.snapshot()
    actions = [random_actions(rng, (4,)) for _ in range(15)]
    first = [env.step(a)[0]["observation"] for a in actions]
    env.restore(state)
    second = [env.step(a)[0]["observation"] for a in actions]
    for a, b in zip(first, second, strict=True):
        np.testing.assert_array_equal(a, b)


def test_config_passes_through_gym_make() -> None:
    env = gym.make("panda_rapier/PickAndPlace-v0", control_frequency=50, success_threshold=0.03)
    assert env.unwrapped.dt == pytest.approx(0.02)
    assert env.unwrapped.config["success_threshold"] == 0.03
    assert env.metadata["render_fps"] == 50
    env = gym.make("panda_rapier/PickAndPlace-v0", render_mode="rgb_array")
    assert env.render_mode == "rgb_array"


def test_a_task_is_configured_by_its_own_section() -> None:
    region = {"low": [0.45, 0.1], "high": [0.5, 0.15]}
    env = gym.make("panda_rapier/Push-v0", task={"name": "push", "goal_region": region})
    config = env.unwrapped.config["task"]
    assert config["name"] == "push" and config["goal_region"] == region
    defaults = json.loads(next(t["defaults"] for t in REGISTRY if t["name"] == "push"))
    assert config["cube_region"] == defaults["cube_region"]
    for seed in range(20):
        obs, _ = env.reset(seed=seed)
        x, y, _ = obs["desired_goal"]
        assert 0.45 - 1e-6 <= x <= 0.5 + 1e-6 and 0.1 - 1e-6 <= y <= 0.15 + 1e-6
    # The name alone is the task with its defaults, the same environment.
    short = gym.make("panda_rapier/Reach-v0")
    long = gym.make("panda_rapier/Reach-v0", task={"name": "reach"})
    assert short.unwrapped.config == long.unwrapped.config


def test_the_registry_lists_every_task_once_with_its_ids() -> None:
    names = [t["name"] for t in REGISTRY]
    assert names == list(TASK_NAMES) and len(set(names)) == len(names)
    for task in REGISTRY:
        spec = gym.spec(f"panda_rapier/{task['id_stem']}-v0")
        assert spec.kwargs["task"] == task["name"]
        assert spec.max_episode_steps == task["episode_steps"]
        env = gym.make(spec.id)
        assert env.unwrapped.config["task"] == json.loads(task["defaults"])
        env.close()


@pytest.mark.parametrize(
    ("env_id", "old", "new"),
    [
        (
            "panda_rapier/Reach-v0",
            {"reach_goal_region": [[0.4, -0.1, 0.2], [0.5, 0.1, 0.3]]},
            {"goal_region": [[0.4, -0.1, 0.2], [0.5, 0.1, 0.3]]},
        ),
        ("panda_rapier/Lift-v0", {"lift_height": [0.1, 0.15]}, {"goal_height": [0.1, 0.15]}),
        (
            "panda_rapier/PickAndPlace-v0",
            {"goal_air_probability": 0.5, "pick_region": {"low": [0.45, -0.2], "high": [0.5, 0]}},
            {"goal_air_probability": 0.5, "cube_region": {"low": [0.45, -0.2], "high": [0.5, 0]}},
        ),
    ],
)
def test_options_from_before_0_2_warn_and_mean_the_same(
    env_id: str, old: dict[str, object], new: dict[str, object]
) -> None:
    task = gym.spec(env_id).kwargs["task"]
    with pytest.warns(FutureWarning, match="0.3.0") as record:
        before = gym.make(env_id, **old)
    assert all(key in " ".join(str(w.message) for w in record) for key in old)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        after = gym.make(env_id, task={"name": task, **new})
    assert before.unwrapped.config == after.unwrapped.config
    first, second = before.reset(seed=5)[0], after.reset(seed=5)[0]
    for key in first:
        np.testing.assert_array_equal(first[key], second[key])


def test_the_sim_section_from_before_0_2_warns_and_means_the_same() -> None:
    """``sim`` spread over ``physics``, ``robot``, ``arm`` and the task's section: one warning
    per old key, the same configuration and the same episode as the new spelling."""
    old = {
        "sim": {
            "solver": {"solver_iterations": 8, "substeps": 4},
            "robot_friction": 0.4,
            "cube": {"mass": 0.15, "position": [0.5, -0.15, 0.025]},
            "platform": {"friction": 0.8},
            "arm": "kinematic",
        }
    }
    with pytest.warns(FutureWarning, match="0.3.0") as record:
        before = gym.make("panda_rapier/Stack-v0", **old)
    messages = " ".join(str(w.message) for w in record)
    for key in ("sim.solver", "sim.solver.substeps", "sim.robot_friction", "sim.cube.position"):
        assert key in messages, messages
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        after = gym.make(
            "panda_rapier/Stack-v0",
            task={"name": "stack", "cube": {"mass": 0.15}, "platform": {"friction": 0.8}},
            physics={"solver": {"solver_iterations": 8}},
            robot={"link_friction": 0.4},
            arm="kinematic",
        )
    assert before.unwrapped.config == after.unwrapped.config
    assert after.unwrapped.config["task"]["cube"]["mass"] == 0.15
    first, second = before.reset(seed=5)[0], after.reset(seed=5)[0]
    for key in first:
        np.testing.assert_array_equal(first[key], second[key])
    # An old key that would do nothing now is an error, not silence.
    with pytest.raises(panda_rapier.ConfigError, match=r"sim\.cube"):
        gym.make("panda_rapier/Reach-v0", sim={"cube": {"mass": 0.3}})


@pytest.mark.parametrize("env_id", panda_rapier.ENV_IDS)
def test_kinematic_arm_passes_the_checker_and_reports_blocked_motion(env_id: str) -> None:
    env = gym.make(env_id, arm="kinematic")
    check_env(env.unwrapped, skip_render_check=True)
    assert env.unwrapped.config["arm"] == "kinematic"
    _, info = env.reset(seed=0)
    assert info["arm_blocked"] is False
    for _ in range(5):
        _, _, _, _, info = env.step(env.action_space.sample())
        assert isinstance(info["arm_blocked"], bool)
    with pytest.raises(panda_rapier.ConfigError, match=r"`dynamic` or `kinematic`"):
        gym.make(env_id, arm="teleport")


def test_kinematic_arm_rejects_torque_control() -> None:
    env = gym.make("panda_rapier/PickAndPlace-v0", arm="kinematic")
    env.reset(seed=0)
    with pytest.raises(panda_rapier.InvalidArgumentError, match="dynamic arm"):
        env.unwrapped.robot.torque_control("panda_joint2", 1.0)


def test_names_from_before_tasks_are_the_same_objects() -> None:
    """Code written against the first release keeps working: the old names are the same
    objects, each with a FutureWarning naming the new one and the removal version."""
    from panda_rapier import env as env_module
    from panda_rapier import sb3, vector

    for module, old, new in (
        (panda_rapier, "PickAndPlaceEnv", panda_rapier.PandaEnv),
        (panda_rapier, "PickAndPlaceVectorEnv", panda_rapier.PandaVectorEnv),
        (env_module, "PickAndPlaceEnv", panda_rapier.PandaEnv),
        (vector, "PickAndPlaceVectorEnv", panda_rapier.PandaVectorEnv),
        (sb3, "PandaRapierVecEnv", sb3.PandaVecEnv),
    ):
        with pytest.warns(FutureWarning, match=f"{old} is renamed .*{new.__name__}.*0.3.0"):
            assert getattr(module, old) is new
    with pytest.raises(AttributeError):
        _ = panda_rapier.NoSuchName
    env = panda_rapier.PandaEnv()
    env.reset(seed=1)
    with pytest.warns(FutureWarning, match="save_state is renamed"):
        state = env.save_state()
    before = env.step(np.zeros(4, dtype=np.float32))[0]
    with pytest.warns(FutureWarning, match="restore_state is renamed"):
        env.restore_state(state)
    after = env.step(np.zeros(4, dtype=np.float32))[0]
    for key in before:
        np.testing.assert_array_equal(before[key], after[key])
