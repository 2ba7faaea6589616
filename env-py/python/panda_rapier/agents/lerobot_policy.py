"""LeRobot policies acted out here: a ``pretrained_model`` directory written by
``lerobot-train`` (ACT, Diffusion Policy, ...), evaluated by ``panda-rapier eval --policy DIR``
on the native vector env with the same seeds, episode records and report as every other
policy, so that its figures sit beside the behaviour-cloned models' and can be checked against
``lerobot-eval``'s.

What the policy sees is what LeRobot's own evaluation hands it on the ``panda_rapier`` env
type (:mod:`panda_rapier.learning.lerobot_env`): ``observation.state`` (the flat observation,
or with ``observation.environment_state`` among the policy's inputs the goals' and the
robot's entries, the objects' going to ``observation.environment_state``, as
:func:`state_split` says) and ``observation.images.<camera>`` (the observation camera,
:data:`panda_rapier.pixels.DEFAULT_CAMERA`, at the size the policy's input has), converted by
LeRobot's ``preprocess_observation`` and run through the policy's saved pre- and
post-processors (normalisation) as ``lerobot-eval`` runs them. Each episode gets the task's
summary as its task string.

A LeRobot policy keeps state between steps (ACT's queue of planned actions, Diffusion Policy's
past observations) for the whole batch it is called with, and ``lerobot-eval`` therefore runs
its environments in lock-step batches. The evaluation here refills an environment as soon as
its episode ends, so each environment gets its own view of the policy (the weights shared, the
step state its own), called one environment at a time and reset when a new episode starts
there: an episode's actions do not depend on ``num_envs`` or on the other episodes.

Loading reads the weights (safetensors) and JSON configurations by data. A processor step
named by a Python class path instead of LeRobot's registry would import that module: it
needs ``trust=True`` (``--trust-model-file``), like a pickled stable-baselines3 model.

Needs the ``lerobot`` extra (``pip install "panda-rapier[lerobot]"``, Python >= 3.12).
"""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import _common
from ..errors import ConfigError, InvalidArgumentError
from ..pixels import DEFAULT_CAMERA
from ..registration import TASKS
from ._threads import torch_threads
from .model_file import UnsupportedModelError, UntrustedModelError, read_run_info

__all__ = [
    "LEROBOT_POLICY_FILES",
    "LeRobotPolicy",
    "is_lerobot_policy",
    "lerobot_policy_env_id",
    "state_split",
]

#: The files that make a directory a LeRobot policy (``PreTrainedPolicy.save_pretrained``).
LEROBOT_POLICY_FILES = ("config.json", "model.safetensors")
#: The processor pipelines saved beside a policy by lerobot 0.6.
_PROCESSOR_FILES = ("policy_preprocessor.json", "policy_postprocessor.json")
_STATE = "observation.state"
_ENVIRONMENT_STATE = "observation.environment_state"
_IMAGES = "observation.images."


def state_split(schema: _common.Schema) -> tuple[list[int], list[int]]:
    """The flat observation's columns that ``environment_state=True`` writes as
    ``observation.state`` (the goals' and the robot's) and as
    ``observation.environment_state`` (the task's: its objects' state), each in flat order.
    A task without entries of its own (Reach) has no environment state: a
    :class:`~panda_rapier.errors.ConfigError`."""
    try:
        task = schema.source_part("task")
    except InvalidArgumentError:
        raise ConfigError(
            "environment_state needs a task with object entries in its observation; this "
            "task's observation is the goals and the robot only (write observation.state alone)"
        ) from None
    environment = list(range(task.start, task.stop))
    state = [i for i in range(schema.flat_dim) if not task.start <= i < task.stop]
    return state, environment


def is_lerobot_policy(path: str | Path) -> bool:
    """Whether ``path`` is a directory holding a saved LeRobot policy."""
    path = Path(path)
    return path.is_dir() and all((path / name).is_file() for name in LEROBOT_POLICY_FILES)


def _read_json(path: Path, what: str) -> Any:
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise UnsupportedModelError(f"{path}: not a readable {what} ({error})") from None


def lerobot_policy_env_id(path: str | Path) -> str | None:
    """The id of the environment the policy was trained for: the ``env_id`` of the run record
    in its directory (``panda_rapier_run.json``, as the policies shipped in ``models/`` carry),
    else the id its training dataset was recorded on, where ``lerobot-train`` saved its
    configuration beside the policy (``train_config.json``) and the dataset written by
    ``panda-rapier demos --format lerobot`` is still at its root; ``None`` otherwise."""
    from ..registration import ENV_IDS

    recorded = (read_run_info(path) or {}).get("env_id")
    if recorded in ENV_IDS:
        return str(recorded)
    train = Path(path) / "train_config.json"
    if not train.is_file():
        return None
    dataset = _read_json(train, "training configuration").get("dataset") or {}
    root = dataset.get("root") if isinstance(dataset, Mapping) else None
    if not isinstance(root, str):
        return None
    meta = Path(root) / "meta" / "panda_rapier.json"
    if not meta.is_file():
        return None
    env_id = _read_json(meta, "dataset description").get("env_id")
    return env_id if env_id in ENV_IDS else None


