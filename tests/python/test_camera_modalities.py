"""Depth, segmentation and point clouds (issue 60): their entries and spaces in every mode,
back-projected depth on the surfaces it shows, segmentation ids against the visible objects,
determinism for any thread count and batch, colour left bit for bit as it was, and bad options.
The seeds (7301 to 7309) are this file's alone."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import panda_rapier
from panda_rapier import PandaVectorEnv
from panda_rapier.errors import ConfigError
from panda_rapier.pixels import DEFAULT_CAMERA, DEPTH_FAR, OBS_MODES
from panda_rapier.registration import env_config

ENV_ID = "panda_rapier/PickAndPlace-v0"
CUBE_ID = 8
GOALS = {"achieved_goal", "desired_goal"}
PROPRIO = {"desired_goal", "proprioception"}
STATE = {"achieved_goal", "desired_goal", "observation"}


@pytest.mark.parametrize(
    ("obs_mode", "keys"),
    [
        ("depth", GOALS | {"rgb_depth"}),
        ("rgbd", GOALS | {"rgb", "rgb_depth"}),
        ("state+depth", STATE | {"rgb_depth"}),
        ("proprio+depth", PROPRIO | {"rgb_depth"}),
        ("proprio+rgbd", PROPRIO | {"rgb", "rgb_depth"}),
        ("segmentation", GOALS | {"rgb_segmentation"}),
        ("state+rgb+segmentation", STATE | {"rgb", "rgb_segmentation"}),
        ("points", GOALS | {"rgb_points", "rgb_points_mask"}),
        (
            "proprio+rgbd+segmentation+points",
            PROPRIO
            | {
                "rgb",
                "rgb_depth",
                "rgb_segmentation",
                "rgb_points",
                "rgb_points_mask",
                "rgb_points_rgb",
                "rgb_points_segmentation",
            },
        ),
    ],
)
def test_modes_give_their_entries_in_their_spaces(obs_mode: str, keys: set[str]) -> None:
    assert obs_mode in OBS_MODES
    env = gym.make(ENV_ID, obs_mode=obs_mode, image_size=(40, 48))
    obs, _ = env.reset(seed=7301)
    space = env.observation_space
    assert set(obs) == keys == set(space.spaces)
    assert obs in space
    if "rgb_depth" in obs:
        depth = obs["rgb_depth"]
        assert depth.shape == (40, 48, 1) and depth.dtype == np.float32
        assert space["rgb_depth"].low.min() == 0.0
        assert space["rgb_depth"].high.max() == np.float32(DEPTH_FAR)
        assert (depth > 0.3).all() and (depth <= DEPTH_FAR).all()
    if "rgb_segmentation" in obs:
        ids = obs["rgb_segmentation"]
        assert ids.shape == (40, 48, 1) and ids.dtype == np.uint8
        assert set(np.unique(ids)) <= set(env.unwrapped.segmentation_ids)
    if "rgb_points" in obs:
        assert obs["rgb_points"].shape == (1024, 3) and obs["rgb_points"].dtype == np.float32
        assert obs["rgb_points_mask"].shape == (1024,)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_the_segmentation_table_names_every_id() -> None:
    env = gym.make(ENV_ID, obs_mode="segmentation")
    table = env.unwrapped.segmentation_ids
    assert table[0] == "background" and table[1] == "floor" and table[2] == "platform"
    assert table[3] == "goal" and table[CUBE_ID] == "object:cube"
    links = [name for i, name in table.items() if i >= 32]
    assert "link:panda_link0" in links and len(links) >= 8
    env.close()
    stack = gym.make("panda_rapier/Stack-v0", obs_mode="segmentation")
    objects = [name for i, name in stack.unwrapped.segmentation_ids.items() if 8 <= i < 32]
    assert len(objects) == 2
    stack.close()
    # Without segmentation, no table.
    assert gym.make(ENV_ID, obs_mode="rgb").unwrapped.segmentation_ids == {}


def _eye(camera: dict[str, Any]) -> np.ndarray:
    target = np.array(camera["target"])
    azimuth, elevation = math.radians(camera["azimuth"]), math.radians(camera["elevation"])
    return target + camera["distance"] * np.array(
        [
            math.cos(elevation) * math.cos(azimuth),
            math.cos(elevation) * math.sin(azimuth),
            math.sin(elevation),
        ]
    )


@pytest.mark.parametrize("seed", [7302, 7303])
def test_back_projected_depth_lands_on_the_surfaces_it_shows(seed: int) -> None:
    size = 96
    env = gym.make(
        ENV_ID,
        obs_mode="state+rgbd+segmentation+points",
        image_size=size,
        cameras={"rgb": {**DEFAULT_CAMERA, "points": 6000}},
    )
    obs, _ = env.reset(seed=seed)
    points, ids = obs["rgb_points"], obs["rgb_points_segmentation"]
    assert obs["rgb_points_mask"].all()  # the floor fills the picture's lower part
    # A pixel's footprint at each point's distance from the eye.
    pixel = 2 * math.tan(math.radians(DEFAULT_CAMERA["fov"]) / 2) / size
    footprint = np.linalg.norm(points - _eye(DEFAULT_CAMERA), axis=1) * pixel
    # The floor: z = 0.
    floor = ids == 1
    assert floor.sum() > 500
    assert (np.abs(points[floor, 2]) <= footprint[floor]).all()
    # The cube (5 cm, on the floor, turned about z): on its top face, or on a side face.
    cube = ids == CUBE_ID
    assert 5 <= cube.sum()
    centre, half = obs["achieved_goal"], 0.025
    offset = points[cube] - centre
    on_top = np.abs(offset[:, 2] - half) <= footprint[cube]
    across = np.linalg.norm(offset[:, :2], axis=1)
    on_side = (across >= half - footprint[cube]) & (np.abs(offset[:, 2]) <= half + footprint[cube])
    assert (on_top | on_side).all()
    assert (across <= half * math.sqrt(2) + footprint[cube]).all()
    # The platform's top (z = 0.1 over [0.35, 0.65] x [0.15, 0.45]) and sides.
    platform = ids == 2
    assert platform.sum() > 50
    top = np.abs(points[platform, 2] - 0.1) <= footprint[platform]
    assert top.sum() > 30
    assert (points[platform, 2] <= 0.1 + footprint[platform]).all()
    inside = np.abs(points[platform, :2] - [0.5, 0.3]) <= 0.15 + footprint[platform, None]
    assert inside.all()
    # Each point's depth along the optical axis is its pixel's in the depth image.
    eye = _eye(DEFAULT_CAMERA)
    forward = np.array(DEFAULT_CAMERA["target"]) - eye
    along = (points - eye) @ (forward / np.linalg.norm(forward))
    depths = np.sort(obs["rgb_depth"].reshape(-1))
    nearest = depths[np.clip(np.searchsorted(depths, along), 0, depths.size - 1)]
    below = depths[np.clip(np.searchsorted(depths, along) - 1, 0, depths.size - 1)]
    gap = np.minimum(np.abs(nearest - along), np.abs(below - along))
    assert (gap <= 1e-4 * along).all()
    env.close()


def test_camera_frame_points_are_world_points_seen_by_the_camera() -> None:
    def points(frame: str) -> np.ndarray:
        env = gym.make(
            ENV_ID,
            obs_mode="points",
            image_size=32,
            cameras={"rgb": {**DEFAULT_CAMERA, "points": 256, "points_frame": frame}},
        )
        obs, _ = env.reset(seed=7304)
        env.close()
        return np.asarray(obs["rgb_points"], dtype=np.float64)

    world, seen = points("world"), points("camera")
    eye = _eye(DEFAULT_CAMERA)
    forward = np.array(DEFAULT_CAMERA["target"]) - eye
    forward /= np.linalg.norm(forward)
    # z along the optical axis; distances from the eye kept.
    np.testing.assert_allclose(seen[:, 2], (world - eye) @ forward, atol=1e-4)
    np.testing.assert_allclose(
        np.linalg.norm(seen, axis=1), np.linalg.norm(world - eye, axis=1), atol=1e-4
    )


def _segmentation(camera: dict[str, Any], seed: int) -> np.ndarray:
    env = gym.make(ENV_ID, obs_mode="segmentation", image_size=64, cameras={"view": camera})
    obs, _ = env.reset(seed=seed)
    table = env.unwrapped.segmentation_ids
    ids = obs["view_segmentation"]
    assert set(np.unique(ids)) <= set(table)
    env.close()
    return ids


def test_segmentation_shows_the_cube_iff_it_is_in_view() -> None:
    seen = _segmentation(DEFAULT_CAMERA, 7305)
    assert CUBE_ID in seen and 2 in seen and 1 in seen and 0 in seen
    assert any(i >= 32 for i in np.unique(seen))  # the arm
    # Looking at the floor behind the robot: no cube, no platform.
    away = {"target": [-1.0, 0.0, 0.0], "distance": 0.6, "azimuth": 180.0, "elevation": 60.0}
    behind = _segmentation(away, 7305)
    assert CUBE_ID not in behind and 2 not in behind
    assert 1 in behind
    # The goal marker's id only with show_goal.
    assert 3 not in seen
    marked = _segmentation({**DEFAULT_CAMERA, "show_goal": True}, 7305)
    assert 3 in marked


def test_ids_stay_in_the_table_through_an_episode() -> None:
    env = gym.make("panda_rapier/Stack-v0", obs_mode="state+segmentation", image_size=32)
    obs, _ = env.reset(seed=7306)
    table = set(env.unwrapped.segmentation_ids)
    policy = panda_rapier.ScriptedPolicy(env)
    for _ in range(30):
        assert set(np.unique(obs["rgb_segmentation"])) <= table
        obs, *_ = env.step(policy.predict(obs)[0])
    env.close()


MODE = "state+rgbd+segmentation+points"


def test_new_modes_match_the_single_env_for_any_threads_and_batch() -> None:
    config = env_config(ENV_ID)
    cameras = {"rgb": {**DEFAULT_CAMERA, "points": 200}, "side": panda_rapier.pixels.SIDE_CAMERA}
    options = {"obs_mode": MODE, "image_size": 24, "cameras": cameras}
    single = gym.make(ENV_ID, **options)
    single_obs, _ = single.reset(seed=7307)
    actions = np.random.default_rng(7307).uniform(-1, 1, (6, 5, 4)).astype(np.float32)
    runs: dict[tuple[int, int], dict[str, np.ndarray]] = {}
    for num_envs, threads in [(5, 1), (5, 2), (7, 2)]:
        envs = PandaVectorEnv(num_envs, num_threads=threads, **options, **config)
        obs, _ = envs.reset(seed=7307)
        assert obs in envs.observation_space
        for key, value in single_obs.items():
            np.testing.assert_array_equal(obs[key][0], value, err_msg=key)
        seen = {key: [value[:5].copy()] for key, value in obs.items()}
        for step in actions:
            padded = np.concatenate([step, np.zeros((num_envs - 5, 4), np.float32)])
            obs, *_ = envs.step(padded)
            for key, value in obs.items():
                seen[key].append(value[:5].copy())
        runs[(num_envs, threads)] = {key: np.stack(value) for key, value in seen.items()}
        envs.close()
    for key in runs[(5, 1)]:
        np.testing.assert_array_equal(runs[(5, 1)][key], runs[(5, 2)][key], err_msg=key)
        np.testing.assert_array_equal(runs[(5, 1)][key], runs[(7, 2)][key], err_msg=key)
    for t, step in enumerate(actions):
        single_obs, *_ = single.step(step[0])
        for key, value in single_obs.items():
            np.testing.assert_array_equal(runs[(5, 1)][key][t + 1, 0], value, err_msg=key)
    single.close()


def test_colour_is_the_same_bits_with_every_modality() -> None:
    plain = gym.make(ENV_ID, obs_mode="state+rgb", image_size=48)
    every = gym.make(ENV_ID, obs_mode=MODE, image_size=48)
    obs, _ = plain.reset(seed=7308)
    more, _ = every.reset(seed=7308)
    for _ in range(5):
        np.testing.assert_array_equal(obs["rgb"], more["rgb"])
        np.testing.assert_array_equal(obs["observation"], more["observation"])
        action = np.full(4, 0.4, dtype=np.float32)
        obs, *_ = plain.step(action)
        more, *_ = every.step(action)
    plain.close()
    every.close()


def test_sb3_gives_the_new_entries_and_their_final_observations() -> None:
    from panda_rapier.sb3 import make_vec_env

    venv = make_vec_env(
        ENV_ID, n_envs=2, seed=7309, obs_mode="rgbd", image_size=16, max_episode_steps=2
    )
    obs = venv.reset()
    assert obs["rgb_depth"].shape == (2, 16, 16, 1)
    for _ in range(2):
        obs, _, dones, infos = venv.step(np.zeros((2, 4), dtype=np.float32))
    assert dones.all()
    assert infos[0]["terminal_observation"]["rgb_depth"].shape == (16, 16, 1)
    venv.close()


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"obs_mode": "heat"}, "obs_mode"),
        ({"obs_mode": "depth+rgb"}, "obs_mode"),  # not in MODALITIES' order
        ({"obs_mode": "rgb+depth"}, "obs_mode"),  # spelled rgbd
        ({"obs_mode": "state+proprio+rgb"}, "obs_mode"),
        ({"obs_mode": "points", "cameras": {"rgb": {"points": 0}}}, "points"),
        ({"obs_mode": "points", "cameras": {"rgb": {"points": True}}}, "points"),
        ({"obs_mode": "points", "cameras": {"rgb": {"points": 2**21}}}, "points"),
        ({"obs_mode": "points", "cameras": {"rgb": {"points_frame": "moon"}}}, "points_frame"),
        ({"obs_mode": "depth", "cameras": {"rgb": {"points": 10}}}, "points"),
        ({"obs_mode": "rgbd", "cameras": {"a": {}, "a_depth": {}}}, "a_depth"),
    ],
)
def test_bad_modality_options_are_config_errors(kwargs: dict[str, Any], named: str) -> None:
    with pytest.raises(ConfigError, match=named):
        gym.make(ENV_ID, **kwargs)
    with pytest.raises(ConfigError, match=named):
        PandaVectorEnv(2, **env_config(ENV_ID), **kwargs)


def test_bench_measures_the_modalities_beside_colour() -> None:
    from panda_rapier.tools.bench import run_benchmark

    report = run_benchmark(
        num_envs=[2],
        targets=["vector"],
        policies=["random"],
        rounds=1,
        env_steps=10,
        peers=False,
        image_sizes=[16],
        image_modes=["rgb", "depth", "segmentation"],
    )
    targets = [row["target"] for row in report["results"]]
    assert targets == [
        "vector",
        "vector +rgb 16px",
        "vector +depth 16px",
        "vector +segmentation 16px",
    ]
    assert report["image_modes"] == ["rgb", "depth", "segmentation"]
