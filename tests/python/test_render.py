"""Rendering: rgb_array frames (size, content, determinism), the vector env's tiles, typed
errors, the human-mode window under Xvfb, and videos written by ``panda-rapier eval``."""

from __future__ import annotations

import itertools
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import panda_rapier
from panda_rapier import ConfigError, DisplayError

ENV_ID = "panda_rapier/PickAndPlace-v0"
JOINTS_ID = "panda_rapier/PickAndPlaceJoints-v0"
CAMERA = {"target": [0.45, 0.05, 0.1], "distance": 1.5, "azimuth": 35.0, "elevation": 30.0}


def project(point: np.ndarray, width: int, height: int, fov: float = 45.0) -> tuple[int, int]:
    """Pixel (column, row) of a world point seen by CAMERA: the renderer's look-at camera."""
    target = np.array(CAMERA["target"])
    az, el = np.radians(CAMERA["azimuth"]), np.radians(CAMERA["elevation"])
    eye = target + CAMERA["distance"] * np.array(
        [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)]
    )
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(point) - eye
    focal = height / 2 / np.tan(np.radians(fov) / 2)
    depth = d @ forward
    return (
        int(width / 2 + focal * (d @ right) / depth),
        int(height / 2 - focal * (d @ up) / depth),
    )


def window(frame: np.ndarray, column: int, row: int, radius: int) -> np.ndarray:
    return frame[
        max(row - radius, 0) : row + radius + 1, max(column - radius, 0) : column + radius + 1
    ]


def is_cube_colour(pixels: np.ndarray) -> np.ndarray:
    r, g, b = (pixels[..., k].astype(int) for k in range(3))
    return (r > 100) & (r > 2 * g) & (r > 2 * b)


def test_rgb_array_frames_have_the_requested_size() -> None:
    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert isinstance(frame, np.ndarray)
    assert frame.shape == (480, 720, 3) and frame.dtype == np.uint8
    env.close()
    env = gym.make(ENV_ID, render_mode="rgb_array", width=320, height=200)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (200, 320, 3) and frame.dtype == np.uint8
    # Not a blank picture: sky, floor, robot and cube make many colours.
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 50
    env.close()


def test_the_cube_and_the_robot_are_where_they_should_be() -> None:
    width, height = 640, 480
    env = gym.make(ENV_ID, render_mode="rgb_array", width=width, height=height, camera=CAMERA)
    obs, _ = env.reset(seed=5)
    frame = env.render()
    cube = obs["achieved_goal"]
    column, row = project(cube, width, height)
    assert is_cube_colour(window(frame, column, row, 3)).mean() > 0.8
    # Cube-coloured pixels exist only around the cube (nothing else in the scene is red).
    rows, columns = np.nonzero(is_cube_colour(frame))
    assert len(rows) > 50
    assert np.abs(rows - row).max() < 40 and np.abs(columns - column).max() < 40
    # The hand (a box reaching 5.8 cm below its frame, pointing down) is dark grey among the
    # light links, floor and sky.
    hand = env.unwrapped.robot.link_state("panda_hand")["position"]
    column, row = project(np.asarray(hand) - np.array([0.0, 0.0, 0.03]), width, height)
    patch = window(frame, column, row, 3).astype(int)
    assert (patch.max(axis=-1) < 95).mean() > 0.5, patch
    # Move the cube: the red pixels follow it.
    obs, _ = env.reset(seed=5, options={"cube_position": [0.35, -0.25, 0.025]})
    moved = env.render()
    column, row = project(obs["achieved_goal"], width, height)
    assert is_cube_colour(window(moved, column, row, 3)).mean() > 0.8
    env.close()


def test_the_frame_changes_when_the_arm_moves() -> None:
    env = gym.make(JOINTS_ID, render_mode="rgb_array", width=320, height=240)
    env.reset(seed=1)
    before = env.render()
    action = np.zeros(8, dtype=np.float32)
    action[0] = 1.0  # swing the base joint
    for _ in range(5):
        env.step(action)
    after = env.render()
    changed = np.any(before != after, axis=-1).mean()
    assert changed > 0.005, changed
    env.close()


