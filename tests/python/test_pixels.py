"""Image observations: ``obs_mode="rgb"``, ``"state+rgb"``, ``"proprio+rgb"`` on the single,
vector and stable-baselines3 environments, their determinism, final observations, bad options,
the benchmark, evaluation of a pixel policy and a pixel PPO smoke run."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import panda_rapier
from panda_rapier import PandaVectorEnv
from panda_rapier.errors import ConfigError, InvalidArgumentError
from panda_rapier.pixels import DEFAULT_IMAGE_SIZE, SIDE_CAMERA
from panda_rapier.registration import env_config

ENV_ID = "panda_rapier/PickAndPlace-v0"
TWO_CAMERAS = {"front": panda_rapier.pixels.DEFAULT_CAMERA, "side": SIDE_CAMERA}


def _keys(obs: dict[str, Any]) -> set[str]:
    return set(obs)


@pytest.mark.parametrize(
    ("obs_mode", "keys"),
    [
        ("state", {"achieved_goal", "desired_goal", "observation"}),
        ("rgb", {"achieved_goal", "desired_goal", "rgb"}),
        ("state+rgb", {"achieved_goal", "desired_goal", "observation", "rgb"}),
        ("proprio+rgb", {"desired_goal", "proprioception", "rgb"}),
    ],
)
def test_obs_modes_give_their_keys_and_pass_the_checker(obs_mode: str, keys: set[str]) -> None:
    env = gym.make(ENV_ID, obs_mode=obs_mode)
    obs, _ = env.reset(seed=0)
    assert _keys(obs) == keys == set(env.observation_space.spaces)
    assert obs in env.observation_space
    if obs_mode != "state":
        image = obs["rgb"]
        assert image.shape == (DEFAULT_IMAGE_SIZE, DEFAULT_IMAGE_SIZE, 3)
        assert image.dtype == np.uint8
        assert len(np.unique(image.reshape(-1, 3), axis=0)) > 20  # a scene, not a blank
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", ["panda_rapier/Reach-v0", "panda_rapier/StackJoints-v0"])
def test_every_task_has_image_observations(env_id: str) -> None:
    env = gym.make(env_id, obs_mode="rgb", image_size=(48, 64), cameras=TWO_CAMERAS)
    obs, _ = env.reset(seed=1)
    assert obs["front"].shape == obs["side"].shape == (48, 64, 3)
    assert not np.array_equal(obs["front"], obs["side"])
    obs, *_ = env.step(env.action_space.sample())
    assert obs in env.observation_space
    env.close()


def _rollout_images(make: Any, steps: int = 12) -> list[bytes]:
    env = make()
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    out = [obs["rgb"].tobytes()]
    for _ in range(steps):
        obs, *_ = env.step(rng.uniform(-1, 1, 4).astype(np.float32))
        out.append(obs["rgb"].tobytes())
    env.close()
    return out


def test_images_are_deterministic_and_follow_the_arm() -> None:
    first = _rollout_images(lambda: gym.make(ENV_ID, obs_mode="rgb"))
    second = _rollout_images(lambda: gym.make(ENV_ID, obs_mode="rgb"))
    assert first == second
    assert len(set(first)) > 8  # the arm moves in the pictures
    # A pickled environment (EzPickle) keeps its image options.
    clone = pickle.loads(pickle.dumps(gym.make(ENV_ID, obs_mode="rgb", image_size=32).unwrapped))
    obs, _ = clone.reset(seed=0)
    assert obs["rgb"].shape == (32, 32, 3)


def test_vector_images_match_the_single_env_for_any_threads_and_batch() -> None:
    config = env_config(ENV_ID)
    single = gym.make(ENV_ID, obs_mode="state+rgb", image_size=40)
    single_obs, _ = single.reset(seed=9)
    actions = np.random.default_rng(1).uniform(-1, 1, (8, 5, 4)).astype(np.float32)
    rows = {}
    for num_envs, threads in [(5, 1), (5, 2)]:
        envs = PandaVectorEnv(
            num_envs, num_threads=threads, obs_mode="state+rgb", image_size=40, **config
        )
        obs, _ = envs.reset(seed=9)
        assert obs["rgb"].shape == (num_envs, 40, 40, 3)
        assert obs in envs.observation_space
        np.testing.assert_array_equal(obs["rgb"][0], single_obs["rgb"])
        seen = [obs["rgb"].copy()]
        for step in actions:
            obs, *_ = envs.step(step)
            seen.append(obs["rgb"].copy())
        rows[threads] = np.stack(seen)
        envs.close()
    np.testing.assert_array_equal(rows[1], rows[2])
    # Environment 0 of the vector env follows the single env step for step.
    for t, step in enumerate(actions):
        single_obs, *_ = single.step(step[0])
        np.testing.assert_array_equal(rows[1][t + 1, 0], single_obs["rgb"])
    single.close()


def _final_image(seed: int, steps: int) -> np.ndarray:
    env = gym.make(ENV_ID, obs_mode="rgb", image_size=32, max_episode_steps=steps)
    obs, _ = env.reset(seed=seed)
    for _ in range(steps):
        obs, *_ = env.step(np.full(4, 0.5, dtype=np.float32))
    env.close()
    return obs["rgb"]


def test_final_observations_carry_the_last_image_before_the_reset() -> None:
    steps = 4
    expected = _final_image(0, steps)
    action = np.full((2, 4), 0.5, dtype=np.float32)
    envs = PandaVectorEnv(
        2,
        autoreset_mode="same_step",
        obs_mode="rgb",
        image_size=32,
        **env_config(ENV_ID, max_episode_steps=steps),
    )
    envs.reset(seed=0)
    for _ in range(steps):
        obs, _, _, truncated, infos = envs.step(action)
    assert truncated.all()
    np.testing.assert_array_equal(infos["final_obs"][0]["rgb"], expected)
    assert not np.array_equal(obs["rgb"][0], expected)  # already the next episode's first
    envs.close()

    from panda_rapier.sb3 import make_vec_env

    venv = make_vec_env(
        ENV_ID, n_envs=2, seed=0, obs_mode="rgb", image_size=32, max_episode_steps=steps
    )
    venv.reset()
    for _ in range(steps):
        obs, _, dones, sb3_infos = venv.step(action)
    assert dones.all()
    np.testing.assert_array_equal(sb3_infos[0]["terminal_observation"]["rgb"], expected)
    assert obs["rgb"].shape == (2, 32, 32, 3)
    venv.close()


def test_the_goal_marker_is_left_out_unless_asked_for() -> None:
    def image(show_goal: bool | None) -> np.ndarray:
        camera = dict(panda_rapier.pixels.DEFAULT_CAMERA)
        if show_goal is not None:
            camera["show_goal"] = show_goal
        env = gym.make(ENV_ID, obs_mode="rgb", cameras={"rgb": camera})
        obs, _ = env.reset(seed=2, options={"goal": [0.45, 0.0, 0.3]})
        env.close()
        return obs["rgb"]

    assert np.array_equal(image(None), image(False))
    assert not np.array_equal(image(None), image(True))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"obs_mode": "heat"},
        {"obs_mode": "depth", "image_size": 0},
        {"obs_mode": "rgb", "image_size": 0},
        {"obs_mode": "rgb", "image_size": (84,)},
        {"obs_mode": "rgb", "image_size": True},
        {"obs_mode": "rgb", "image_size": 5000},
        {"obs_mode": "rgb", "cameras": {}},
        {"obs_mode": "rgb", "cameras": {"observation": {}}},
        {"obs_mode": "rgb", "cameras": {"rgb": {"fov": float("nan")}}},
        {"obs_mode": "rgb", "cameras": {"rgb": {"zoom": 2}}},
        {"obs_mode": "rgb", "cameras": {"rgb": {"show_goal": "yes"}}},
        {"obs_mode": "rgb", "cameras": ["rgb"]},
        {"cameras": {"rgb": {}}},  # cameras without images
    ],
)
def test_bad_image_options_are_config_errors(kwargs: dict[str, Any]) -> None:
    with pytest.raises(ConfigError):
        gym.make(ENV_ID, **kwargs)
    with pytest.raises(ConfigError):
        PandaVectorEnv(2, **env_config(ENV_ID), **kwargs)


@pytest.mark.parametrize("env_id", [ENV_ID, "panda_rapier/StackJoints-v0"])
def test_proprio_rgb_carries_no_object_state(env_id: str) -> None:
    """Moving the cube (same seed, so the same robot state; the same goal) changes the images
    and no other entry; the proprioception is exactly the robot's slots of the state."""
    from panda_rapier import _common

    def first_steps(cube: list[float]) -> list[dict[str, np.ndarray]]:
        env = gym.make(env_id, obs_mode="proprio+rgb")
        # The same seed draws the same goal and robot state whatever the cube override.
        obs, _ = env.reset(seed=5, options={"cube_position": cube})
        out = [obs]
        action = np.zeros(env.action_space.shape, np.float32)
        for _ in range(3):
            obs, *_ = env.step(action)
            out.append(obs)
        env.close()
        return out

    a = first_steps([0.45, -0.12, 0.025])
    b = first_steps([0.58, -0.02, 0.025])
    for one, other in zip(a, b, strict=True):
        assert set(one) == {"desired_goal", "proprioception", "rgb"}
        np.testing.assert_array_equal(one["proprioception"], other["proprioception"])
        np.testing.assert_array_equal(one["desired_goal"], other["desired_goal"])
        assert not np.array_equal(one["rgb"], other["rgb"])
    state_env = gym.make(env_id, obs_mode="state")
    state, _ = state_env.reset(seed=5, options={"cube_position": [0.45, -0.12, 0.025]})
    schema = state_env.unwrapped._schema
    flat = np.concatenate([state[k] for k in _common.DICT_KEYS])
    np.testing.assert_array_equal(a[0]["proprioception"], flat[schema.source_part("robot")])
    assert a[0]["proprioception"].shape == (25,)
    state_env.close()


