"""Bad input raises documented, typed exceptions; nothing crashes the interpreter."""

from __future__ import annotations

import inspect
import json
import pickle

import gymnasium as gym
import numpy as np
import pytest

import panda_rapier
import panda_rapier.errors
from panda_rapier import (
    ConfigError,
    InvalidActionError,
    InvalidArgumentError,
    PandaEnv,
    PandaRapierError,
    PandaVectorEnv,
    ResetNeededError,
)


def test_hierarchy() -> None:
    for cls in (InvalidActionError, ConfigError, InvalidArgumentError):
        assert issubclass(cls, ValueError) and issubclass(cls, PandaRapierError)
    assert issubclass(panda_rapier.AssetError, PandaRapierError)
    assert issubclass(ResetNeededError, RuntimeError)


#: Every class with its direct bases, as documented in panda_rapier.errors.
BASES = {
    "PandaRapierError": ("Exception",),
    "InvalidArgumentError": ("PandaRapierError", "ValueError"),
    "InvalidActionError": ("InvalidArgumentError",),
    "ConfigError": ("InvalidArgumentError",),
    "AssetError": ("PandaRapierError", "OSError"),
    "ResetNeededError": ("PandaRapierError", "RuntimeError"),
    "DisplayError": ("PandaRapierError", "RuntimeError"),
}


@pytest.mark.parametrize("name", sorted(BASES))
def test_classes_come_from_the_native_module(name: str) -> None:
    cls = getattr(panda_rapier.errors, name)
    assert cls is getattr(panda_rapier._native, name) is getattr(panda_rapier, name)
    assert name in panda_rapier.errors.__all__
    assert tuple(base.__name__ for base in cls.__bases__) == BASES[name]
    assert (cls.__module__, cls.__qualname__) == ("panda_rapier.errors", name)
    assert inspect.getdoc(cls) and inspect.getdoc(cls) != inspect.getdoc(Exception)
    error = cls("message")
    assert isinstance(error, panda_rapier.PandaRapierError) and str(error) == "message"
    copy = pickle.loads(pickle.dumps(error))
    assert type(copy) is cls and copy.args == ("message",)


def test_native_errors_are_instances_of_the_classes() -> None:
    with pytest.raises(ConfigError) as raised:
        PandaEnv(max_episode_steps=0)
    assert type(raised.value) is ConfigError
    assert isinstance(raised.value, ValueError)
    copy = pickle.loads(pickle.dumps(raised.value))
    assert type(copy) is ConfigError and str(copy) == str(raised.value)
    env = PandaEnv()
    with pytest.raises(ResetNeededError) as reset_needed:
        env._native.step(np.zeros(4, np.float32))
    assert type(reset_needed.value) is ResetNeededError
    env.reset(seed=0)
    with pytest.raises(InvalidActionError):
        env._native.step(np.array([0.0, np.nan, 0.0, 0.0], np.float32))
    # Too few values, too many, and a position beyond the observation's bound (3.4e38 fits a
    # float64 but not the float32 observation).
    for options in ({"goal": [0.5, 0.0]}, {"joint_positions": [0.0] * 3},
                    {"goal": [0.0, 0.0, 3.4e38]}, {"cube_position": [1e4, 0.0, 0.03]}):  # fmt: skip
        with pytest.raises(InvalidArgumentError, match="reset option") as bad_option:
            env._native.reset(0, json.dumps(options))
        assert type(bad_option.value) is InvalidArgumentError


@pytest.mark.parametrize(
    ("action", "match"),
    [
        (np.zeros(3, np.float32), r"shape \(4,\)"),
        (np.zeros((1, 4), np.float32), r"shape \(4,\)"),
        (np.zeros(8, np.float32), r"shape \(4,\)"),
        (np.array(["a", "b", "c", "d"]), r"real numbers .*shape \(4,\)"),
        (np.zeros(4, np.complex64), "real numbers"),
        (np.zeros(4, bool), "real numbers"),
        (np.array([0.0, np.nan, 0.0, 0.0], np.float32), r"action\[1\] must be finite"),
        (np.array([0.0, 0.0, np.inf, 0.0]), r"action\[2\] must be finite"),
        ([0.0, 0.0], r"shape \(4,\)"),
        (None, "real numbers"),
        (object(), "real numbers"),
        (np.float32(0.5), r"shape \(4,\)"),
    ],
    ids=lambda value: type(value).__name__,
)
def test_bad_actions(action: object, match: str) -> None:
    env = gym.make("panda_rapier/PickAndPlace-v0")
    env.reset(seed=0)
    with pytest.raises(InvalidActionError, match=match):
        env.step(action)
    # The env is still usable.
    env.step(np.zeros(4, np.float32))


