"""Objects this project did not make: PyBullet's own URDF object files (`pybullet_data`, from
the `pybullet` package) drawn by PickObject. Each loads (meshes by relative path, `_vhacd`
files taken as their hulls, primitives, the file's mass); set down as its file has it, it
settles (an object standing on an edge topples) and then rests without drifting or sinking
(< 1 mm in 2 s); dropped, it falls and settles; the expert picks up and places those that fit
the gripper; a URDF with a moving joint is refused naming the joint. (PyBullet's duck is
refused as ungraspable: 8.3 x 7.7 x 5.8 cm with nothing narrower than the fingers open.)"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from panda_rapier import AssetError
from panda_rapier.agents.evaluation import evaluate
from panda_rapier.agents.inference import resolve_policy

pybullet_data = pytest.importorskip("pybullet_data")
DATA = Path(pybullet_data.getDataPath())

#: Files of pybullet_data, by what they exercise: a `_vhacd` mesh (the teddy), a mesh with a
#: separate collision mesh (the mug, the domino), boxes and a sphere (lego, jenga, the small
#: cube and sphere), and procedurally made objects of many hulls (random_urdfs).
FILES = [
    "teddy_vhacd.urdf",
    "objects/mug.urdf",
    "domino/domino.urdf",
    "lego/lego.urdf",
    "jenga/jenga.urdf",
    "cube_small.urdf",
    "sphere_small.urdf",
    "random_urdfs/001/001.urdf",
    "random_urdfs/003/003.urdf",
    "random_urdfs/006/006.urdf",
]

#: Those the expert picks up and places (seeds 7000-7015: all 16 of each).
PICKABLE = [
    "lego/lego.urdf",
    "jenga/jenga.urdf",
    "cube_small.urdf",
    "domino/domino.urdf",
    "random_urdfs/001/001.urdf",
    "random_urdfs/007/007.urdf",
    "random_urdfs/009/009.urdf",
]

STILL = 50  # control steps of 0.04 s: 2 s


def pick_object(*files: str) -> gym.Env:
    return gym.make(
        "panda_rapier/PickObject-v0",
        task={"name": "pick_object", "objects": [str(DATA / f) for f in files]},
    )


def hold_still(env: gym.Env, steps: int) -> dict[str, np.ndarray]:
    """Steps with zero actions (the arm holds still), returning the last observation."""
    for _ in range(steps):
        obs, *_ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    return obs


@pytest.mark.parametrize("name", FILES)
def test_pybullet_objects_settle_and_rest_on_the_floor_without_drifting(name: str) -> None:
    env = pick_object(name)
    env.reset(seed=0)
    settled = hold_still(env, STILL)
    rested = hold_still(env, STILL)
    moved = np.abs(rested["achieved_goal"] - settled["achieved_goal"])
    assert moved.max() < 1e-3, (name, moved)
    env.close()


def test_a_pybullet_object_dropped_falls_and_settles() -> None:
    env = pick_object("jenga/jenga.urdf")
    obs, _ = env.reset(seed=1, options={"cube_position": [0.5, -0.1, 0.15]})
    assert obs["achieved_goal"][2] > 0.1
    obs = hold_still(env, STILL)
    half_height = obs["observation"][43]
    # On the floor (its centre a half height up, give or take a tilt) and at rest.
    assert obs["achieved_goal"][2] < 2 * half_height + 1e-3
    assert np.linalg.norm(obs["observation"][32:35]) < 1e-2
    env.close()


def test_the_expert_picks_up_pybullet_objects_that_fit_the_gripper() -> None:
    overrides = {"task": {"name": "pick_object", "objects": [str(DATA / f) for f in PICKABLE]}}
    resolved = resolve_policy("scripted", "panda_rapier/PickObject-v0", overrides=overrides)
    report = evaluate(resolved.policy, resolved.config, 32, num_envs=8, first_seed=7000)
    stats = report.statistics()
    assert stats["placed_rate"] >= 0.9, stats["success_by_episode"]


HINGED = """<robot name="hinged">
  <link name="a"><collision><geometry><box size="0.03 0.03 0.03"/></geometry></collision></link>
  <link name="b">
    <inertial><mass value="0.1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
    <collision><geometry><box size="0.03 0.03 0.03"/></geometry></collision>
  </link>
  <joint name="lid" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def test_a_urdf_with_a_moving_joint_is_refused_by_name(tmp_path: Path) -> None:
    urdf = tmp_path / "hinged.urdf"
    urdf.write_text(HINGED)
    with pytest.raises(AssetError, match=r"task.objects\[0\].*lid.*revolute"):
        gym.make("panda_rapier/PickObject-v0", task={"name": "pick_object", "objects": [str(urdf)]})


def test_a_urdf_with_a_missing_mesh_names_the_file(tmp_path: Path) -> None:
    urdf = tmp_path / "ghost.urdf"
    urdf.write_text(
        '<robot name="ghost"><link name="a"><collision><geometry>'
        '<mesh filename="meshes/ghost.obj"/></geometry></collision></link></robot>'
    )
    with pytest.raises(AssetError, match=r"ghost.obj"):
        gym.make("panda_rapier/PickObject-v0", task={"name": "pick_object", "objects": [str(urdf)]})
