"""Gymnasium registration of the panda_rapier environments."""

from __future__ import annotations

import json
from typing import Any

import gymnasium as gym

from ._native import default_config_json, tasks

#: Episode length of the pick-and-place and lift ids: the core's default, 70 steps at 25 Hz
#: (2.8 s), the length the scripted baseline needs to place the cube in 99 % of episodes in both
#: action modes (see ``help(panda_rapier.PandaEnv)``).
MAX_EPISODE_STEPS: int = json.loads(default_config_json())["max_episode_steps"]

#: Every task's static facts, as the core's registry (``env-core/src/task/registry.rs``)
#: lists them: ``name``, ``id_stem``, ``episode_steps``, ``joint_step`` (of its joints ids, or
#: None for the default), ``has_platform``, ``summary`` and
#: ``defaults`` (the JSON of its configuration section's defaults).
TASKS: tuple[dict[str, Any], ...] = tuple(tasks())

#: Episode length of each task's ids (the task's descriptor: long enough for the scripted
#: expert in both action modes; reach takes panda-gym's 50 steps, stack 150).
TASK_EPISODE_STEPS: dict[str, int] = {t["name"]: int(t["episode_steps"]) for t in TASKS}

#: Id stem of each task, in the order tables list them.
TASK_NAMES: dict[str, str] = {t["name"]: str(t["id_stem"]) for t in TASKS}

#: The joint action scale of each task's ``joints`` ids where it differs from the default
#: ``joint_step`` (slide's let-go speed and flip's rolls need 0.1 rad per step).
TASK_JOINT_STEPS: dict[str, float] = {
    t["name"]: float(t["joint_step"]) for t in TASKS if t["joint_step"] is not None
}

#: The control mode of each task's end-effector ids: ``ee``, or ``ee_pose`` for a task whose
#: hand must turn (peg insertion).
TASK_EE_CONTROL_MODES: dict[str, str] = {t["name"]: str(t["ee_control_mode"]) for t in TASKS}

_VARIANTS: dict[str, dict[str, Any]] = {
    f"panda_rapier/{name}{dense}-v0": {
        "task": task,
        "control_mode": TASK_EE_CONTROL_MODES[task] if control == "ee" else control,
        "reward_type": reward,
        **(
            {"joint_step": TASK_JOINT_STEPS[task]}
            if control == "joints" and task in TASK_JOINT_STEPS
            else {}
        ),
    }
    for task, name in TASK_NAMES.items()
    for control, joints in (("ee", ""), ("joints", "Joints"))
    for reward, dense in (("sparse", joints), ("dense", joints + "Dense"))
}

#: Every registered environment id.
ENV_IDS: tuple[str, ...] = tuple(_VARIANTS)


def variant(env_id: str) -> dict[str, Any]:
    """What an id fixes: its ``task``, ``control_mode`` and ``reward_type`` (and, for the
    ``joints`` ids of a task that needs another, its ``joint_step``)."""
    from .errors import ConfigError

    if env_id not in _VARIANTS:
        raise ConfigError(f"unknown environment id {env_id!r}; registered: {', '.join(ENV_IDS)}")
    return dict(_VARIANTS[env_id])


def task_places(task: str) -> bool:
    """Whether ``task`` (``"pick_and_place"``, ``"reach"``, ...) has a placed rate: the
    object also let go of and at rest (``is_placed``)."""
    return any(bool(t["has_placed"]) for t in TASKS if t["name"] == task)


def task_id(task: str, control_mode: str = "ee", reward_type: str = "sparse") -> str:
    """The id of ``task`` (``"pick_and_place"``, ``"reach"``, ...) in an action mode and
    reward type: ``task_id("reach", "joints")`` is ``panda_rapier/ReachJoints-v0``. ``"ee"``
    names a task's end-effector ids whatever their actions (``ee_pose`` for peg insertion)."""
    if control_mode == "ee":
        control_mode = TASK_EE_CONTROL_MODES.get(task, "ee")
    wanted = {"task": task, "control_mode": control_mode, "reward_type": reward_type}
    for env_id, fixed in _VARIANTS.items():
        if all(fixed[key] == value for key, value in wanted.items()):
            return env_id
    raise KeyError(f"no id for {wanted}")


#: The id commands use when none is given (``panda-rapier eval``, ``train``, ``bench``).
DEFAULT_ENV_ID = "panda_rapier/PickAndPlace-v0"


def env_config(env_id: str, **overrides: Any) -> dict[str, Any]:
    """The configuration options of a registered panda_rapier id (its time limit included),
    with ``overrides`` applied: what the vector environments and the scripted policy take."""
    from .errors import ConfigError

    try:
        spec = gym.spec(env_id)
    except gym.error.Error as error:
        raise ConfigError(f"unknown environment id {env_id!r}; see panda_rapier.ENV_IDS") from error
    if not str(spec.entry_point).startswith("panda_rapier"):
        raise ConfigError(f"{env_id} is not a panda_rapier environment; see panda_rapier.ENV_IDS")
    options = dict(spec.kwargs)
    if spec.max_episode_steps is not None:
        options.setdefault("max_episode_steps", spec.max_episode_steps)
    options.update(overrides)
    options.pop("render_mode", None)
    return options


def register_envs() -> None:
    """Registers every id in :data:`ENV_IDS` (idempotent)."""
    for env_id, kwargs in _VARIANTS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point="panda_rapier.env:PandaEnv",
            vector_entry_point="panda_rapier.vector:PandaVectorEnv",
            max_episode_steps=TASK_EPISODE_STEPS[kwargs["task"]],
            kwargs=dict(kwargs),
        )
