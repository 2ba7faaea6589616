"""Image observations (``obs_mode="rgb"``, ``"state+rgb"``, ``"proprio+rgb"``, and depth,
segmentation and point clouds: ``"depth"``, ``"rgbd"``, ``"proprio+rgb+segmentation"``,
...): what the cameras of the CPU renderer see, in the observation dict, for the single,
vector and stable-baselines3 environments; and touch (``"state+touch"``,
``"proprio+rgb+touch"``, ...: :data:`TOUCH_SUFFIX`), the hand's contact forces.

Every environment class reads its observation layout from one :class:`ObservationSpec`: the
state keys the task's schema gives, plus each camera's entries: a uint8 ``(height, width, 3)``
colour image under the camera's key, a float32 ``(height, width, 1)`` depth image under
``<key>_depth``, a uint8 ``(height, width, 1)`` segmentation image under
``<key>_segmentation``, a point cloud under ``<key>_points`` (with ``_points_mask``, and
``_points_rgb`` / ``_points_segmentation`` when the mode has colour / segmentation), as the
mode asks (:data:`MODALITIES`).
``"proprio+rgb"`` is what a policy without privileged state sees: the images, the robot's own
state (``proprioception``: the slots the native schema marks ``robot``) and the commanded goal
(``desired_goal``); nothing of the simulator's object state, not even ``achieved_goal``.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from . import _common, _native
from .errors import ConfigError

#: The observation modes: the state vector (default), camera images with the goals, both, or
#: camera images with the robot's own state and the commanded goal only (no object state); and
#: ``"flat"``: the state dict's entries in one float32 vector (``achieved_goal``,
#: ``desired_goal``, ``observation``, as ``gymnasium.wrappers.FlattenObservation`` lays out
#: the ``"state"`` dict), for learners that take a plain ``Box`` (RLlib's default encoders),
#: without a flattening step per observation.
#:
#: Beyond colour (:data:`MODALITIES`), an image mode is ``[state+|proprio+]`` followed by one or
#: more of ``rgb``, ``depth``, ``segmentation``, ``points``, in that order, joined by ``+``
#: (``rgbd`` stands for ``rgb+depth``): ``"depth"``, ``"rgbd"``, ``"state+depth"``,
#: ``"proprio+rgbd"``, ``"rgb+segmentation+points"``, ... Without a prefix the dict holds the
#: two goals, as ``"rgb"`` does.
MODALITIES = ("rgb", "depth", "segmentation", "points")

#: The prefixes of the image modes: the goals alone, the whole state, or the robot's own state
#: with the commanded goal.
_PREFIXES = ("", "state+", "proprio+")


def _modality_sets() -> list[tuple[str, ...]]:
    """Every non-empty subset of :data:`MODALITIES`, in their order."""
    return [
        tuple(m for bit, m in enumerate(MODALITIES) if mask >> bit & 1)
        for mask in range(1, 1 << len(MODALITIES))
    ]


def _mode_name(modalities: tuple[str, ...]) -> str:
    """The mode string of ``modalities``, with ``rgbd`` for colour and depth."""
    name = "+".join(modalities)
    return "rgbd" + name[len("rgb+depth") :] if name.startswith("rgb+depth") else name


#: Every image mode (see :data:`MODALITIES`) by its prefix and modalities: the mode string
#: names a layout once (``rgb+depth`` is spelled ``rgbd``).
_IMAGE_MODES: dict[str, tuple[str, tuple[str, ...]]] = {
    prefix + _mode_name(modalities): (prefix.rstrip("+"), modalities)
    for prefix in _PREFIXES
    for modalities in _modality_sets()
}

#: Every ``obs_mode``: the five above first, then the image modes with depth, segmentation or
#: point clouds.
OBS_MODES = (
    "state",
    "rgb",
    "state+rgb",
    "proprio+rgb",
    "flat",
    *(mode for mode in _IMAGE_MODES if mode not in ("rgb", "state+rgb", "proprio+rgb")),
)

#: The suffix that adds the hand's touch reading to the dict (``"state+touch"``,
#: ``"rgb+touch"``, ``"proprio+rgbd+touch"``: any mode of :data:`OBS_MODES` but ``"flat"``):
#: a float32 ``(14,)`` entry under :data:`TOUCH_KEY`, laid out as :data:`TOUCH_LAYOUT` says,
#: the mean over each control step of the contacts and the hand's motion (``Robot.touch``).
TOUCH_SUFFIX = "+touch"

#: The observation key of the touch entry.
TOUCH_KEY = "touch"

#: Where each part of the touch entry sits (defined once, in Rust: ``TouchReading::LAYOUT``):
#: ``finger_normal_forces`` (2: each finger's summed normal contact force, N),
#: ``finger_forces`` (6: each finger's summed contact force vector, normal and friction, N,
#: world frame, first finger first), ``wrist_force`` (3, N) and ``wrist_torque`` (3, N m):
#: the wrench the hand, its fingers and what they hold exert on the arm, in the hand frame,
#: the torque about the hand frame's origin (the flange); a still, empty hand reads its
#: weight, pointing down. Values are clamped to ``+-1000``.
TOUCH_LAYOUT: dict[str, slice] = {
    str(name): slice(int(start), int(start) + int(count))
    for name, start, count in _native.TOUCH_LAYOUT
}

#: Depth images' value where nothing nearer is drawn (m): depths lie in ``[0, DEPTH_FAR]``.
DEPTH_FAR = float(_native.DEPTH_FAR)

#: The default number of points of a point cloud (a camera's ``points`` option).
DEFAULT_POINTS = 1024

#: The key of the robot's own state in ``"proprio+rgb"`` observations.
PROPRIOCEPTION_KEY = "proprioception"

#: Keys a camera cannot take: the state entries of every mode.
RESERVED_KEYS = (*_common.DICT_KEYS, PROPRIOCEPTION_KEY)

#: The options that choose what an observation holds, as every environment class takes them;
#: the others configure the simulation (:func:`split_options`).
OBSERVATION_OPTIONS = ("obs_mode", "image_size", "cameras", "visual_randomization")

#: The ranges of ``visual_randomization=True`` (half-widths of uniform draws; the renderer's
#: ``VisualRandomization``). Each episode's camera pose, light and colours are drawn from the
#: episode's goal and ``seed``, each frame's noise from that and the step: the same episode
#: looks the same whatever the batch or threads.
#:
#: - ``camera_position``: the eye and the point looked at each move up to this along every
#:   axis (m; at most 0.2)
#: - ``camera_fov``: the field of view changes up to this (degrees; at most 20)
#: - ``light_direction``: each component of the direction towards the light, (0.4, 0.3, 1.0)
#:   before normalising, moves up to this (at most 0.9)
#: - ``light_intensity``: ambient and sun light scaled within ``1 +- x`` (below 1)
#: - ``colors``: each colour channel of each object, the floor's tiles and the platform scaled
#:   within ``1 +- x`` (below 1)
#: - ``noise``: every channel of every pixel moves by a uniform integer in ``[-noise, noise]``
#:   each frame (at most 64)
#: - ``seed``: the seed of the draws (another seed, other looks)
VISUAL_RANDOMIZATION: dict[str, Any] = {
    "camera_position": 0.02,
    "camera_fov": 2.0,
    "light_direction": 0.3,
    "light_intensity": 0.2,
    "colors": 0.15,
    "noise": 6,
    "seed": 0,
}

#: The randomisations by what they change, as ``panda-rapier eval --visual-randomization`` and
#: the robustness table (:func:`randomization_of`) name them; ``seed`` belongs to none.
RANDOMIZATION_GROUPS: dict[str, tuple[str, ...]] = {
    "camera": ("camera_position", "camera_fov"),
    "light": ("light_direction", "light_intensity"),
    "colors": ("colors",),
    "noise": ("noise",),
}


def randomization_of(name: str) -> dict[str, Any] | None:
    """The ``visual_randomization`` value a name stands for: ``"off"`` (``None``), ``"all"``
    (:data:`VISUAL_RANDOMIZATION`) or one of :data:`RANDOMIZATION_GROUPS` (its ranges at their
    defaults, every other range 0)."""
    if name == "off":
        return None
    if name == "all":
        return dict(VISUAL_RANDOMIZATION)
    if name not in RANDOMIZATION_GROUPS:
        raise ConfigError(
            f"unknown visual randomisation {name!r}; known: off, all, "
            + ", ".join(RANDOMIZATION_GROUPS)
        )
    return {
        k: (v if k in RANDOMIZATION_GROUPS[name] or k == "seed" else type(v)(0))
        for k, v in VISUAL_RANDOMIZATION.items()
    }


#: Default image size (pixels, square), a common size for pixel-based RL (Atari's 84x84).
DEFAULT_IMAGE_SIZE = 84

#: The default observation camera: in front of the robot, looking down at the pick region and
#: the platform, with the gripper in the picture up to about 0.4 m above the floor. Defined once,
#: in Rust (``CameraConfig::OBSERVATION``); its set options, here.
DEFAULT_CAMERA: dict[str, Any] = {
    key: value
    for key, value in json.loads(_native.observation_camera_json()).items()
    if value is not None
}

#: A second camera, from the robot's left side (pass both in ``cameras`` for two views).
SIDE_CAMERA: dict[str, Any] = {
    "target": [0.42, 0.05, 0.18],
    "distance": 1.2,
    "azimuth": 100.0,
    "elevation": 30.0,
    "fov": 48.0,
}

#: The default ``cameras``: one camera whose image is the ``rgb`` entry.
DEFAULT_CAMERAS: dict[str, dict[str, Any]] = {"rgb": DEFAULT_CAMERA}


@dataclass(frozen=True)
class ObservationSpec:
    """What an environment's observation dict holds: the state keys (a subset of
    ``achieved_goal``, ``desired_goal``, ``observation``, or ``desired_goal`` and
    ``proprioception``) and each camera's entries (images, depth, segmentation, points)."""

    mode: str
    schema: _common.Schema
    #: Sensor entry keys (each camera's, then ``touch``), in the order of the native bytes.
    image_keys: tuple[str, ...] = ()
    #: The shape of each entry (``(height, width, 3)`` for a colour image).
    image_shapes: tuple[tuple[int, ...], ...] = ()
    #: The cameras as the native side takes them (``"[]"`` for none).
    cameras_json: str = "[]"
    #: The element type of each entry (``"uint8"`` or ``"float32"``; all ``"uint8"`` when
    #: empty).
    image_dtypes: tuple[str, ...] = ()
    #: The ``(low, high)`` bounds of each entry's values.
    image_bounds: tuple[tuple[float, float], ...] = ()
    #: ``(id, what)`` of every segmentation id the cameras can see (empty without
    #: segmentation): ``background``, ``floor``, ``platform``, ``goal``, ``object:<name>``,
    #: ``link:<name>``.
    segmentation_ids: tuple[tuple[int, str], ...] = ()
    #: Whether the dict holds the touch entry (the last of the native entries).
    touch: bool = False

    @property
    def base_mode(self) -> str:
        """The mode without :data:`TOUCH_SUFFIX`."""
        return self.mode.removesuffix(TOUCH_SUFFIX) if self.touch else self.mode

    @property
    def state_keys(self) -> tuple[str, ...]:
        """The state entries of the dict."""
        mode = self.base_mode
        prefix = _IMAGE_MODES[mode][0] if mode in _IMAGE_MODES else "state"
        if prefix == "":
            return ("achieved_goal", "desired_goal")
        if prefix == "proprio":
            return ("desired_goal", PROPRIOCEPTION_KEY)
        return _common.DICT_KEYS

    @functools.cached_property
    def _proprioception(self) -> slice:
        """Where the robot's own state sits in the flat vector (looked up once, not per step)."""
        return self.schema.source_part("robot")

    @property
    def has_images(self) -> bool:
        """Whether observations carry images."""
        return self.cameras_json.strip() != "[]"

    @property
    def has_sensors(self) -> bool:
        """Whether observations carry entries the native sensors write (images, touch)."""
        return bool(self.image_keys)

    def space(self) -> spaces.Dict | spaces.Box:
        """The observation space of one environment (a ``Box`` in ``"flat"`` mode, else a
        ``Dict``)."""
        if self.mode == "flat":
            flat = spaces.flatten_space(_common.observation_space(self.schema))
            assert isinstance(flat, spaces.Box)  # a Dict of Boxes flattens to one Box
            return flat
        state = dict(_common.observation_space(self.schema).spaces)
        if PROPRIOCEPTION_KEY in self.state_keys:
            robot = self._proprioception
            state[PROPRIOCEPTION_KEY] = spaces.Box(
                -_common.OBSERVATION_BOUND,
                _common.OBSERVATION_BOUND,
                shape=(robot.stop - robot.start,),
                dtype=np.float32,
            )
        entries: dict[str, spaces.Space[Any]] = {key: state[key] for key in self.state_keys}
        for key, shape, dtype, (low, high) in zip(
            self.image_keys, self.image_shapes, self._dtypes, self._bounds, strict=True
        ):
            if dtype == "uint8":
                entries[key] = spaces.Box(int(low), int(high), shape=shape, dtype=np.uint8)
            else:
                entries[key] = spaces.Box(low, high, shape=shape, dtype=np.float32)
        return spaces.Dict(entries)

    @property
    def _dtypes(self) -> tuple[str, ...]:
        return self.image_dtypes or ("uint8",) * len(self.image_keys)

    @property
    def _bounds(self) -> tuple[tuple[float, float], ...]:
        return self.image_bounds or ((0.0, 255.0),) * len(self.image_keys)

    def assemble(self, flat: np.ndarray, images: np.ndarray | None) -> Any:
        """The observation dict from the flat state (``(d,)`` or ``(n, d)``) and the native
        image bytes (``(bytes,)`` or ``(n, bytes)``; ``None`` without cameras); in ``"flat"``
        mode the flat state itself."""
        if self.mode == "flat":
            return flat
        parts = _common.split_observation(flat, self.schema)
        if PROPRIOCEPTION_KEY in self.state_keys:
            parts[PROPRIOCEPTION_KEY] = np.ascontiguousarray(flat[..., self._proprioception])
        obs = {key: parts[key] for key in self.state_keys}
        if images is not None:
            lead = images.shape[:-1]
            start = 0
            for key, shape, dtype in zip(
                self.image_keys, self.image_shapes, self._dtypes, strict=True
            ):
                count = int(np.prod(shape))
                if dtype == "uint8":
                    obs[key] = images[..., start : start + count].reshape(*lead, *shape)
                    start += count
                    continue
                # Little-endian float32 bytes, viewed as numbers (a copy of the bytes, so
                # that each entry owns an aligned buffer).
                chunk = np.ascontiguousarray(images[..., start : start + 4 * count])
                values = chunk.view(np.dtype("<f4")).astype(np.float32, copy=False)
                obs[key] = values.reshape(*lead, *shape)
                start += 4 * count
        return obs

    def row(self, obs: Any, i: int | np.integer) -> Any:
        """Environment ``i``'s entries of a batched observation (dict, or array in ``"flat"``
        mode)."""
        if self.mode == "flat":
            return obs[i]
        return {key: value[i] for key, value in obs.items()}