def _check_processors(path: Path, trust: bool) -> None:
    """Refuses (without ``trust``) processor steps that LeRobot would import by class path."""
    for name in _PROCESSOR_FILES:
        file = path / name
        if not file.is_file():
            raise UnsupportedModelError(
                f"{path} has no {name}: saved by a LeRobot older than 0.4, whose policies "
                "carry no processors (save it again with lerobot 0.6)"
            )
        steps = _read_json(file, "processor pipeline").get("steps", [])
        for step in steps if isinstance(steps, list) else []:
            if isinstance(step, Mapping) and "registry_name" not in step and not trust:
                raise UntrustedModelError(
                    f"{file}: the step {step.get('class')!r} is named by a Python class path, "
                    "which loading would import; pass --trust-model-file (Python: trust=True) "
                    "if you trust where the policy came from"
                )


def _inputs(
    policy_config: Any, schema: _common.Schema, path: Path
) -> tuple[tuple[list[int], list[int] | None], list[str], int]:
    """Which flat columns feed ``observation.state`` and ``observation.environment_state``
    (``None``: not an input), the cameras of the policy's images and their size; a
    :class:`~panda_rapier.errors.ConfigError` for inputs the environment cannot give."""
    features = dict(policy_config.input_features)
    known = (_STATE, _ENVIRONMENT_STATE)
    unknown = [k for k in features if k not in known and not k.startswith(_IMAGES)]
    if unknown:
        raise ConfigError(
            f"{path}: the policy reads {unknown}, which panda_rapier environments do not give "
            f"(they give {_STATE}, {_ENVIRONMENT_STATE} and {_IMAGES}<camera>)"
        )
    if _ENVIRONMENT_STATE in features:
        state, environment = state_split(schema)
        columns: tuple[list[int], list[int] | None] = (state, environment)
    else:
        columns = (list(range(schema.flat_dim)), None)
    for key, wanted in ((_STATE, columns[0]), (_ENVIRONMENT_STATE, columns[1])):
        feature = features.get(key)
        if feature is not None and wanted is not None and tuple(feature.shape) != (len(wanted),):
            raise ConfigError(
                f"{path}: the policy's {key} has shape {tuple(feature.shape)}; this "
                f"environment's is ({len(wanted)},): a policy trained on another task or "
                "observation (--env chooses the environment)"
            )
    cameras = sorted(k.removeprefix(_IMAGES) for k in features if k.startswith(_IMAGES))
    sizes = {tuple(features[_IMAGES + key].shape) for key in cameras}
    if len(sizes) > 1 or any(len(s) != 3 or s[0] != 3 or s[1] != s[2] for s in sizes):
        raise ConfigError(
            f"{path}: the policy's images have shapes {sorted(sizes)}; panda_rapier cameras "
            "give one square size, (3, size, size)"
        )
    size = int(next(iter(sizes))[1]) if sizes else 0
    return columns, cameras, size


def _row(value: Any, i: int, n: int) -> Any:
    """Row ``i`` of a batch entry, as a batch of one: tensors and per-row lists sliced, any
    other entry (a processor's bookkeeping) as it is."""
    import torch

    if isinstance(value, torch.Tensor) and value.ndim > 0 and value.shape[0] == n:
        return value[i : i + 1]
    if isinstance(value, list | tuple) and len(value) == n:
        return type(value)([value[i]])
    return value


