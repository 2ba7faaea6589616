"""The Franka Panda of one environment, from Python: the classic PyBullet tutorial's
``getJointInfo`` / ``getLinkState`` / ``setJointMotorControl2`` / ``calculateInverseKinematics``,
with names instead of magic indices and typed errors instead of silent garbage."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from .errors import InvalidArgumentError

JointControl = Literal["position", "velocity", "torque"]


class Robot:
    """The robot of a :class:`~panda_rapier.PandaEnv` (``env.unwrapped.robot``).

    Changing the robot's state (``set_joint_positions``, ``step_simulation``) refreshes the
    environment's observation. ``env.step`` sets its own joint targets, overriding controls set
    here; use the controls with ``step_simulation`` for tutorial-style manual control.
    """

    def __init__(self, owner: Any) -> None:
        self._owner = owner

    @property
    def _native(self) -> Any:
        return self._owner._native

    @property
    def num_dofs(self) -> int:
        """Entries of the configuration ``q``: 7 arm joints and the gripper (the second finger
        mimics the first)."""
        return int(self._native.num_dofs)

    def joint_info(self) -> list[dict[str, Any]]:
        """Every joint (fixed ones included), in URDF order: ``index``, ``name``, ``type``
        (revolute, prismatic, continuous, fixed), ``lower``, ``upper`` (rad or m), ``max_force``
        (N m or N), ``max_velocity``, ``axis``, ``parent_link``, ``child_link``, ``dof`` (entry
        of ``q`` driven by the joint, or None), ``mimic`` (index of the joint it copies) and the
        passive ``damping`` (N m s/rad or N s/m) and ``friction`` (N m or N) the simulation
        applies (the URDF's ``<dynamics>``, or the ``robot`` options ``joint_damping`` /
        ``joint_friction``)."""
        return list(self._native.joint_info())

    def link_names(self) -> list[str]:
        """Link names in URDF order."""
        return list(self._native.link_names())

    def link_state(self, name: str) -> dict[str, Any]:
        """World ``position``, ``orientation`` (quaternion x, y, z, w), ``linear_velocity``,
        ``angular_velocity``, and ``mass``, ``friction``, ``num_colliders`` of a link."""
        return dict(self._native.link_state(str(name)))

    def joint_positions(self) -> np.ndarray:
        """The configuration ``q`` (rad, and m for the gripper)."""
        return np.asarray(self._native.joint_states()[0])

    def joint_velocities(self) -> np.ndarray:
        """Velocities of the entries of ``q``."""
        return np.asarray(self._native.joint_states()[1])

    def set_joint_positions(self, q: Sequence[float] | np.ndarray) -> None:
        """Teleports the robot to ``q`` at rest (clamped into the limits); position control
        then holds it."""
        self._native.set_joint_positions(_floats(q, "q"))

    def position_control(
        self,
        joint: int | str,
        target: float,
        *,
        target_velocity: float = 0.0,
        max_force: float | None = None,
    ) -> None:
        """Drives ``joint`` (index or name) to ``target`` with its motor, at most ``max_force``
        (default: the joint's effort limit)."""
        self._native.set_joint_control(
            joint, "position", float(target), float(target_velocity), max_force
        )

    def velocity_control(
        self, joint: int | str, target: float, *, max_force: float | None = None
    ) -> None:
        """Drives ``joint`` at ``target`` velocity."""
        self._native.set_joint_control(joint, "velocity", float(target), 0.0, max_force)

    def torque_control(self, joint: int | str, torque: float) -> None:
        """Applies ``torque`` (N m, or N for the fingers; clamped to the effort limit) with the
        motor switched off."""
        self._native.set_joint_control(joint, "torque", float(torque), 0.0, None)

    def step_simulation(self, steps: int = 1) -> None:
        """Advances the physics by ``steps`` solver steps with the current controls."""
        if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 0:
            raise InvalidArgumentError(f"steps must be an int >= 0, got {steps!r}")
        self._native.step_simulation(int(steps))

    def forward_kinematics(
        self, q: Sequence[float] | np.ndarray
    ) -> dict[str, tuple[list[float], list[float]]]:
        """World ``(position, quaternion xyzw)`` of every link and of ``"tcp"`` (the point
        between the fingertips) for configuration ``q``; the simulation is not touched."""
        return dict(self._native.forward_kinematics(_floats(q, "q")))

    def inverse_dynamics(
        self,
        q: Sequence[float] | np.ndarray | None = None,
        qd: Sequence[float] | np.ndarray | None = None,
        qdd: Sequence[float] | np.ndarray | None = None,
    ) -> np.ndarray:
        """Joint torques ``M(q) qdd + C(q, qd) qd + g(q)`` (N m; N for the gripper entry, both
        fingers together) of the rigid-body model under the simulation's gravity, by recursive
        Newton-Euler: PyBullet's ``calculateInverseDynamics``. ``q`` and ``qd`` default to the
        current state, ``qdd`` to zeros. Joint damping, friction and armature are not included
        (none is configured by default)."""
        q_ = _floats(self.joint_positions() if q is None else q, "q")
        qd_ = _floats(self.joint_velocities() if qd is None else qd, "qd")
        qdd_ = _floats(np.zeros(self.num_dofs) if qdd is None else qdd, "qdd")
        return np.asarray(self._native.inverse_dynamics(q_, qd_, qdd_))

    def gravity_torques(self, q: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """The torques that hold the robot still at ``q`` (default: the current one): apply
        them with :meth:`torque_control` for gravity compensation."""
        return self.inverse_dynamics(q, np.zeros(self.num_dofs), np.zeros(self.num_dofs))

    def mass_matrix(self, q: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """The joint-space mass matrix ``M(q)`` (``num_dofs x num_dofs``; default: the
        current ``q``): PyBullet's ``calculateMassMatrix``."""
        q_ = _floats(self.joint_positions() if q is None else q, "q")
        return np.asarray(self._native.mass_matrix(q_))

    def jacobian(
        self,
        link: str = "tcp",
        point: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        q: Sequence[float] | np.ndarray | None = None,
    ) -> np.ndarray:
        """The world-frame Jacobian (``6 x num_dofs``: linear velocity rows, then angular) of
        ``point`` in the frame of ``link`` (default: the tool centre point) at ``q`` (default:
        the current one): PyBullet's ``calculateJacobian``, both parts in one matrix."""
        p = _floats(point, "point")
        if len(p) != 3:
            raise InvalidArgumentError(f"point must have 3 values, got {len(p)}")
        q_ = _floats(self.joint_positions() if q is None else q, "q")
        return np.asarray(self._native.jacobian(str(link), (p[0], p[1], p[2]), q_))

    def inverse_kinematics(
        self,
        position: Sequence[float] | np.ndarray,
        orientation: Sequence[float] | np.ndarray | None = None,
        *,
        q_start: Sequence[float] | np.ndarray | None = None,
        max_iterations: int = 100,
    ) -> dict[str, Any]:
        """A configuration whose TCP reaches ``position`` (and ``orientation``, quaternion
        x, y, z, w, when given), starting from ``q_start`` (default: the current ``q``).

        Returns ``q``, ``position_error`` (m), ``orientation_error`` (rad), ``iterations`` and
        ``converged``; unreachable targets return the closest configuration found with
        ``converged=False``.
        """
        target = _floats(position, "position")
        if len(target) != 3:
            raise InvalidArgumentError(f"position must have 3 values, got {len(target)}")
        quaternion = None
        if orientation is not None:
            quaternion = _floats(orientation, "orientation")
            if len(quaternion) != 4:
                raise InvalidArgumentError(
                    f"orientation must be a quaternion (x, y, z, w), got {len(quaternion)} values"
                )
        start = None if q_start is None else _floats(q_start, "q_start")
        return dict(self._native.inverse_kinematics(target, quaternion, start, int(max_iterations)))

    def touch(self) -> dict[str, Any]:
        """What the hand felt over the last control step (or the last ``step_simulation``
        call's steps), from its contact impulses: means over its physics steps, in N:

        - ``finger_normal_forces``: each finger's summed normal contact force (N, 2 values;
          the driving joint's finger first), over all its contacts (objects, floor, platform).
        - ``finger_forces``: each finger's summed contact force vector, normal and friction
          (N, world frame, ``(2, 3)``).
        - ``wrist_force`` (N) and ``wrist_torque`` (N m): the wrist force-torque reading, the
          wrench the hand, its fingers and what they hold exert on the arm (Newton-Euler on
          the hand subtree over those steps: weight, inertia and outside contacts), in the
          hand frame, the torque about the hand frame's origin (the flange). A still, empty
          hand reads its own weight, pointing down.
        - ``hand_mass``: the mass of that subtree (kg; attached objects included).

        The ``obs_mode`` suffix ``"+touch"`` puts the same values in the observation
        (:data:`panda_rapier.pixels.TOUCH_LAYOUT`)."""
        raw = dict(self._native.touch())
        return {
            "finger_normal_forces": np.asarray(raw["finger_normal_forces"]),
            "finger_forces": np.asarray(raw["finger_forces"]),
            "wrist_force": np.asarray(raw["wrist_force"]),
            "wrist_torque": np.asarray(raw["wrist_torque"]),
            "hand_mass": float(raw["hand_mass"]),
        }

    def object_state(self, name: str = "cube") -> dict[str, Any]:
        """World ``position``, ``orientation`` (xyzw) and velocities of the scene's object
        ``name`` (pick-and-place has one, ``"cube"``)."""
        return dict(self._native.object_state(str(name)))


def _floats(values: Any, what: str) -> list[float]:
    array = np.asarray(values)
    if array.ndim != 1 or array.dtype.kind not in "fiu":
        raise InvalidArgumentError(f"{what} must be a 1-D sequence of numbers, got {values!r}")
    return [float(v) for v in array]