def test_the_same_state_gives_the_same_bytes() -> None:
    def frames(seed: int) -> list[bytes]:
        env = gym.make(ENV_ID, render_mode="rgb_array", width=240, height=160)
        obs, _ = env.reset(seed=seed)
        policy = panda_rapier.ScriptedPolicy(env)
        out = [env.render().tobytes()]
        for _ in range(20):
            action, _ = policy.predict(obs)
            obs, *_ = env.step(action)
            out.append(env.render().tobytes())
        env.close()
        return out

    first, second = frames(3), frames(3)
    assert first == second
    assert len(set(first)) > 10  # the scene moves
    # Restoring a saved state redraws the saved picture.
    env = gym.make(ENV_ID, render_mode="rgb_array", width=240, height=160)
    env.reset(seed=3)
    state = env.unwrapped.snapshot()
    saved = env.render().tobytes()
    env.step(np.ones(4, dtype=np.float32))
    assert env.render().tobytes() != saved
    env.unwrapped.restore(state)
    assert env.render().tobytes() == saved
    env.close()


def test_vector_env_renders_env_zero_or_tiles() -> None:
    kwargs = {"vectorization_mode": "vector_entry_point", "render_mode": "rgb_array"}
    envs = gym.make_vec(ENV_ID, num_envs=4, width=160, height=120, **kwargs)
    envs.reset(seed=0)
    single = envs.render()
    assert single.shape == (120, 160, 3) and single.dtype == np.uint8
    envs.close()
    tiled_envs = gym.make_vec(ENV_ID, num_envs=4, width=160, height=120, render_envs=3, **kwargs)
    tiled_envs.reset(seed=0)
    tiled = tiled_envs.render()
    assert tiled.shape == (240, 320, 3)
    assert np.array_equal(tiled[:120, :160], single)
    assert not np.array_equal(tiled[:120, 160:], single)  # another cube position
    assert not tiled[120:, 160:].any()  # the grid's empty cell
    tiled_envs.close()


@pytest.mark.parametrize(
    "kwargs",
    [
        {"width": 0},
        {"height": 10**6},
        {"width": 320.5},
        {"width": True},
        {"camera": {"fov": 0.0}},
        {"camera": {"fov": float("nan")}},
        {"camera": {"zoom": 2.0}},
        {"camera": {"eye": CAMERA["target"], "target": CAMERA["target"]}},
        {"camera": {"eye": [1.0, 1.0, 1.0], "distance": 2.0}},
        {"camera": {"elevation": 120.0}},
        {"camera": "top"},
        {"render_mode": "rgb"},
    ],
)
def test_bad_render_options_are_config_errors(kwargs: dict) -> None:
    kwargs = {"render_mode": "rgb_array", **kwargs}
    if kwargs["render_mode"] == "rgb_array":  # gym.make itself warns about unknown modes
        with pytest.raises(ConfigError):
            gym.make(ENV_ID, **kwargs)
    with pytest.raises(ConfigError):
        panda_rapier.PandaEnv(**kwargs)
    with pytest.raises(ConfigError):
        panda_rapier.PandaVectorEnv(2, **kwargs)


def test_vector_env_render_envs_must_fit() -> None:
    for bad in (0, 3, 1.5):
        with pytest.raises(ConfigError, match="render_envs"):
            panda_rapier.PandaVectorEnv(2, render_mode="rgb_array", render_envs=bad)


def test_a_straight_down_camera_draws_without_nan() -> None:
    camera = {"elevation": 90.0, "distance": 1.2}
    env = gym.make(ENV_ID, render_mode="rgb_array", width=64, height=48, camera=camera)
    env.reset(seed=0)
    assert env.render().shape == (48, 64, 3)
    env.close()


def test_human_mode_without_a_display_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(DisplayError, match="rgb_array"):
        gym.make(ENV_ID, render_mode="human")


def _start_xvfb() -> tuple[subprocess.Popen, str]:
    read, write = os.pipe()
    xvfb = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", "800x600x24", "-nolisten", "tcp"],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write)
    with os.fdopen(read) as pipe:
        number = pipe.readline().strip()
    if not number:
        xvfb.kill()
        pytest.fail("Xvfb did not report a display number")
    return xvfb, f":{number}"