def test_a_model_s_image_options_are_read_off_its_space() -> None:
    from panda_rapier.agents.model_file import model_observation

    for mode in ("rgb", "state+rgb", "proprio+rgb"):
        env = gym.make(ENV_ID, obs_mode=mode, image_size=(48, 64))
        assert model_observation(env.observation_space) == {
            "obs_mode": mode,
            "image_size": (48, 64),
        }
        env.close()


def test_cameras_cannot_take_a_state_key() -> None:
    with pytest.raises(ConfigError, match="proprioception"):
        gym.make(ENV_ID, obs_mode="proprio+rgb", cameras={"proprioception": {}})


def test_the_scripted_policy_needs_the_state() -> None:
    env = gym.make(ENV_ID, obs_mode="rgb")
    obs, _ = env.reset(seed=0)
    policy = panda_rapier.ScriptedPolicy(env)
    with pytest.raises(InvalidArgumentError, match="state\\+rgb"):
        policy.predict(obs)
    env.close()
    env = gym.make(ENV_ID, obs_mode="state+rgb")
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs)
    assert action.shape == (4,)
    env.close()


def test_bench_measures_image_observations() -> None:
    from panda_rapier.tools.bench import format_report, run_benchmark

    report = run_benchmark(
        num_envs=[2],
        targets=["gym.make", "vector"],
        policies=["random"],
        rounds=1,
        env_steps=20,
        peers=False,
        image_sizes=[64],
    )
    targets = {row["target"] for row in report["results"]}
    assert targets == {"gym.make", "vector", "gym.make +rgb 64px", "vector +rgb 64px"}
    assert all(row["env_steps_per_s"] > 0 for row in report["results"])
    assert "vector +rgb 64px" in format_report(report)