def test_accepted_actions_other_dtypes_and_out_of_range() -> None:
    env = PandaEnv()
    env.reset(seed=0)
    env.step([0, 0, 0, 1])
    env.step(np.array([1e300, -1e300, 0.0, 0.0]))  # clipped, not turned into inf
    env.step(np.zeros(8, np.float32)[::2])  # non-contiguous view
    obs, *_ = env.step(np.full(4, 5.0, np.float32))
    assert all(np.isfinite(v).all() for v in obs.values())


def test_bad_vector_actions() -> None:
    envs = PandaVectorEnv(2)
    envs.reset(seed=0)
    with pytest.raises(InvalidActionError, match=r"shape \(2, 4\)"):
        envs.step(np.zeros(4, np.float32))
    bad = np.zeros((2, 4), np.float32)
    bad[1, 3] = np.nan
    with pytest.raises(InvalidActionError, match="environment 1"):
        envs.step(bad)


@pytest.mark.parametrize(
    ("config", "match"),
    [
        ({"colour": "red"}, "unknown field `colour`"),
        ({"success_threshold": -0.1}, "success_threshold"),
        ({"control_mode": "teleport"}, "control_mode|unknown variant"),
        ({"max_episode_steps": 0}, "max_episode_steps"),
        ({"control_frequency": 30}, "control_frequency"),
        (
            {"task": {"name": "lift", "cube_region": {"low": [0.6, 0.0], "high": [0.4, -0.2]}}},
            "task.cube_region",
        ),
        ({"task": {"name": "reach", "goal_height": [0.1, 0.2]}}, "goal_height"),
        ({"task": "juggle"}, "unknown task"),
        ({"task": {"goal_region": [[0, 0, 0], [1, 1, 1]]}}, "name"),
        ({"task": "push", "lift_height": [0.1, 0.2]}, "lift_height"),
        ({"physics": {"solver": {"dt": 0.0}}}, "physics.solver.dt"),
        ({"task": {"name": "push", "cube": {"mass": -1.0}}}, "task.cube.mass"),
        ({"robot": {"motors": {"stiffness": 0.0}}}, "robot.motors.stiffness"),
        ({"physics": {"solver": {"substeps": 2}}}, "substeps"),
        ({"task": {"name": "lift", "cube": {"position": [0.5, 0.0, 0.025]}}}, "position"),
        ({"task": "reach", "randomization": {"cube_mass": [0.1, 0.2]}}, "randomization.cube_mass"),
        ({"success_threshold": object()}, "not supported"),
    ],
)
def test_bad_config(config: dict[str, object], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        PandaEnv(**config)
    with pytest.raises(ConfigError, match=match):
        PandaVectorEnv(2, **config)


def test_bad_vector_arguments() -> None:
    with pytest.raises(ConfigError, match="num_envs"):
        PandaVectorEnv(0)
    with pytest.raises(ConfigError, match="num_threads"):
        PandaVectorEnv(2, num_threads=0)
    with pytest.raises(ConfigError, match="autoreset_mode"):
        PandaVectorEnv(2, autoreset_mode="sometimes")
    with pytest.raises(ConfigError, match="render_mode"):
        PandaEnv(render_mode="ascii")


def test_call_order() -> None:
    env = PandaEnv()
    with pytest.raises(ResetNeededError, match="before the first reset"):
        env.step(np.zeros(4, np.float32))
    env.reset(seed=0)
    env.close()
    with pytest.raises(ResetNeededError, match="closed"):
        env.step(np.zeros(4, np.float32))
    with pytest.raises(ResetNeededError, match="closed"):
        env.reset()
    env.close()  # twice is fine


@pytest.mark.parametrize("seed", [-1, 2**64, 1.5, "7", True])
def test_bad_seeds(seed: object) -> None:
    env = PandaEnv()
    with pytest.raises((InvalidArgumentError, gym.error.Error, TypeError)):
        env.reset(seed=seed)  # type: ignore[arg-type]


def test_robot_argument_errors() -> None:
    env = PandaEnv()
    env.reset(seed=0)
    robot = env.robot
    with pytest.raises(InvalidArgumentError, match="unknown link `nope`"):
        robot.link_state("nope")
    with pytest.raises(InvalidArgumentError, match="unknown joint"):
        robot.position_control("nope", 0.0)
    with pytest.raises(InvalidArgumentError, match="out of range"):
        robot.torque_control(99, 1.0)
    with pytest.raises(InvalidArgumentError, match="must have 8 values"):
        robot.set_joint_positions([0.0] * 3)
    with pytest.raises(InvalidArgumentError, match="finite"):
        robot.forward_kinematics([np.nan] * 8)
    with pytest.raises(InvalidArgumentError, match="quaternion"):
        robot.inverse_kinematics([0.5, 0.0, 0.3], [0.0, 0.0, 0.0, 0.0])
    with pytest.raises(InvalidArgumentError, match="control mode"):
        env._native.set_joint_control(0, "magic", 0.0)
