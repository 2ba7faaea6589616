"""The robot from Python: introspection, state, control and kinematics agree with each other."""

from __future__ import annotations

import numpy as np
import pytest

from panda_rapier import PandaEnv


@pytest.fixture
def env() -> PandaEnv:
    env = PandaEnv()
    env.reset(seed=0)
    return env


def test_joint_info_is_the_urdf_table(env: PandaEnv) -> None:
    joints = env.robot.joint_info()
    names = [j["name"] for j in joints]
    assert names[:7] == [f"panda_joint{i}" for i in range(1, 8)]
    first = joints[0]
    assert set(first) >= {
        "index", "name", "type", "lower", "upper", "max_force", "max_velocity",
        "axis", "parent_link", "child_link",
    }  # fmt: skip
    assert first["type"] == "revolute" and first["parent_link"] == "panda_link0"
    assert first["lower"] == pytest.approx(-2.8973) and first["max_force"] == pytest.approx(87.0)
    fingers = [j for j in joints if j["type"] == "prismatic"]
    assert len(fingers) == 2 and fingers[1]["mimic"] == fingers[0]["index"]
    assert env.robot.num_dofs == 8


def test_forward_kinematics_matches_the_simulated_links(env: PandaEnv) -> None:
    q = env.robot.joint_positions()
    poses = env.robot.forward_kinematics(q)
    for name in ("panda_link3", "panda_hand", "panda_leftfinger"):
        np.testing.assert_allclose(
            poses[name][0], env.robot.link_state(name)["position"], atol=2e-3
        )


def test_inverse_kinematics_round_trip(env: PandaEnv) -> None:
    target = [0.45, -0.1, 0.25]
    down = [1.0, 0.0, 0.0, 0.0]
    solution = env.robot.inverse_kinematics(target, down)
    assert solution["converged"] and solution["position_error"] < 1e-5
    np.testing.assert_allclose(
        env.robot.forward_kinematics(solution["q"])["tcp"][0], target, atol=1e-5
    )
    far = env.robot.inverse_kinematics([3.0, 0.0, 0.3])
    assert not far["converged"] and far["position_error"] > 1.0


def test_teleport_and_controls_move_the_robot(env: PandaEnv) -> None:
    q = env.robot.joint_positions()
    q[0] = 0.3
    env.robot.set_joint_positions(q)
    np.testing.assert_allclose(env.robot.joint_positions()[0], 0.3, atol=1e-6)
    obs = env.robot._owner._native.current()[0]
    assert obs[6] == pytest.approx(0.3, abs=1e-6)  # the observation follows the teleport
    env.robot.position_control("panda_joint1", -0.2)
    env.robot.step_simulation(100)
    assert env.robot.joint_positions()[0] == pytest.approx(-0.2, abs=0.02)
    env.robot.velocity_control(0, 0.5)
    env.robot.step_simulation(50)
    assert env.robot.joint_velocities()[0] == pytest.approx(0.5, abs=0.05)
    before = env.robot.joint_positions()[6]
    env.robot.torque_control("panda_joint7", 5.0)
    env.robot.step_simulation(20)
    assert env.robot.joint_positions()[6] > before + 0.01
    cube = env.robot.object_state("cube")
    assert len(cube["position"]) == 3 and len(cube["orientation"]) == 4
