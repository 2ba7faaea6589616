"""Property-based tests (hypothesis) of every public entry point: whatever goes in, the result
is a finite observation, a clipped action or a documented, typed exception; never a crash, a
hang, another exception type or a NaN."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

import panda_rapier
from panda_rapier import (
    ConfigError,
    InvalidActionError,
    InvalidArgumentError,
    PandaEnv,
    PandaRapierError,
    PandaVectorEnv,
    ResetNeededError,
    ScriptedPolicy,
)

# hypothesis itself warns when it squeezes generated floats into float16 or float32 arrays.
pytestmark = pytest.mark.filterwarnings("ignore:overflow encountered in cast:RuntimeWarning")

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])

DTYPES = st.sampled_from(
    [np.float16, np.float32, np.float64, np.int8, np.int64, np.uint8, np.bool_, np.complex64]
)
WILD_FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64) | st.sampled_from(
    [1e300, -1e300, 3.4e38, -3.4e38, 1e-310, 0.0, -0.0]
)


def finite(obs: dict[str, np.ndarray]) -> bool:
    return all(np.isfinite(v).all() for v in obs.values())


def wild_arrays(shape: st.SearchStrategy) -> st.SearchStrategy:
    """Arrays of any dtype and the given shapes, with wild values where the dtype allows."""

    def build(dtype: type) -> st.SearchStrategy:
        elements = WILD_FLOATS if np.dtype(dtype).kind in "fc" else None
        return hnp.arrays(dtype, shape, elements=elements)

    return DTYPES.flatmap(build)


def non_contiguous(array: np.ndarray) -> np.ndarray:
    """The same values, laid out with a stride (every other element of a larger array)."""
    wide = np.zeros((*array.shape[:-1], 2 * array.shape[-1]), dtype=array.dtype)
    wide[..., ::2] = array
    return wide[..., ::2]


#: Every task in both action modes: the hostile-input properties hold for each.
TASK_IDS = [i for i in panda_rapier.ENV_IDS if "Dense" not in i]


@pytest.fixture(scope="module", params=TASK_IDS)
def env(request: pytest.FixtureRequest) -> gym.Env:
    env = gym.make(request.param)
    env.reset(seed=0)
    return env


@FAST
@given(
    action=wild_arrays(hnp.array_shapes(min_dims=0, max_dims=3, max_side=9))
    | wild_arrays(st.sampled_from([(4,), (8,)]))
    | st.lists(WILD_FLOATS, max_size=9)
    | st.none()
    | st.text(max_size=4),
    strided=st.booleans(),
)
def test_any_action_steps_or_raises_invalid_action(
    env: gym.Env, action: object, strided: bool
) -> None:
    if strided and isinstance(action, np.ndarray) and action.ndim >= 1 and action.size:
        action = non_contiguous(action)
    try:
        obs, reward, terminated, truncated, _ = env.step(action)
    except InvalidActionError as error:
        assert isinstance(error, ValueError) and str(error)
        return
    assert finite(obs) and math.isfinite(reward)
    if terminated or truncated:
        env.reset()


@FAST
@given(actions=wild_arrays(st.sampled_from([(3, 4), (3, 8), (4,), (3,), (0, 4), (3, 4, 1)])))
def test_any_batch_steps_or_raises_invalid_action(actions: np.ndarray) -> None:
    envs = PandaVectorEnv(3)
    envs.reset(seed=1)
    try:
        obs, rewards, *_ = envs.step(actions)
    except InvalidActionError:
        # Nothing moved: the next valid step works.
        obs, rewards, *_ = envs.step(np.zeros((3, 4), np.float32))
    assert finite(obs) and np.isfinite(rewards).all()
    envs.close()


CONFIG_KEYS = sorted(json.loads(panda_rapier._native.default_config_json()))
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | WILD_FLOATS | st.integers(-(2**70), 2**70) | st.text(max_size=5),
    lambda children: (
        st.lists(children, max_size=4)
        | st.dictionaries(st.sampled_from([*CONFIG_KEYS, "x", "dt", "mass"]), children, max_size=3)
    ),
    max_leaves=8,
)


@FAST
@given(
    config=st.dictionaries(
        st.sampled_from([*CONFIG_KEYS, "unknown_key", "physics.solver.dt"]), JSON_VALUES, max_size=3
    )
)
def test_any_config_builds_a_working_env_or_raises_config_error(config: dict) -> None:
    try:
        env = PandaEnv(**config)
    except ConfigError as error:
        assert isinstance(error, ValueError) and str(error)
        return
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        obs, reward, *_ = env.step(env.action_space.sample())
        assert finite(obs) and math.isfinite(reward)


@pytest.mark.parametrize(
    "config",
    [
        {"task": {"name": "pick_and_place", "cube": {"mass": -1.0}}},
        {"task": {"name": "stack", "cube": {"mass": 0.0}}},
        {"physics": {"solver": {"dt": 0.0}}},
        {"physics": {"solver": {"dt": float("nan")}}},
        {"task": {"name": "push", "cube_region": {"low": [0.6, 0.0], "high": [0.4, -0.2]}}},
        {"task": {"name": "stack", "goal_region": {"low": [0.5, 0.3], "high": [0.5, 0.3]}}}
        | {"success_threshold": -1},
        {"task": {"name": "lift", "cube_yaw_range": [1.0, -1.0]}},
        {"task": {"name": "reach", "goal_region": [[0.5, 0, 0], [0.4, 1, 1]]}},
        {"task": {"name": "pick_and_place", "goal_air_probability": 2.0}},
        {"no_such_option": 1},
        {"robot": {"urdf": "/nonexistent/robot.urdf"}},
        {"control_frequency": 0},
        {"max_episode_steps": 0},
    ],
)
def test_documented_invalid_configs(config: dict) -> None:
    with pytest.raises((ConfigError, panda_rapier.AssetError)):
        PandaEnv(**config)


@FAST
@given(
    seed=st.none()
    | st.integers(-(2**70), 2**70)
    | st.booleans()
    | WILD_FLOATS
    | st.text(max_size=3)
    | st.just(np.int64(5))
    | st.just(np.uint64(2**64 - 1)),
    options=st.none()
    | st.dictionaries(
        st.sampled_from(["cube_position", "cube_yaw", "goal", "joint_positions", "bogus"]),
        JSON_VALUES,
        max_size=2,
    ),
)
def test_any_seed_and_options_reset_or_raise_invalid_argument(
    env: gym.Env, seed: object, options: object
) -> None:
    try:
        obs, _ = env.unwrapped.reset(seed=seed, options=options)
    except InvalidArgumentError as error:
        assert isinstance(error, ValueError) and str(error)
        env.reset(seed=0)
        return
    assert finite(obs)


@FAST
@given(
    observation=wild_arrays(hnp.array_shapes(min_dims=0, max_dims=3, max_side=70))
    | st.dictionaries(
        st.sampled_from(["achieved_goal", "desired_goal", "observation"]),
        wild_arrays(hnp.array_shapes(max_dims=2, max_side=70)),
    )
)
@pytest.mark.parametrize("task", ["pick_and_place", "reach", "lift", "push", "stack"])
def test_scripted_policy_acts_or_raises_invalid_argument(task: str, observation: object) -> None:
    policy = ScriptedPolicy(task=task)
    try:
        actions, _ = policy.predict(observation)
    except InvalidArgumentError:
        return
    assert np.isfinite(actions).all() and (np.abs(actions) <= 1).all()


class CallOrder(RuleBasedStateMachine):
    """Any sequence of reset / step / save / restore / close on a single env ends in results or
    typed errors: ``ResetNeededError`` before the first reset and after close."""

    def __init__(self) -> None:
        super().__init__()
        self.env = PandaEnv(max_episode_steps=3)
        self.reset_once = False
        self.closed = False
        self.saved = None

    @rule(seed=st.none() | st.integers(0, 5))
    def reset(self, seed: int | None) -> None:
        try:
            self.env.reset(seed=seed)
        except ResetNeededError:
            assert self.closed
            return
        assert not self.closed
        self.reset_once = True

    @rule()
    def step(self) -> None:
        try:
            obs, *_ = self.env.step(np.zeros(4, np.float32))
        except ResetNeededError:
            return
        assert self.reset_once and not self.closed and finite(obs)

    @rule()
    def save(self) -> None:
        try:
            self.saved = self.env.snapshot()
        except PandaRapierError:
            assert self.closed or not self.reset_once

    @precondition(lambda self: self.saved is not None)
    @rule()
    def restore(self) -> None:
        try:
            self.env.restore(self.saved)
        except PandaRapierError:
            assert self.closed

    @rule()
    def close(self) -> None:
        self.env.close()  # twice is fine
        self.closed = True

    @invariant()
    def spaces_stay(self) -> None:
        assert self.env.action_space.shape == (4,)


TestCallOrder = CallOrder.TestCase
TestCallOrder.settings = settings(max_examples=40, stateful_step_count=12, deadline=None)
