"""The dynamic arm against an independent engine: the same URDF loaded in MuJoCo gives the
gravity torques that hold our arm still, the accelerations of one step, and the motion under
constant torques over many steps (issue 33: a torque used to pile up step after step)."""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import panda_rapier

mujoco = pytest.importorskip("mujoco")

URDF = Path(__file__).resolve().parents[2] / "assets" / "panda" / "panda.urdf"
HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])  # the ready pose
ARM = [f"panda_joint{i}" for i in range(1, 8)]
DT = 0.01


def _mujoco_arm() -> tuple[object, object]:
    """The bundled URDF in MuJoCo, its fingers welded open (ours are held by their drive)."""
    text = URDF.read_text()
    text = re.sub(r"<visual>.*?</visual>", "", text, flags=re.S)
    text = re.sub(
        r"(<robot[^>]*>)",
        r'\1<mujoco><compiler discardvisual="true" fusestatic="false" '
        r'balanceinertia="false"/></mujoco>',
        text,
        count=1,
    )
    model = mujoco.MjModel.from_xml_string(text)
    model.opt.timestep = DT
    # Nothing touches anything in these tests; MuJoCo must not find contacts between
    # overlapping collision shapes of non-adjacent links either.
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, i) for i in range(model.njnt)]
    assert names[:7] == ARM, names
    # Heavy armature on the fingers: they stay where they are put, as our held fingers do.
    model.dof_armature[7:] = 1e6
    return model, mujoco.MjData(model)


def _robot(**robot):
    env = gym.make("panda_rapier/PickAndPlace-v0", **({"robot": robot} if robot else {}))
    env.reset(seed=0)
    return env, env.unwrapped.robot


def _configurations(n: int, seed: int, spread: float = 0.35) -> np.ndarray:
    return HOME + np.random.default_rng(seed).uniform(-spread, spread, (n, 7))


def _gravity(model, data, q: np.ndarray) -> np.ndarray:
    data.qpos[:] = 0.0
    data.qpos[:7] = q
    data.qpos[7:9] = 0.04
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    return data.qfrc_bias[:7].copy()


def test_gravity_torques_from_mujoco_hold_the_arm_still() -> None:
    """The bar of issue 33: MuJoCo's gravity torques, held constant for 50 physics steps
    (0.5 s), keep every joint below 0.05 rad/s, from 12 configurations near home."""
    model, data = _mujoco_arm()
    env, robot = _robot()
    worst = 0.0
    for q in _configurations(12, seed=1):
        robot.set_joint_positions([*q, 0.04])
        for name, torque in zip(ARM, _gravity(model, data, q), strict=True):
            robot.torque_control(name, float(torque))
        robot.step_simulation(50)
        worst = max(worst, float(np.abs(robot.joint_velocities()[:7]).max()))
    env.close()
    assert worst < 0.05, f"fastest joint {worst} rad/s after 0.5 s"


def test_one_step_accelerations_match_mujoco() -> None:
    """From rest, zero torque and a unit torque per joint: the velocity after one physics step
    divided by the step is MuJoCo's acceleration within 0.1 % of its size (plus 0.001 rad/s^2;
    measured: 2.6e-5 relative, median of 24 configurations)."""
    model, data = _mujoco_arm()
    env, robot = _robot()
    for q in _configurations(6, seed=2):
        for probe in [None, *range(7)]:
            tau = np.zeros(7)
            if probe is not None:
                tau[probe] = 5.0
            robot.set_joint_positions([*q, 0.04])
            for name, torque in zip(ARM, tau, strict=True):
                robot.torque_control(name, float(torque))
            robot.step_simulation(1)
            ours = robot.joint_velocities()[:7] / DT
            _gravity(model, data, q)
            data.qfrc_applied[:] = 0.0
            data.qfrc_applied[:7] = tau
            mujoco.mj_forward(model, data)
            reference = data.qacc[:7]
            error = np.abs(ours - reference).max()
            assert error <= 1e-3 * np.abs(reference).max() + 1e-3, (q, probe, ours, reference)
    env.close()