def _image_size(image_size: Any) -> tuple[int, int]:
    """``image_size``: an int (square) or ``(height, width)``, in pixels."""
    values = (
        [image_size] * 2
        if isinstance(image_size, int | np.integer) and not isinstance(image_size, bool)
        else image_size
    )
    if (
        not isinstance(values, list | tuple)
        or len(values) != 2
        or any(isinstance(v, bool) or not isinstance(v, int | np.integer) for v in values)
        or any(not 1 <= int(v) <= 4096 for v in values)
    ):
        raise ConfigError(
            f"image_size must be an int or (height, width) of ints in [1, 4096] pixels, got "
            f"{image_size!r}"
        )
    return int(values[0]), int(values[1])


def observation_spec(
    schema: _common.Schema,
    obs_mode: Any = "state",
    image_size: Any = DEFAULT_IMAGE_SIZE,
    cameras: Any = None,
    visual_randomization: Any = None,
    config_json: str = "{}",
) -> ObservationSpec:
    """The observation layout for ``obs_mode`` with images of ``image_size`` from ``cameras``
    (a dict from observation key to camera options: ``target``, ``distance``, ``azimuth``,
    ``elevation`` or ``eye``, ``fov``, as for rendering, and ``show_goal``, default False: the
    goal marker is left out of observation images so that a relabelled goal never contradicts
    the picture; with point clouds, ``points``, the number of points, default
    :data:`DEFAULT_POINTS`, and ``points_frame``, ``"world"`` (default) or ``"camera"``).
    ``visual_randomization`` (``True`` for :data:`VISUAL_RANDOMIZATION`'s ranges, or a dict of
    some of them; ``None`` or ``False``: off) randomises every camera's pictures, seeded per
    episode (see :data:`VISUAL_RANDOMIZATION`). ``config_json`` is the environment's
    configuration, whose scene names the segmentation ids. ``obs_mode`` ending in
    :data:`TOUCH_SUFFIX` adds the ``touch`` entry. Bad values raise
    :class:`~panda_rapier.ConfigError`."""
    touch = isinstance(obs_mode, str) and obs_mode.endswith(TOUCH_SUFFIX)
    base = obs_mode.removesuffix(TOUCH_SUFFIX) if touch else obs_mode
    if base not in OBS_MODES or (touch and base == "flat"):
        raise ConfigError(
            "obs_mode must be 'state', 'flat', or [state+|proprio+] followed by one or more of "
            f"{', '.join(MODALITIES)} in that order, joined by '+' ('rgbd' for 'rgb+depth'): "
            f"one of {OBS_MODES}, each but 'flat' optionally followed by {TOUCH_SUFFIX!r} for "
            f"the hand's touch reading; got {obs_mode!r}"
        )
    if base in ("state", "flat"):
        if cameras is not None or visual_randomization not in (None, False):
            raise ConfigError(
                "cameras and visual_randomization set the observation cameras of the image "
                "obs_modes; for render() frames, use camera"
            )
        if not touch:
            return ObservationSpec(mode=obs_mode, schema=schema)
        native = _native.Cameras("[]", True)
        return ObservationSpec(
            mode=str(obs_mode),
            schema=schema,
            image_keys=tuple(native.keys),
            image_shapes=tuple(tuple(shape) for shape in native.shapes),
            image_dtypes=tuple(native.dtypes),
            image_bounds=tuple((float(lo), float(hi)) for lo, hi in native.bounds),
            touch=True,
        )
    height, width = _image_size(image_size)
    if cameras is None:
        cameras = DEFAULT_CAMERAS
    if not isinstance(cameras, Mapping) or not cameras:
        raise ConfigError(
            f"cameras must be a non-empty dict from observation key to camera options, got "
            f"{cameras!r}"
        )
    randomization = _randomization(visual_randomization)
    modalities = _IMAGE_MODES[base][1]
    entries = []
    for key, options in cameras.items():
        reserved = (*RESERVED_KEYS, TOUCH_KEY) if touch else RESERVED_KEYS
        if not isinstance(key, str) or key in reserved or not key:
            raise ConfigError(
                f"camera keys must be non-empty strings other than {reserved}, got {key!r}"
            )
        if not isinstance(options, Mapping):
            raise ConfigError(f"cameras[{key!r}] must be a dict of camera options, got {options!r}")
        camera = dict(options)
        show_goal = camera.pop("show_goal", False)
        if not isinstance(show_goal, bool):
            raise ConfigError(f"cameras[{key!r}]['show_goal'] must be a bool, got {show_goal!r}")
        render = {"width": width, "height": height, "camera": camera, "show_goal": show_goal}
        if randomization is not None:
            render["randomization"] = randomization
        entry: dict[str, Any] = {"key": key, "render": render}
        points = {name: camera.pop(name) for name in ("points", "points_frame") if name in camera}
        if points and "points" not in modalities:
            raise ConfigError(
                f"cameras[{key!r}]: {sorted(points)} are options of the point cloud modes (an "
                f"obs_mode with 'points'), not of {obs_mode!r}"
            )
        count = points.get("points", DEFAULT_POINTS)
        if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
            raise ConfigError(f"cameras[{key!r}]['points'] must be an int >= 1, got {count!r}")
        frame = points.get("points_frame", "world")
        if frame not in ("world", "camera"):
            raise ConfigError(
                f"cameras[{key!r}]['points_frame'] must be 'world' or 'camera', got {frame!r}"
            )
        if modalities != ("rgb",):
            entry["modalities"] = list(modalities)
        if "points" in modalities:
            entry["points"] = int(count)
            entry["points_frame"] = frame
        entries.append(entry)
    try:
        cameras_json = json.dumps(
            entries,
            allow_nan=False,
            default=lambda v: v.tolist() if isinstance(v, np.ndarray | np.generic) else str(v),
        )
    except ValueError as error:
        raise ConfigError(f"camera options must be finite numbers: {error}") from error
    native = _native.Cameras(cameras_json, touch)  # validates every camera
    camera_keys = native.keys[:-1] if touch else native.keys
    clash = set(camera_keys) & {*RESERVED_KEYS, *((TOUCH_KEY,) if touch else ())}
    if clash:
        raise ConfigError(f"camera entries {sorted(clash)} clash with the state keys")
    return ObservationSpec(
        mode=str(obs_mode),
        schema=schema,
        image_keys=tuple(native.keys),
        image_shapes=tuple(tuple(shape) for shape in native.shapes),
        cameras_json=cameras_json,
        image_dtypes=tuple(native.dtypes),
        image_bounds=tuple((float(lo), float(hi)) for lo, hi in native.bounds),
        segmentation_ids=(
            tuple((int(i), str(name)) for i, name in _native.segmentation_ids(config_json))
            if "segmentation" in modalities
            else ()
        ),
        touch=touch,
    )


