"""PPO's updates overlapped with the next rollout (``panda_rapier.learning.overlap``): the learner
process must compute exactly the schedule it promises (rollout ``k + 1`` collected by the
policy from before update ``k``), hand back the logs and update count, drop the update in
flight when a callback stops training, fail with a clear error, and ``train`` / ``bench-train``
must take and record the option."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
import stable_baselines3
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.logger import Logger

from panda_rapier.errors import InvalidArgumentError
from panda_rapier.learning.normalization import NormalizedFlatten
from panda_rapier.learning.overlap import LearnerProcessError, UpdateProcess
from panda_rapier.learning.ppo import PPO
from panda_rapier.sb3 import make_vec_env

ENV_ID = "panda_rapier/ReachDense-v0"
N_ENVS, N_STEPS = 4, 32
SETTINGS: dict[str, Any] = {
    "n_steps": N_STEPS,
    "batch_size": 32,
    "n_epochs": 2,
    "policy_kwargs": {
        "features_extractor_class": NormalizedFlatten,
        "net_arch": {"pi": [32, 32], "vf": [32, 32]},
        "log_std_init": -0.5,
    },
}


@pytest.fixture(autouse=True)
def _one_torch_thread() -> Any:
    """The learner process updates on one thread; the in-process references do too, so the
    comparisons below are of the same kernels."""
    found = th.get_num_threads()
    th.set_num_threads(1)
    yield
    th.set_num_threads(found)


def _model(**settings: Any) -> PPO:
    env = make_vec_env(ENV_ID, n_envs=N_ENVS, seed=11)
    return PPO("MultiInputPolicy", env, seed=0, device="cpu", **{**SETTINGS, **settings})


def _weights(model: Any) -> dict[str, np.ndarray]:
    return {k: v.detach().numpy().copy() for k, v in model.policy.state_dict().items()}


def test_overlapped_learn_is_the_one_update_old_schedule() -> None:
    rollouts = 3
    overlapped = _model()
    start = _weights(overlapped)
    overlapped.overlap_updates = True
    overlapped.learn(rollouts * N_ENVS * N_STEPS)
    assert overlapped._n_updates == rollouts * SETTINGS["n_epochs"]

    # The same schedule in one process: an actor collects, a copy of it (made as the learner
    # process makes it) trains, and the actor takes each update in after its next rollout.
    actor = _model()
    assert all(np.array_equal(start[k], v) for k, v in _weights(actor).items())
    total, callback = actor._setup_learn(rollouts * N_ENVS * N_STEPS, None)
    callback.on_training_start(locals(), globals())
    saved = io.BytesIO()
    actor.save(saved)
    learner = PPO.load(io.BytesIO(saved.getvalue()), device="cpu")
    learner.set_logger(Logger(folder=None, output_formats=[]))
    pending = False
    for _ in range(rollouts):
        assert actor.collect_rollouts(actor.env, callback, actor.rollout_buffer, N_STEPS)
        if pending:
            actor.policy.load_state_dict(learner.policy.state_dict())
        actor._update_current_progress_remaining(actor.num_timesteps, total)
        learner.rollout_buffer = actor.rollout_buffer
        learner._current_progress_remaining = actor._current_progress_remaining
        learner.train()
        actor.rollout_buffer = type(actor.rollout_buffer)(
            N_STEPS, actor.observation_space, actor.action_space, device="cpu",
            gamma=actor.gamma, gae_lambda=actor.gae_lambda, n_envs=N_ENVS,
        )  # fmt: skip
        pending = True
    actor.policy.load_state_dict(learner.policy.state_dict())

    ours, reference = _weights(overlapped), _weights(actor)
    assert ours.keys() == reference.keys()
    for key in ours:
        np.testing.assert_array_equal(ours[key], reference[key], err_msg=key)
    assert not all(np.array_equal(start[k], v) for k, v in ours.items())  # it trained
    # The optimizer's state came back too (Adam's moments after the last update).
    moments = overlapped.policy.optimizer.state_dict()["state"]
    expected = learner.policy.optimizer.state_dict()["state"]
    assert moments.keys() == expected.keys() and moments
    for index in moments:
        for name in ("exp_avg", "exp_avg_sq"):
            assert th.equal(moments[index][name], expected[index][name])


def test_overlapped_learn_differs_from_the_plain_schedule_and_logs_the_same_keys() -> None:
    steps = 3 * N_ENVS * N_STEPS
    plain, overlapped = _model(), _model()
    overlapped.overlap_updates = True
    plain.learn(steps)
    overlapped.learn(steps)
    assert plain._n_updates == overlapped._n_updates
    keys = {k for k in plain.logger.name_to_value if k.startswith("train/")}
    assert "train/approx_kl" in keys
    assert keys == {k for k in overlapped.logger.name_to_value if k.startswith("train/")}
    # Rollouts after the first are collected by an older policy: the weights differ.
    assert any(
        not np.array_equal(a, b)
        for a, b in zip(_weights(plain).values(), _weights(overlapped).values(), strict=True)
    )


class _StopInSecondRollout(BaseCallback):
    def __init__(self) -> None:
        super().__init__()
        self.rollouts = 0

    def _on_rollout_start(self) -> None:
        self.rollouts += 1

    def _on_step(self) -> bool:
        return self.rollouts < 2


def test_a_stop_inside_a_rollout_drops_the_update_in_flight() -> None:
    model = _model()
    start = _weights(model)
    model.overlap_updates = True
    model.learn(10 * N_ENVS * N_STEPS, callback=CallbackList([_StopInSecondRollout()]))
    # The callbacks stopped training while the policy they saw was the first one: that is the
    # model, its first update (in flight) dropped.
    assert model._n_updates == 0
    assert all(np.array_equal(start[k], v) for k, v in _weights(model).items())


def test_parameters_frozen_in_the_main_process_stay_frozen_in_the_learner() -> None:
    """What ``panda_rapier.learning.finetune.CriticWarmup`` does: the actor frozen, the critic
    trains."""
    model = _model()
    for parameter in model.policy.action_net.parameters():
        parameter.requires_grad_(False)
    start = _weights(model)
    model.overlap_updates = True
    model.learn(2 * N_ENVS * N_STEPS)
    after = _weights(model)
    assert np.array_equal(start["action_net.weight"], after["action_net.weight"])
    assert not np.array_equal(start["value_net.weight"], after["value_net.weight"])


def test_an_exception_in_the_loop_stops_the_learner_at_once() -> None:
    model = _model()
    with pytest.raises(KeyError), UpdateProcess(model) as learner:
        model._setup_learn(N_ENVS * N_STEPS, None)
        callback = CallbackList([])
        callback.init_callback(model)
        model.collect_rollouts(model.env, callback, model.rollout_buffer, N_STEPS)
        learner.start(model)
        raise KeyError("the main process failed with an update in flight")
    assert learner._process.poll() is not None


def test_the_overlap_setting_is_not_saved_with_the_model(tmp_path: Path) -> None:
    model = _model()
    model.overlap_updates = True
    model.save(tmp_path / "m.zip")
    loaded = stable_baselines3.PPO.load(tmp_path / "m.zip", device="cpu")
    assert "overlap_updates" not in vars(loaded)
    assert PPO.load(tmp_path / "m.zip", device="cpu").overlap_updates is False


class _BadBuffer:
    """Arrays of the wrong shape: the learner process fails filling its buffer."""

    def __init__(self) -> None:
        self.observations = {"observation": np.zeros((3, 3), dtype=np.float32)}

    def __getattr__(self, name: str) -> np.ndarray:
        return np.zeros((2, 2), dtype=np.float32)


def test_a_failing_learner_process_raises_a_typed_error_with_its_traceback() -> None:
    model = _model()
    with UpdateProcess(model) as learner:
        model.rollout_buffer = _BadBuffer()  # type: ignore[assignment]
        learner.start(model)
        with pytest.raises(LearnerProcessError, match="learner process failed") as error:
            learner.finish(model)
    assert "broadcast" in str(error.value) or "shape" in str(error.value)
    assert isinstance(error.value, RuntimeError)


def test_train_records_the_option_and_refuses_it_where_it_does_not_apply(tmp_path: Path) -> None:
    from panda_rapier.learning.runner import train

    conf = tmp_path / "ppo.yml"
    conf.write_text(
        f"{ENV_ID}:\n  policy: MultiInputPolicy\n  n_envs: {N_ENVS}\n  n_steps: {N_STEPS}\n"
        "  batch_size: 32\n  n_epochs: 1\n"
    )
    kwargs: dict[str, Any] = {
        "conf": conf, "timesteps": 2 * N_ENVS * N_STEPS, "eval_every": 0,
        "checkpoint_every": 0, "progress": False, "say": lambda _: None,
    }  # fmt: skip
    run = train("ppo", ENV_ID, tmp_path / "run", overlap_updates=True, **kwargs)
    assert run["overlap_updates"] is True
    assert run["env_steps"] == 2 * N_ENVS * N_STEPS
    assert json.loads((tmp_path / "run" / "run.json").read_text())["overlap_updates"] is True
    # A resumed run keeps what it recorded.
    kwargs["timesteps"] = 3 * N_ENVS * N_STEPS
    resumed = train("ppo", ENV_ID, tmp_path / "run", resume=True, **kwargs)
    assert resumed["overlap_updates"] is True and resumed["env_steps"] == 3 * N_ENVS * N_STEPS
    with pytest.raises(InvalidArgumentError, match="overlapped updates"):
        train("ppo", ENV_ID, tmp_path / "stock", overlap_updates=True, stock_sb3=True, **kwargs)


def test_the_learner_starts_before_it_has_a_model_and_refuses_to_train_without_one() -> None:
    """``PPO.learn`` starts the process before the run's set-up (its imports take seconds) and
    gives it the model afterwards; the model is given once, and a process that never got one
    is stopped at once."""
    model = _model()
    with UpdateProcess() as learner:
        with pytest.raises(LearnerProcessError, match="no model yet"):
            learner.start(model)
        learner.load(model)
        with pytest.raises(LearnerProcessError, match="given its model already"):
            learner.load(model)
    assert learner._process.poll() is not None
    with UpdateProcess() as idle:
        pass
    assert idle._process.returncode is not None