def test_pixel_ppo_trains_evaluates_and_reloads(tmp_path: Path) -> None:
    """The pixel smoke run: PPO with SB3's CNN on camera images, the native VecEnv drawing
    them; the saved model is evaluated through ``evaluate`` and ``panda-rapier eval``."""
    torch = pytest.importorskip("torch")
    from stable_baselines3 import PPO
    from stable_baselines3.common.torch_layers import NatureCNN

    from panda_rapier.agents.evaluation import evaluate
    from panda_rapier.cli import main
    from panda_rapier.sb3 import make_vec_env

    torch.set_num_threads(1)
    dense = "panda_rapier/PickAndPlaceDense-v0"
    venv = make_vec_env(dense, n_envs=4, seed=0, num_threads=1, obs_mode="rgb", image_size=64)
    model = PPO("MultiInputPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, seed=0)
    assert isinstance(model.policy.features_extractor.extractors["rgb"], NatureCNN)
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(256)
    assert model.num_timesteps == 256
    after = list(model.policy.parameters())
    assert any(not torch.equal(a, b) for a, b in zip(before, after, strict=True))
    path = tmp_path / "pixel_ppo.zip"
    model.save(path)

    def run() -> list[float]:
        report = evaluate(
            model, env_config(dense), 3, num_envs=2, first_seed=5, obs_mode="rgb", image_size=64
        )
        assert len(report.episodes) == 3
        return [e.episode_return for e in report.episodes]

    first = run()
    assert first == run()  # evaluation of a pixel policy is reproducible
    assert all(np.isfinite(first))
    # A CNN policy runs on torch: loading it unpickles the file, which takes consent.
    assert main(["eval", "--policy", str(path), "--episodes", "2", "--quiet"]) == 2
    assert main(["eval", "--policy", str(path), "--episodes", "2", "--quiet",
                 "--trust-model-file"]) == 0  # fmt: skip


def test_the_pixel_examples_run(tmp_path: Path) -> None:
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    png = tmp_path / "pixels.png"
    subprocess.run(
        [sys.executable, root / "examples/pixel_observations.py", "--out", png, "--size", "32",
         "--steps", "0", "5"],
        check=True, timeout=600,
    )  # fmt: skip
    assert png.read_bytes().startswith(b"\x89PNG")
    result = subprocess.run(
        [sys.executable, root / "examples/pixel_ppo.py", "--steps", "64", "--n-envs", "2",
         "--image-size", "48", "--eval-episodes", "2", "--out", tmp_path / "run",
         "--no-progress"],
        check=True, timeout=600, capture_output=True, text=True,
    )  # fmt: skip
    assert "from 48px images" in result.stdout
    assert (tmp_path / "run" / "model.zip").is_file()


def test_visual_randomization_is_seeded_by_the_episode() -> None:
    """Randomised pictures differ from the plain ones (nothing else does), repeat for the same
    episode whatever the batch and threads, and change with the randomisation's seed."""
    options = {"obs_mode": "proprio+rgb", "image_size": 32}
    plain = gym.make(ENV_ID, **options)
    plain_obs, _ = plain.reset(seed=9)
    single = gym.make(ENV_ID, **options, visual_randomization=True)
    single_obs, _ = single.reset(seed=9)
    assert (single_obs["rgb"] != plain_obs["rgb"]).any()
    np.testing.assert_array_equal(single_obs["proprioception"], plain_obs["proprioception"])
    config = env_config(ENV_ID)
    actions = np.random.default_rng(1).uniform(-1, 1, (3, 4, 4)).astype(np.float32)
    rows = {}
    for num_envs, threads in [(4, 1), (2, 2)]:
        envs = PandaVectorEnv(
            num_envs, num_threads=threads, **options, visual_randomization=True, **config
        )
        obs, _ = envs.reset(seed=9)
        seen = [obs["rgb"][:2].copy()]
        for step in actions:
            obs, *_ = envs.step(step[:num_envs])
            seen.append(obs["rgb"][:2].copy())
        rows[num_envs] = np.stack(seen)
        envs.close()
    np.testing.assert_array_equal(rows[4], rows[2])
    np.testing.assert_array_equal(rows[4][0, 0], single_obs["rgb"])
    # Another seed, another look; no randomisation at all, the plain picture.
    other = gym.make(ENV_ID, **options, visual_randomization={"seed": 1})
    assert (other.reset(seed=9)[0]["rgb"] != single_obs["rgb"]).any()
    off = {k: 0 for k in panda_rapier.pixels.VISUAL_RANDOMIZATION}
    zero = gym.make(ENV_ID, **options, visual_randomization=off)
    np.testing.assert_array_equal(zero.reset(seed=9)[0]["rgb"], plain_obs["rgb"])


@pytest.mark.parametrize(
    "value",
    [{"colors": 1.0}, {"noise": 100}, {"hue": 0.2}, "yes", {"camera_fov": -1.0}],
)
def test_bad_visual_randomization_is_a_config_error(value: Any) -> None:
    with pytest.raises(ConfigError):
        gym.make(ENV_ID, obs_mode="rgb", visual_randomization=value)
    with pytest.raises(ConfigError, match="visual_randomization"):
        gym.make(ENV_ID, visual_randomization=True)  # state observations have no pictures


@pytest.mark.parametrize("env_id", ["panda_rapier/PickAndPlace-v0", "panda_rapier/StackJoints-v0"])
def test_flat_observations_are_the_state_dict_flattened(env_id: str) -> None:
    """``obs_mode="flat"``: the state dict's values in one vector, in Gymnasium's flattening
    order, from the single, vector and stable-baselines3 environments alike (final
    observations too); it passes Gymnasium's checker."""
    from panda_rapier.sb3 import make_vec_env

    state, flat = gym.make(env_id), gym.make(env_id, obs_mode="flat")
    assert flat.observation_space == gym.spaces.flatten_space(state.observation_space)
    rng = np.random.default_rng(0)
    obs_state, _ = state.reset(seed=5)
    obs_flat, _ = flat.reset(seed=5)
    for _ in range(4):
        assert obs_flat.dtype == np.float32 and obs_flat in flat.observation_space
        np.testing.assert_array_equal(
            obs_flat, gym.spaces.flatten(state.observation_space, obs_state)
        )
        action = rng.uniform(-1, 1, state.action_space.shape).astype(np.float32)
        obs_state, *_ = state.step(action)
        obs_flat, *_ = flat.step(action)
    check_env(flat.unwrapped, skip_render_check=True)
    state.close()
    flat.close()

    def concatenated(obs: dict[str, np.ndarray]) -> np.ndarray:
        return np.concatenate([obs[key] for key in sorted(obs)], axis=-1)

    short = env_config(env_id, max_episode_steps=3)
    vec_state = PandaVectorEnv(3, autoreset_mode="same_step", **short)
    vec_flat = PandaVectorEnv(3, autoreset_mode="same_step", obs_mode="flat", **short)
    assert vec_flat.single_observation_space == flat.observation_space
    a, _ = vec_state.reset(seed=2)
    b, _ = vec_flat.reset(seed=2)
    np.testing.assert_array_equal(b, concatenated(a))
    for _ in range(3):
        actions = rng.uniform(-1, 1, vec_state.action_space.shape).astype(np.float32)
        a, *_, info_a = vec_state.step(actions)
        b, *_, info_b = vec_flat.step(actions)
        np.testing.assert_array_equal(b, concatenated(a))
    assert info_b["_final_obs"].all()
    for i in range(3):
        np.testing.assert_array_equal(info_b["final_obs"][i], concatenated(info_a["final_obs"][i]))
    vec_state.close()
    vec_flat.close()

    sb3_state = make_vec_env(env_id, n_envs=2, seed=4)
    sb3_flat = make_vec_env(env_id, n_envs=2, seed=4, obs_mode="flat")
    np.testing.assert_array_equal(sb3_flat.reset(), concatenated(sb3_state.reset()))
    sb3_state.close()
    sb3_flat.close()
    with pytest.raises(ConfigError, match="cameras"):
        gym.make(env_id, obs_mode="flat", cameras={"rgb": {}})


def test_a_model_on_flat_observations_evaluates_in_flat_mode(tmp_path: Path) -> None:
    """A stable-baselines3 model trained on ``obs_mode="flat"`` is evaluated on flat
    observations: its space says so (``model_observation``), and ``panda-rapier eval``'s
    resolver builds that environment."""
    sb3 = pytest.importorskip("stable_baselines3")
    from panda_rapier.agents.evaluation import evaluate
    from panda_rapier.agents.inference import resolve_policy
    from panda_rapier.agents.model_file import model_observation
    from panda_rapier.sb3 import make_vec_env

    env = make_vec_env(ENV_ID, n_envs=2, seed=0, obs_mode="flat")
    assert model_observation(env.observation_space) == {"obs_mode": "flat"}
    model = sb3.PPO("MlpPolicy", env, n_steps=8, batch_size=16, n_epochs=1, seed=0, device="cpu")
    model.learn(16)
    model.save(tmp_path / "flat.zip")
    env.close()
    for inference in ("torch", "auto"):
        resolved = resolve_policy(tmp_path / "flat.zip", ENV_ID, inference=inference, trust=True)
        if inference == "torch":
            assert resolved.observation == {"obs_mode": "flat"}
        report = evaluate(resolved.policy, resolved.config, 3, num_envs=2, **resolved.observation)
        assert len(report.episodes) == 3