def _randomization(value: Any) -> dict[str, Any] | None:
    """The renderer's randomisation entry for ``visual_randomization`` (checked by the
    renderer, which names a bad field)."""
    if value is None or value is False:
        return None
    if value is True:
        return dict(VISUAL_RANDOMIZATION)
    if not isinstance(value, Mapping):
        raise ConfigError(
            f"visual_randomization must be True, False, None or a dict of ranges, got {value!r}"
        )
    unknown = set(value) - set(VISUAL_RANDOMIZATION)
    if unknown:
        raise ConfigError(
            f"visual_randomization: unknown entries {sorted(unknown)}; known: "
            f"{list(VISUAL_RANDOMIZATION)}"
        )
    return {**VISUAL_RANDOMIZATION, **dict(value)}


def split_options(options: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``options`` (as ``gym.make`` or a training run's ``env_kwargs`` take them) split into the
    simulation's configuration and the observation options (:data:`OBSERVATION_OPTIONS`, which
    :func:`~panda_rapier.evaluation.evaluate` takes as keywords)."""
    config = {k: v for k, v in options.items() if k not in OBSERVATION_OPTIONS}
    observation = {k: v for k, v in options.items() if k in OBSERVATION_OPTIONS}
    return config, observation


def plain_observation(observation: Mapping[str, Any]) -> dict[str, Any]:
    """The observation options a model is validated and evaluated with: those it was trained
    with, without ``visual_randomization``. Randomisation is something to train with; a
    benchmark's scene is the plain one unless an evaluation asks otherwise
    (``panda-rapier eval --visual-randomization``)."""
    return {k: v for k, v in observation.items() if k != "visual_randomization"}
