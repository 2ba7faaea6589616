"""Computed-torque control of the dynamic arm in torque mode: the model's inverse dynamics
(``robot.inverse_dynamics``) turns a desired joint acceleration, corrected by a PD term on the
tracking error, into joint torques, every physics step (100 Hz).

    python examples/computed_torque.py --seconds 2

prints the largest joint tracking error of a smooth trajectory around the ready pose, with and
without the model (PD alone, the same gains), and the gravity-compensation hold.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import panda_rapier  # noqa: F401  (registers the ids)

ARM = [f"panda_joint{i}" for i in range(1, 8)]
AMPLITUDE = np.array([0.3, 0.2, 0.3, 0.3, 0.4, 0.3, 0.5])
FREQUENCY = 0.5  # Hz


def desired(t: float, home: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration of the reference trajectory at time t."""
    w = 2 * np.pi * FREQUENCY
    ramp = np.sin(w * t)
    return (
        home + AMPLITUDE * (1 - np.cos(w * t)) / 2,
        AMPLITUDE * w * ramp / 2,
        AMPLITUDE * w * w * np.cos(w * t) / 2,
    )


def track(seconds: float, use_model: bool, kp: float = 400.0, kd: float = 40.0) -> float:
    """Largest joint error (rad) while tracking the trajectory for `seconds`."""
    env = gym.make("panda_rapier/PickAndPlace-v0")
    env.reset(seed=0)
    robot = env.unwrapped.robot
    home = robot.joint_positions()[:7].copy()
    gripper = robot.joint_positions()[7]
    dt = 0.01  # one physics step
    worst = 0.0
    for step in range(int(seconds / dt)):
        q, qd = robot.joint_positions(), robot.joint_velocities()
        q_d, qd_d, qdd_d = desired(step * dt, home)
        error, rate = q_d - q[:7], qd_d - qd[:7]
        worst = max(worst, float(np.abs(error).max()))
        command = qdd_d + kp * error + kd * rate
        if use_model:
            torques = robot.inverse_dynamics(q, qd, [*command, 0.0])[:7]
        else:
            torques = command  # PD alone: no model (unit inertia, no gravity compensation)
        for name, torque in zip(ARM, torques, strict=True):
            robot.torque_control(name, float(torque))
        robot.position_control("panda_finger_joint1", float(gripper))
        robot.step_simulation(1)
    env.close()
    return worst


def hold(seconds: float) -> float:
    """Fastest joint (rad/s) after holding the ready pose on gravity compensation alone."""
    env = gym.make("panda_rapier/PickAndPlace-v0")
    env.reset(seed=0)
    robot = env.unwrapped.robot
    for name, torque in zip(ARM, robot.gravity_torques()[:7], strict=True):
        robot.torque_control(name, float(torque))
    robot.step_simulation(int(seconds / 0.01))
    speed = float(np.abs(robot.joint_velocities()[:7]).max())
    env.close()
    return speed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0)
    args = parser.parse_args()
    with_model = track(args.seconds, use_model=True)
    without = track(args.seconds, use_model=False)
    print(f"computed torque: max tracking error {with_model * 1e3:.2f} mrad")
    print(f"PD alone:        max tracking error {without * 1e3:.2f} mrad")
    print(f"gravity compensation: fastest joint {hold(args.seconds):.4f} rad/s")


if __name__ == "__main__":
    main()