def test_constant_torques_over_many_steps_follow_mujoco() -> None:
    """Gravity compensation plus a constant extra torque for 30 steps (0.3 s): the joint
    velocities follow MuJoCo's semi-implicit Euler rollout of the same torques. Before the fix
    each step added the torque again and the velocities ran away quadratically."""
    model, data = _mujoco_arm()
    env, robot = _robot()
    extra = np.array([1.0, -2.0, 0.5, 1.5, -0.3, 0.4, 0.1])
    for q in _configurations(4, seed=3):
        tau = _gravity(model, data, q) + extra
        robot.set_joint_positions([*q, 0.04])
        for name, torque in zip(ARM, tau, strict=True):
            robot.torque_control(name, float(torque))
        _gravity(model, data, q)
        data.qfrc_applied[:] = 0.0
        data.qfrc_applied[:7] = tau
        for step in range(1, 31):
            robot.step_simulation(1)
            mujoco.mj_step(model, data)
            if step % 10 == 0:
                ours, reference = robot.joint_velocities()[:7], data.qvel[:7]
                error = np.abs(ours - reference).max()
                assert error <= 0.03 * np.abs(reference).max() + 2e-3, (step, ours, reference)
    env.close()


def test_varying_torques_follow_mujoco() -> None:
    """Torques that change every step (gravity compensation plus a sinusoid per joint), 40
    steps (0.3 s; the joints reach about 1.5 rad/s): velocities within 5 % of MuJoCo's (plus
    2e-3 rad/s; measured 0.3-3.3 % over six configurations: the two first-order integrators
    part at O(dt) as the arm moves)."""
    model, data = _mujoco_arm()
    env, robot = _robot()
    q = _configurations(1, seed=8)[0]
    gravity = _gravity(model, data, q)
    robot.set_joint_positions([*q, 0.04])
    amplitude = np.array([1.0, 1.5, 0.8, 1.0, 0.3, 0.3, 0.15])
    for step in range(30):
        tau = gravity + amplitude * np.sin(0.3 * step + np.arange(7))
        for name, torque in zip(ARM, tau, strict=True):
            robot.torque_control(name, float(torque))
        data.qfrc_applied[:] = 0.0
        data.qfrc_applied[:7] = tau
        robot.step_simulation(1)
        mujoco.mj_step(model, data)
    ours, reference = robot.joint_velocities()[:7], data.qvel[:7]
    assert np.abs(ours - reference).max() <= 0.05 * np.abs(reference).max() + 2e-3
    env.close()


def test_a_snapshot_taken_under_torque_control_continues_identically() -> None:
    env, robot = _robot()
    robot.set_joint_positions([*_configurations(1, seed=9)[0], 0.04])
    for name in ARM:
        robot.torque_control(name, 2.0)
    robot.step_simulation(10)
    snapshot = env.unwrapped.snapshot()
    robot.step_simulation(10)
    straight = robot.joint_velocities()
    env.unwrapped.restore(snapshot)
    robot.step_simulation(10)
    np.testing.assert_array_equal(robot.joint_velocities(), straight)
    env.close()


def test_torque_leaves_nothing_behind_under_position_control() -> None:
    """After a torque run, position control holds the arm where a fresh start holds it."""
    env, robot = _robot()
    q = _configurations(1, seed=4)[0]
    robot.set_joint_positions([*q, 0.04])
    for name in ARM:
        robot.torque_control(name, 3.0)
    robot.step_simulation(5)
    robot.set_joint_positions([*q, 0.04])
    for name, target in zip(ARM, q, strict=True):
        robot.position_control(name, float(target))
    robot.step_simulation(100)
    after_torque = robot.joint_positions()[:7]
    fresh_env, fresh = _robot()
    fresh.set_joint_positions([*q, 0.04])
    for name, target in zip(ARM, q, strict=True):
        fresh.position_control(name, float(target))
    fresh.step_simulation(100)
    np.testing.assert_allclose(after_torque, fresh.joint_positions()[:7], atol=1e-5)
    env.close()
    fresh_env.close()


