"""The single-instance Gymnasium environment."""

from __future__ import annotations

from typing import Any, cast

import gymnasium as gym
import numpy as np
from gymnasium.utils import EzPickle

from . import _common, _native
from .errors import InvalidArgumentError
from .pixels import DEFAULT_IMAGE_SIZE, observation_spec
from .rendering import DEFAULT_HEIGHT, DEFAULT_WIDTH, RENDER_MODES, FrameSource
from .robot import Robot


class PandaEnv(_common.NativeBacked, gym.Env[dict[str, np.ndarray], np.ndarray], EzPickle):
    """A Franka Panda manipulation task; by default it picks a cube off the floor and places it
    on a platform.

    ## Tasks
    The ``task`` option (each registered id sets it): a task's name, or its section of the
    configuration, ``task={"name": "push", "goal_region": {"low": [0.4, 0.1], "high": [0.6,
    0.2]}}``, whose fields (regions, ranges) are the task's own; fields left out keep their
    defaults. ``panda_rapier.registration.TASKS`` lists every task with its defaults.

    - ``"pick_and_place"`` (``PickAndPlace*`` ids, the default): described below.
    - ``"reach"`` (``Reach*``): move the TCP to a goal in the air, uniform in the box
      ``goal_region``; no objects; ``achieved_goal`` is the TCP position, the observation
      has the robot's 25 entries; dense reward ``1 - tanh(5 d)``; 50 steps.
    - ``"lift"`` (``Lift*``): the cube to a goal ``goal_height`` above its start; no platform;
      pick-and-place's observation and rewards.
    - ``"push"`` (``Push*``): push the cube along the floor to a goal in ``goal_region``,
      fingers closed; no platform; pick-and-place's observation; dense reward reach + carry.
    - ``"stack"`` (``Stack*``): one cube on the goal on the platform, the other on top;
      6-D goals (both cubes), 57-entry observation (both cubes' slots); 150 steps.
    - ``"slide"`` (``Slide*``): slide the cube over a slippery floor (``floor_friction``
      0.04) to a goal beyond the arm's reach; pick-and-place's observation; 100 steps.
    - ``"flip"`` (``Flip*``): turn the cube to a uniformly random goal orientation (panda-gym's
      PandaFlip); 4-D goals (quaternions x, y, z, w), success within ``angle_threshold``
      (0.927 rad, panda-gym's criterion), ``goal_distance`` the angle; dense reward reach +
      ``orient`` ``(q . g)^2``; ``reset(options={"goal": rotation_vector})``; 200 steps.

    Before 0.2 the tasks' fields were top-level options (``pick_region``,
    ``reach_goal_region``, ``lift_height``, ``push_goal_region``, ``goal_air_probability``,
    ...). They still work, each with a ``FutureWarning`` naming the new spelling, until 0.3.

    ``env.unwrapped.schema`` lists every observation slot and info key of the task. The rest
    of this text describes pick-and-place; the core's ``env-core/src/task/<task>.rs`` documents
    each task's observation table, start state and rewards.

    ## Description
    A Panda on a fixed base, a 5 cm cube on the floor in front of it and a raised platform to
    its left, simulated by rapier3d (multibody arm with torque-limited joint motors, friction
    grasp: the fingers hold the cube by contact forces alone). The goal is a point on the
    platform (optionally in the air, the task's ``goal_air_probability``); the cube must be
    carried there and, for ``is_placed``, released at rest.

    Two fidelity levels: ``arm="dynamic"`` (default) simulates the arm's dynamics: its joints
    are motors with the Panda's torque limits that track the commanded targets against
    gravity, inertia and contacts. ``arm="kinematic"`` (Fetch-style; about a fifth fewer
    instructions per step than the dynamic arm) places the arm's links along the commanded joint
    trajectory (velocity limits, ``robot.motors.kinematic_acceleration``), so they push whatever
    they touch with unlimited force; the gripper (hand and fingers, with the same coupled
    force-limited drive) and the cube stay fully dynamic and the grasp is still held by
    friction alone. A motion that would take a kinematic arm link into the floor or the
    platform is refused (the arm stops; ``info["arm_blocked"]``).

    ## Image observations
    ``obs_mode="rgb"`` adds camera images to the observation dict and drops the state vector
    (``observation``); ``"state+rgb"`` keeps both; ``"state"`` (default) has no images. Each
    camera gives a uint8 ``(height, width, 3)`` image drawn on the CPU at ``image_size`` (an
    int, default 84, or ``(height, width)``), under its key in ``cameras`` (default
    ``{"rgb": panda_rapier.pixels.DEFAULT_CAMERA}``; camera options as for ``camera`` below,
    plus ``show_goal``, default False). ``achieved_goal`` and ``desired_goal`` stay, for
    ``compute_reward`` and hindsight relabelling (``achieved_goal`` is the object's position:
    drop it, e.g. with ``gymnasium.wrappers.FilterObservation``, for a policy that must see the
    object only in pictures, or use ``"proprio+rgb"``: the images, the robot's own state as
    ``proprioception`` (joint positions and velocities, TCP position and velocity, gripper
    width) and ``desired_goal``, nothing of the object's state). Images are bit-identical for
    the same state. ``visual_randomization=True`` (or a dict of ranges,
    :data:`panda_rapier.pixels.VISUAL_RANDOMIZATION`) jitters the cameras, light and colours
    per episode and adds pixel noise per frame, seeded by the episode. SB3's
    ``MultiInputPolicy`` takes them as they are (it transposes images for its CNN).
    Depth (float32 metres along the optical axis, ``<key>_depth``), segmentation ids
    (``<key>_segmentation``; :attr:`segmentation_ids` names them) and point clouds
    (``<key>_points``) come with modes such as ``"depth"``, ``"rgbd"``, ``"proprio+rgbd"`` or
    ``"state+segmentation+points"`` (:data:`panda_rapier.pixels.MODALITIES`; the guide's
    *Depth, segmentation and point clouds*).
    Any mode but ``"flat"`` followed by ``"+touch"`` (``"state+touch"``,
    ``"proprio+rgb+touch"``) adds ``touch``: the hand's finger contact forces and wrist
    force-torque reading as float32 ``(14,)`` (:data:`panda_rapier.pixels.TOUCH_LAYOUT`;
    the same values as :meth:`Robot.touch <panda_rapier.Robot.touch>`; the guide's *Touch*).

    ## Action Space
    ``Box(-1, 1, (4,), float32)`` with ``control_mode="ee"`` (default): TCP displacement x, y, z
    times ``ee_step`` (0.05 m) through inverse kinematics, hand pointing down, and the gripper
    (-1 squeezes, +1 opens fully). ``Box(-1, 1, (8,), float32)`` with ``control_mode="joints"``:
    the 7 arm joints' displacements times ``joint_step`` (0.05 rad) and the gripper.
    ``Box(-1, 1, (7,), float32)`` with ``control_mode="ee_pose"``: TCP displacement x, y, z times
    ``ee_step``, a rotation vector times ``ee_rot_step`` (0.1 rad), and the gripper, in the
    robot base's frame (``ee_frame="base"``, default) or the hand's (``ee_frame="hand"``),
    applied to the measured TCP pose through inverse kinematics. Targets are limited by the
    joints' velocity limits; actions outside [-1, 1] are clipped. ``ee_controller="osc"``
    drives ``ee`` and ``ee_pose`` actions by an operational-space controller (joint torques
    from the TCP's pose error through the arm's dynamics; gains in ``osc``, e.g.
    ``osc={"position_stiffness": 150.0, "orientation_stiffness": 150.0, "damping_ratio": 1.0,
    "null_space_stiffness": 10.0}``) instead of inverse kinematics (``"ik"``, the default).

    ## Observation Space
    ``Dict(achieved_goal: (3,), desired_goal: (3,), observation: (41,))``, float32: the cube's
    position, the goal, and joint positions (9) and velocities (9), TCP position and velocity,
    gripper width, cube position, orientation (quaternion xyzw, w >= 0), linear and angular
    velocity, and the cube relative to the TCP. ``obs_mode="flat"``: the same values as one
    ``Box(-1000, 1000, (47,), float32)`` vector (for this task) in that key order (what
    ``gymnasium.wrappers.FlattenObservation`` makes of the dict, without its copy per step),
    for learners that take plain vectors, such as RLlib's default encoders.

    ## Rewards
    ``reward_type="sparse"`` (default): -1 until the cube is within ``success_threshold``
    (0.05 m) of the goal, 0 within it. ``"dense"``: reach 1 + grasp 1 + lift 1 + carry 2 +
    place 5 + release 0, each term in the info as ``reward_*``; the weights are options
    (``reward_weights={"grasp": 0.5, "release": 1.0}``; ``release`` pays the commanded gripper
    opening while the cube is at the goal, off by default). :meth:`compute_reward` recomputes
    either from goals and infos, batched, for hindsight experience replay.

    ## Starting State
    The arm in its ready pose (optionally with ``randomization.joint_noise``), the cube in the
    task's ``cube_region`` with a yaw in ``cube_yaw_range``, the goal in ``goal_region``.
    ``reset(options=...)`` overrides ``cube_position``, ``cube_yaw``, ``goal`` or
    ``joint_positions``.

    ## Episode End
    Terminated on success only with ``terminate_on_success=True``. Truncated by the
    ``TimeLimit`` that ``gym.make`` adds (70 steps at 25 Hz, 2.8 s), or, when constructed
    directly, after ``max_episode_steps`` if given; and at once when the physics becomes
    unstable (``info["physics_unstable"]``, after which ``step`` raises until ``reset``).

    Why 70 and not the 50 of Fetch and panda-gym: the arm is torque-limited, its joint targets
    respect the URDF velocity limits, and joint actions move a joint at most 0.05 rad per step.
    The scripted baseline places the cube in 99.3 % (ee) and 99.7 % (joints) of 1,000 seeded
    episodes within 70 steps (mean 37 and 53 steps), but only 96.8 % (ee) and 25.2 % (joints)
    within 50.

    ## Arguments
    Every field of the configuration (see the core's ``EnvConfig``) as a keyword argument,
    nested ones as dicts: ``arm``, ``control_mode``, ``reward_type``, ``max_episode_steps``,
    ``control_frequency``, ``success_threshold``, ``terminate_on_success``, ``task``,
    ``randomization``, ``physics``, ``robot``, ... Unknown or invalid values raise
    :class:`~panda_rapier.ConfigError`.

    ## Rendering
    ``render_mode="rgb_array"``: :meth:`render` returns an HxWx3 uint8 frame drawn on the CPU
    (no GPU or display needed), ``width`` x ``height`` pixels (default 720 x 480), from
    ``camera``: a dict with ``target``, ``distance``, ``azimuth``, ``elevation`` (degrees, an
    orbit like PyBullet's debug camera) or ``eye`` instead of the orbit, and ``fov`` (vertical,
    degrees). ``render_mode="human"``: a window (pygame, the ``render`` extra) updated on every
    ``reset`` and ``step`` at real-time pace; without a display it raises
    :class:`~panda_rapier.DisplayError`.

    ## Determinism
    ``reset(seed=s)`` makes everything that follows a function of ``s`` and the actions:
    bit-identical across runs, processes and machines with the same build.

    ## Version History
    - v0: initial release.
    """

    metadata: dict[str, Any] = {"render_modes": list(RENDER_MODES), "render_fps": 25}  # noqa: RUF012

    def __init__(
        self,
        render_mode: str | None = None,
        *,
        width: int = DEFAULT_WIDTH,
        height: int = DEFAULT_HEIGHT,
        camera: dict[str, Any] | None = None,
        obs_mode: str = "state",
        image_size: int | tuple[int, int] = DEFAULT_IMAGE_SIZE,
        cameras: dict[str, dict[str, Any]] | None = None,
        visual_randomization: bool | dict[str, Any] | None = None,
        **config: Any,
    ) -> None:
        EzPickle.__init__(
            self,
            render_mode=render_mode,
            width=width,
            height=height,
            camera=camera,
            obs_mode=obs_mode,
            image_size=image_size,
            cameras=cameras,
            visual_randomization=visual_randomization,
            **config,
        )
        self._frames: FrameSource | None = None
        # gym.make keeps time with a TimeLimit wrapper; the env counts only when asked to.
        config.setdefault("max_episode_steps", None)
        self._bind_native(_native.PandaEnv(_common.config_json(config), 0))
        self._obs = observation_spec(
            self._schema,
            obs_mode,
            image_size,
            cameras,
            visual_randomization,
            config_json=self._native.config_json(),
        )
        self._cameras = (
            _native.Cameras(self._obs.cameras_json, self._obs.touch)
            if self._obs.has_sensors
            else None
        )
        # gymnasium types a Dict space's elements as dict[str, Space], not the observations.
        self.observation_space = cast("gym.spaces.Space[dict[str, np.ndarray]]", self._obs.space())
        self.action_space = _common.action_space(self._native.action_dim)
        self._action_shape = (int(self._native.action_dim),)
        self.metadata = {**type(self).metadata, "render_fps": round(1.0 / self._native.dt)}
        self.robot = Robot(self)
        # Last, so a window is opened only for an otherwise valid environment.
        self._frames = FrameSource(render_mode, width, height, camera, float(self._native.dt))
        self.render_mode = render_mode

    @property
    def goal(self) -> np.ndarray:
        """The current goal position."""
        return np.asarray(self._native.goal(), dtype=np.float64)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        native_seed = _common.as_seed(seed)
        # Gymnasium's seeding takes Python ints only; numpy integers were validated above.
        super().reset(seed=native_seed)
        options_json = None
        if options:
            if not isinstance(options, dict):
                raise InvalidArgumentError(f"options must be a dict, got {type(options).__name__}")
            options_json = _common.config_json(options)
        flat, info = self._native.reset(native_seed, options_json)
        if self.render_mode == "human":
            self.render()
        return self._observation(flat), info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        flat, reward, terminated, truncated, info = self._native.step(
            _common.as_actions(action, self._action_shape)
        )
        if self.render_mode == "human":
            self.render()
        return self._observation(flat), reward, terminated, truncated, info

    def _observation(self, flat: np.ndarray) -> dict[str, np.ndarray]:
        images = None if self._cameras is None else self._cameras.observe(self._native)
        return self._obs.assemble(flat, images)

    def snapshot(self) -> _native.EnvSnapshot:
        """An opaque copy of the whole state (physics, random stream, goal, clock)."""
        return self._native.snapshot()

    def restore(self, snapshot: _native.EnvSnapshot) -> None:
        """Returns to a state from :meth:`snapshot` (of this environment or one with the same
        configuration); stepping on continues bit-identically."""
        self._native.restore(snapshot)

    def save_state(self) -> _native.EnvSnapshot:
        """The name before 0.2 of :meth:`snapshot` (removed in 0.3.0)."""
        _warn_renamed("PandaEnv.save_state", "PandaEnv.snapshot")
        return self.snapshot()

    def restore_state(self, snapshot: _native.EnvSnapshot) -> None:
        """The name before 0.2 of :meth:`restore` (removed in 0.3.0)."""
        _warn_renamed("PandaEnv.restore_state", "PandaEnv.restore")
        self.restore(snapshot)

    # Gymnasium < 1.3 (ray[rllib] pins 1.2.2) types Env.render with an unbound TypeVar.
    def render(self) -> np.ndarray | None:  # type: ignore[override, unused-ignore]
        """The current state as an HxWx3 uint8 frame (``rgb_array``), or shown in the window
        (``human``, returns None). The same state always gives the same bytes."""
        if self.render_mode is None or self._frames is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to gym.make.")
            return None
        if isinstance(self._native, _common.Closed):
            self._native.check()
        return self._frames.output(self._frames.renderer.render_env(self._native))

    def close(self) -> None:
        frames = getattr(self, "_frames", None)  # None, or absent if __init__ raised early
        if frames is not None:
            frames.close()
        self._native = _common.Closed("environment")


def _warn_renamed(old: str, new: str) -> None:
    import warnings

    warnings.warn(
        f"{old} is renamed {new} and will be removed in {_common.OLD_NAMES_REMOVED_IN}",
        FutureWarning,
        stacklevel=3,
    )


#: The name before tasks were added (``PickAndPlaceEnv``), with a ``FutureWarning``.
__getattr__ = _common.renamed("panda_rapier.env", {"PickAndPlaceEnv": PandaEnv})