class LeRobotPolicy:
    """A saved LeRobot policy acting in a panda_rapier environment (see the module
    documentation). ``config`` is the environment's configuration (its schema decides how the
    flat observation maps to the policy's inputs); raises
    :class:`~panda_rapier.errors.ConfigError` when the policy's inputs or actions do not fit
    it."""

    #: How its actions are computed (``EvaluationReport.inference``; the fields its outcomes
    #: depend on: :data:`~panda_rapier.agents.evaluation.OUTCOME_FIELDS`).
    inference = "lerobot-torch-f32"

    def __init__(self, path: str | Path, config: Mapping[str, Any], *, trust: bool = False):
        path = Path(path)
        if not is_lerobot_policy(path):
            raise InvalidArgumentError(
                f"{path} is not a saved LeRobot policy (a directory with "
                f"{' and '.join(LEROBOT_POLICY_FILES)})"
            )
        _check_processors(path, trust)
        try:
            import torch
            from lerobot.configs.policies import PreTrainedConfig
            from lerobot.envs.utils import preprocess_observation
            from lerobot.policies.factory import get_policy_class, make_pre_post_processors
        except ImportError as error:
            raise ImportError(
                "evaluating a LeRobot policy needs lerobot: pip install 'panda-rapier[lerobot]' "
                f"(Python >= 3.12): {error}"
            ) from error
        self._torch = torch
        self._preprocess_observation = preprocess_observation
        policy_config = PreTrainedConfig.from_pretrained(str(path), local_files_only=True)
        policy_config.device = "cpu"
        self._policy = get_policy_class(policy_config.type).from_pretrained(
            str(path), config=policy_config, local_files_only=True
        )
        self._policy.eval()
        self._pre, self._post = make_pre_post_processors(
            policy_config,
            pretrained_path=str(path),
            preprocessor_overrides={"device_processor": {"device": "cpu"}},
        )
        self.path = path
        self.policy_type = str(policy_config.type)
        schema = _common.Schema.of(_common.config_json(config))
        self._task = next(str(t["summary"]) for t in TASKS if t["name"] == schema.task)
        self.action_dim = schema.action_dim
        self._columns, self.cameras, image_size = _inputs(policy_config, schema, path)
        output = policy_config.output_features.get("action")
        if output is None or tuple(output.shape) != (schema.action_dim,):
            shape = None if output is None else tuple(output.shape)
            raise ConfigError(
                f"{path}: the policy's action has shape {shape}; this environment's actions "
                f"are ({schema.action_dim},) (--env and --control choose the action mode)"
            )
        #: The observation options of the evaluation (:func:`~.evaluation.evaluate`).
        self.observation: dict[str, Any] = {}
        if self.cameras:
            self.observation = {
                "obs_mode": "state+rgb",
                "cameras": {key: dict(DEFAULT_CAMERA) for key in self.cameras},
                "image_size": image_size,
            }
        self._views: list[Any] = []
        self._episodes: list[int | None] = []

    def __repr__(self) -> str:
        return f"LeRobotPolicy({self.policy_type}, {self.path})"

    def _view(self, env: int) -> Any:
        """Environment ``env``'s view of the policy: the same modules and weights, its own step
        state (what ``reset`` resets)."""
        while len(self._views) <= env:
            # A deep copy that stops at the modules, their parameters and buffers and the
            # configuration: those are shared, everything else is the view's own (ACT's action
            # queue, its temporal ensembler, Diffusion Policy's queues of observations).
            policy = self._policy
            shared: list[Any] = [policy.config, *policy.parameters(), *policy.buffers()]
            shared += [m for m in policy.modules() if m is not policy]
            view = copy.deepcopy(policy, {id(x): x for x in shared})
            view.reset()
            self._views.append(view)
            self._episodes.append(None)
        return self._views[env]

    def act_by_episode(
        self,
        flat: np.ndarray,
        observation: Mapping[str, np.ndarray],
        episodes: Sequence[int | None],
    ) -> np.ndarray:
        """The actions for a batch of environments: ``flat`` observation rows,
        ``observation`` the same as the evaluation assembles it (with the camera images), and
        ``episodes`` the episode (seed) each environment runs, ``None`` for an idle one (its
        action is zero). An environment's view is reset when its episode changes."""
        # One torch thread: the calls are batches of one, and more threads would fight the
        # environments' for the cores (spinning OpenMP workers made a call of ACT take 1 s).
        with torch_threads(1):
            torch = self._torch
            raw: dict[str, Any] = {"agent_pos": flat[:, self._columns[0]]}
            if self._columns[1] is not None:
                raw["environment_state"] = flat[:, self._columns[1]]
            if self.cameras:
                raw["pixels"] = {
                    key: np.ascontiguousarray(observation[key]) for key in self.cameras
                }
            batch = self._preprocess_observation(raw)
            batch["task"] = [self._task] * flat.shape[0]
            batch = self._pre(batch)
            active = [i for i, e in enumerate(episodes) if e is not None]
            out = np.zeros((flat.shape[0], self.action_dim), dtype=np.float32)
            if active:
                actions = self._act_views(batch, episodes, active, flat.shape[0])
                done = self._post(torch.cat(actions))
                out[active] = done.to("cpu").numpy().astype(np.float32)
            return out

    def _act_views(
        self, batch: dict[str, Any], episodes: Sequence[int | None], active: list[int], n: int
    ) -> list[Any]:
        """Each active environment's action from its view, as a batch of one."""
        torch = self._torch
        actions = []
        with torch.inference_mode():
            for i in active:
                view = self._view(i)
                if self._episodes[i] != episodes[i]:
                    view.reset()
                    self._episodes[i] = episodes[i]
                one = {k: _row(v, i, n) for k, v in batch.items()}
                actions.append(view.select_action(one))
        return actions