def read_xwd(data: bytes) -> np.ndarray:
    """An X window dump (``xwd``: a TrueColor ZPixmap of 24 or 32 bits per pixel) as HxWx3."""
    header = np.frombuffer(data[:100], dtype=">u4").astype(np.int64)
    header_size, width, height = header[0], header[4], header[5]
    byte_order, bits_per_pixel, bytes_per_line = header[7], header[11], header[12]
    masks, ncolors = header[14:17], header[19]
    assert bits_per_pixel in (24, 32), bits_per_pixel
    step = bits_per_pixel // 8
    offset = header_size + 12 * ncolors
    raw = np.frombuffer(data[offset : offset + height * bytes_per_line], dtype=np.uint8)
    rows = raw.reshape(height, bytes_per_line)[:, : width * step].reshape(height, width, step)
    weights = 256 ** np.arange(step) if byte_order == 0 else 256 ** np.arange(step)[::-1]
    pixels = (rows.astype(np.int64) * weights).sum(axis=-1)
    channels = []
    for mask in masks:
        shift = (int(mask) & -int(mask)).bit_length() - 1
        channels.append(((pixels & int(mask)) >> shift).astype(np.uint8))
    return np.stack(channels, axis=-1)


HUMAN_SCRIPT = textwrap.dedent(
    """
    import subprocess, sys
    import gymnasium as gym
    import numpy as np
    import panda_rapier

    out, display = sys.argv[1], sys.argv[2]
    kwargs = dict(width=320, height=240)
    human = gym.make("panda_rapier/PickAndPlace-v0", render_mode="human", **kwargs)
    reference = gym.make("panda_rapier/PickAndPlace-v0", render_mode="rgb_array", **kwargs)
    obs, _ = human.reset(seed=4)
    reference.reset(seed=4)
    policy = panda_rapier.ScriptedPolicy(human)
    for _ in range(12):
        action, _ = policy.predict(obs)
        obs, *_ = human.step(action)
        reference.step(action)
    assert human.render() is None
    shot = subprocess.run(["xwd", "-root", "-silent", "-display", display],
                          capture_output=True, check=True).stdout
    with open(out + ".xwd", "wb") as f:
        f.write(shot)
    np.save(out + ".npy", reference.render())
    human.close()
    """
)


@pytest.mark.skipif(
    shutil.which("Xvfb") is None or shutil.which("xwd") is None,
    reason="needs Xvfb and xwd (apt-get install xvfb x11-apps; scripts/test installs them)",
)
def test_human_mode_shows_the_scene_in_a_window(tmp_path: Path) -> None:
    xvfb, display = _start_xvfb()
    try:
        env = {**os.environ, "DISPLAY": display, "SDL_VIDEO_WINDOW_POS": "0,0"}
        env.pop("WAYLAND_DISPLAY", None)
        out = str(tmp_path / "shot")
        result = subprocess.run(
            [sys.executable, "-c", HUMAN_SCRIPT, out, display],
            env=env, capture_output=True, text=True, timeout=120, check=False,
        )  # fmt: skip
        assert result.returncode == 0, result.stderr
    finally:
        xvfb.terminate()
        xvfb.wait(timeout=10)
    screen = read_xwd(Path(out + ".xwd").read_bytes())
    reference = np.load(out + ".npy")
    assert screen.shape == (600, 800, 3)
    shown = screen[:240, :320]
    # The window holds exactly the frame rgb_array gives for the same state ...
    assert np.all(shown == reference, axis=-1).mean() > 0.99
    # ... with the cube in it, and nothing but the X server's black beside it.
    assert is_cube_colour(shown).sum() > 20
    assert not screen[300:, 400:].any()


def console_script() -> str:
    script = Path(sys.executable).parent / "panda-rapier"
    assert script.is_file()
    return str(script)


def read_video(path: Path) -> list[np.ndarray]:
    import imageio.v2 as imageio

    with imageio.get_reader(str(path), format="FFMPEG") as reader:
        return [np.asarray(frame) for frame in reader]


