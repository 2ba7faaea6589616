"""PickObject: objects drawn from a set (the shipped ones by name, a user's mesh files by
path), what the observation says about each, and clear errors for bad objects."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from panda_rapier import AssetError, ConfigError, PandaEnv

SHIPPED = ["can", "bottle", "bowl", "mug", "banana", "tennis_ball", "block", "hammer"]


def box_obj(path: Path, half: tuple[float, float, float], bad: str = "") -> Path:
    """A closed box mesh with its base on z = 0, centred on the z axis."""
    hx, hy, hz = half
    corners = [(x, y, z) for z in (0.0, 2 * hz) for y in (-hy, hy) for x in (-hx, hx)]
    faces = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    lines = [f"v {x} {y} {z}" for x, y, z in corners]
    if bad:
        lines[0] = f"v {bad} 0 0"
    lines += [f"f {a} {b} {c} {d}" for a, b, c, d in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def object_slots(obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The object slots of a PickObject observation (after the robot's 25 entries)."""
    o = obs["observation"]
    return {
        "half_extents": o[41:44],
        "grasp_position": o[44:47],
        "grasp_direction": o[47:49],
        "grasp_width": o[49:50],
    }


def test_a_user_mesh_file_is_drawn_with_the_shipped_objects(tmp_path: Path) -> None:
    box = box_obj(tmp_path / "box.obj", (0.02, 0.03, 0.025))
    env = gym.make(
        "panda_rapier/PickObject-v0",
        task={"name": "pick_object", "objects": [str(box), {"path": str(box), "mass": 0.2}]},
    )
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        slots = object_slots(obs)
        np.testing.assert_allclose(slots["half_extents"], [0.02, 0.03, 0.025], atol=1e-6)
        # Grasped across its 4 cm side, the direction as cos and sin of twice the yaw.
        np.testing.assert_allclose(slots["grasp_width"], [0.04], atol=1e-3)
        assert abs(np.hypot(*slots["grasp_direction"]) - 1.0) < 1e-5
        # The goal is for the box's centre resting on the platform (top at 0.1 m).
        assert obs["desired_goal"][2] == pytest.approx(0.125, abs=1e-6)
    env.close()


def test_the_observation_follows_the_object_drawn() -> None:
    env = gym.make("panda_rapier/PickObject-v0", task={"name": "pick_object", "objects": SHIPPED})
    heights = set()
    for seed in range(12):
        obs, _ = env.reset(seed=seed)
        slots = object_slots(obs)
        heights.add(round(float(slots["half_extents"][2]), 4))
        assert np.all(np.isfinite(obs["observation"]))
        # Resting as its file has it: the centre half its height above the floor.
        assert obs["achieved_goal"][2] == pytest.approx(slots["half_extents"][2], abs=2e-3)
        # The grasp lies within the object's box, seen from above.
        offset = slots["grasp_position"][:2] - obs["achieved_goal"][:2]
        assert np.linalg.norm(offset) <= np.linalg.norm(slots["half_extents"][:2]) + 1e-6
    assert len(heights) >= 4, heights
    env.close()


@pytest.mark.parametrize(
    ("objects", "error", "match"),
    [
        ([], ConfigError, "task.objects.*at least one"),
        (["teapot"], ConfigError, r"task.objects\[0\].*no shipped object.*can, bottle"),
        ([{"path": "{missing}"}], AssetError, r"task.objects\[0\].*cannot be read"),
        (["can", {"path": "{box}", "mass": 0.0}], ConfigError, r"task.objects\[1\].mass"),
        ([{"path": "{box}", "friction": -1.0}], ConfigError, r"task.objects\[0\].friction"),
        ([{"path": "{box}", "scale": 0.0}], ConfigError, r"task.objects\[0\].scale"),
        ([{"path": "{box}", "collision": "exact"}], ConfigError, r"task.objects\[0\].collision"),
        ([{"path": "{nan}"}], AssetError, "not finite"),
        ([{"path": "{empty}"}], AssetError, "no triangles"),
        ([{"path": "{wide}"}], ConfigError, "cannot grasp it from above"),
        ([{"path": "{box}", "colour": "red"}], ConfigError, "unknown field `colour`"),
        ([7], ConfigError, "shipped object's name, a mesh file's path or a map"),
    ],
)
def test_bad_objects_are_clear_errors(
    tmp_path: Path, objects: list[object], error: type[Exception], match: str
) -> None:
    files = {
        "{missing}": str(tmp_path / "missing.obj"),
        "{box}": str(box_obj(tmp_path / "box.obj", (0.02, 0.02, 0.02))),
        "{nan}": str(box_obj(tmp_path / "nan.obj", (0.02, 0.02, 0.02), bad="nan")),
        "{empty}": str(tmp_path / "empty.obj"),
        "{wide}": str(box_obj(tmp_path / "wide.obj", (0.1, 0.1, 0.05))),
    }
    (tmp_path / "empty.obj").write_text("# nothing\n")
    resolved = [
        {k: files.get(v, v) for k, v in o.items()} if isinstance(o, dict) else o for o in objects
    ]
    with pytest.raises(error, match=match):
        PandaEnv(task={"name": "pick_object", "objects": resolved})