def test_model_dynamics_match_mujoco() -> None:
    """robot.gravity_torques, inverse_dynamics (Coriolis included), mass_matrix and jacobian
    against MuJoCo's qfrc_bias, mj_fullM and mj_jac on the same URDF, at 10 states."""
    model, data = _mujoco_arm()
    env, robot = _robot()
    rng = np.random.default_rng(5)
    hand = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "panda_hand")
    for q in _configurations(10, seed=6, spread=0.8):
        full_q = [*q, 0.04]
        qd = rng.uniform(-1.0, 1.0, 7)
        reference = _gravity(model, data, q)
        ours = robot.gravity_torques(full_q)[:7]
        np.testing.assert_allclose(ours, reference, rtol=1e-6, atol=1e-6 * np.abs(reference).max())
        data.qvel[:7] = qd
        mujoco.mj_forward(model, data)
        coriolis = robot.inverse_dynamics(full_q, [*qd, 0.0], np.zeros(8))[:7]
        np.testing.assert_allclose(
            coriolis, data.qfrc_bias[:7], atol=1e-6 * np.abs(reference).max()
        )
        mass = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, mass)
        ours_m = robot.mass_matrix(full_q)
        assert np.linalg.norm(ours_m[:7, :7] - mass[:7, :7]) <= 1e-6 * np.linalg.norm(mass[:7, :7])
        assert np.allclose(ours_m, ours_m.T) and np.all(np.linalg.eigvalsh(ours_m) > 0)
        point = np.array([0.01, -0.02, 0.1])
        world = data.xpos[hand] + data.xmat[hand].reshape(3, 3) @ point
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jac(model, data, jacp, jacr, world, hand)
        ours_j = robot.jacobian("panda_hand", point, full_q)
        np.testing.assert_allclose(ours_j[:3, :7], jacp[:, :7], atol=1e-9)
        np.testing.assert_allclose(ours_j[3:, :7], jacr[:, :7], atol=1e-9)
    env.close()


def test_gravity_compensation_with_the_models_own_torques() -> None:
    """The README's example: robot.gravity_torques() applied with torque_control holds the
    arm (every joint below 0.05 rad/s after 0.5 s), and the Jacobian maps joint velocities
    to the TCP's velocity."""
    env, robot = _robot()
    q = [*_configurations(1, seed=7)[0], 0.04]
    robot.set_joint_positions(q)
    for name, torque in zip(ARM, robot.gravity_torques()[:7], strict=True):
        robot.torque_control(name, float(torque))
    robot.step_simulation(50)
    assert np.abs(robot.joint_velocities()[:7]).max() < 0.05
    jacobian = robot.jacobian()  # the TCP, at the current q
    assert jacobian.shape == (6, 8)
    env.close()


def test_passive_joint_terms_are_explicit() -> None:
    """No damping or friction that nobody configured: the bundled URDF has no <dynamics>, so
    both are 0; robot.joint_damping / joint_friction set them, and joint_info reports them."""
    env, robot = _robot()
    movable = [j for j in robot.joint_info() if j["type"] != "fixed"]
    assert movable and all(j["damping"] == 0.0 and j["friction"] == 0.0 for j in movable)
    env.close()
    env, robot = _robot(joint_damping=0.2, joint_friction=0.05)
    info = {j["name"]: j for j in robot.joint_info()}
    assert info["panda_joint7"]["damping"] == 0.2 and info["panda_joint7"]["friction"] == 0.05
    assert info["panda_hand_joint"]["damping"] == 0.0
    env.close()
    with pytest.raises(panda_rapier.ConfigError, match="joint_damping"):
        _robot(joint_damping=-1.0)