@pytest.mark.parametrize(
    ("extra", "episodes_recorded", "size"),
    [([], 1, (720, 480)), (["--num-envs", "1", "--video-size", "320x240"], 2, (320, 240))],
)
def test_eval_writes_a_video(
    tmp_path: Path, extra: list[str], episodes_recorded: int, size: tuple[int, int]
) -> None:
    out = tmp_path / "out.mp4"
    result = subprocess.run(
        [console_script(), "eval", "--policy", "scripted", "--episodes", "2", "--quiet",
         "--video", str(out), *extra],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    frames = read_video(out)
    # Environment 0's episodes: the first state and one frame per step (70 steps each).
    assert len(frames) == episodes_recorded * 71
    assert f"{len(frames)} frames written" in result.stdout
    width, height = size
    assert frames[0].shape == (height, width, 3)
    differences = [np.abs(a.astype(int) - b).mean() for a, b in itertools.pairwise(frames)]
    assert sum(d > 0.05 for d in differences) > len(frames) // 3
    assert np.abs(frames[0].astype(int) - frames[40]).mean() > 0.5


def test_video_size_is_checked() -> None:
    result = subprocess.run(
        [console_script(), "eval", "--episodes", "1", "--video", "x.mp4", "--video-size", "0x10"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert result.returncode == 2 and "video-size" in result.stderr


def test_the_readme_pictures_script_writes_a_png(tmp_path: Path) -> None:
    out = tmp_path / "stills.png"
    script = Path(__file__).resolve().parents[2] / "examples" / "render_scripted.py"
    subprocess.run(
        [sys.executable, str(script), "--out", str(out), "--width", "96", "--height", "64"],
        check=True, capture_output=True, timeout=120,
    )  # fmt: skip
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert (width, height) == (4 * 96, 64)


def test_render_after_close_is_a_reset_needed_error() -> None:
    env = panda_rapier.PandaEnv(render_mode="rgb_array", width=32, height=24)
    env.close()
    with pytest.raises(panda_rapier.ResetNeededError, match="closed"):
        env.render()
    envs = panda_rapier.PandaVectorEnv(2, render_mode="rgb_array", width=32, height=24)
    envs.close()
    with pytest.raises(panda_rapier.ResetNeededError, match="closed"):
        envs.render()


def test_sb3_vec_env_renders_and_vec_video_recorder_writes_a_video(tmp_path: Path) -> None:
    pytest.importorskip("moviepy")  # the render extra
    from stable_baselines3.common.vec_env import VecVideoRecorder

    from panda_rapier.sb3 import make_vec_env

    venv = make_vec_env(ENV_ID, n_envs=4, seed=0, render_mode="rgb_array", width=96, height=64)
    venv.reset()
    images = venv.get_images()
    assert len(images) == 4 and all(i.shape == (64, 96, 3) and i.dtype == np.uint8 for i in images)
    assert not np.array_equal(images[0], images[1])  # another cube position
    np.testing.assert_array_equal(venv.render(), images[0])
    np.testing.assert_array_equal(venv.render("rgb_array"), images[0])
    with pytest.raises(panda_rapier.InvalidArgumentError, match="render_mode='rgb_array'"):
        venv.render("human")
    # The same seed gives the same bytes.
    again = make_vec_env(ENV_ID, n_envs=4, seed=0, render_mode="rgb_array", width=96, height=64)
    again.reset()
    np.testing.assert_array_equal(again.get_images()[3], images[3])
    again.close()
    recorder = VecVideoRecorder(
        venv, str(tmp_path), record_video_trigger=lambda step: step == 0, video_length=10
    )
    recorder.reset()
    for _ in range(12):
        recorder.step(np.zeros((4, 4), np.float32))
    recorder.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
    tiled = make_vec_env(ENV_ID, n_envs=4, render_mode="rgb_array", width=96, height=64,
                         render_envs=4)  # fmt: skip
    tiled.reset()
    assert tiled.render().shape == (128, 192, 3)
    tiled.close()
    plain = make_vec_env(ENV_ID, n_envs=2)
    assert plain.get_images() == [None, None]
    with pytest.warns(UserWarning, match="render_mode"):
        assert plain.render() is None
    with pytest.raises(ConfigError, match="render_envs"):
        make_vec_env(ENV_ID, n_envs=2, render_mode="rgb_array", render_envs=3)
    with pytest.raises(ConfigError, match="render_mode"):
        make_vec_env(ENV_ID, n_envs=2, render_mode="rgb")


def test_gymnasium_record_video_on_gym_make(tmp_path: Path) -> None:
    pytest.importorskip("moviepy")  # the render extra
    from gymnasium.wrappers import RecordVideo

    env = gym.make(ENV_ID, render_mode="rgb_array", width=96, height=64)
    folder = tmp_path / "videos"  # RecordVideo warns about a folder that already exists
    env = RecordVideo(env, str(folder), episode_trigger=lambda episode: episode == 0)
    env.reset(seed=0)
    for _ in range(panda_rapier.MAX_EPISODE_STEPS):
        env.step(env.action_space.sample())
    env.reset()  # ends the recorded episode
    env.close()
    videos = list(folder.glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
