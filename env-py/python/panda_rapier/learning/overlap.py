"""PPO's update of one rollout overlapped with the collection of the next, in a second process.

While PPO collects a rollout, the cores are not all busy: the policy's forward passes and the
rollout loop's Python run on one core between the environments' steps, and the steps
themselves end on a barrier that leaves a core waiting for the slower half of the batch.
:class:`UpdateProcess` runs the update of rollout ``k`` in a learner process meanwhile, at
idle CPU priority (Linux ``SCHED_IDLE``): it only gets cores nothing else wants, so it never
slows the stepping (at normal priority it did: taking a core from one of the environments'
threads stalls every step's barrier, and the run gained 3 % instead of 17 %,
``docs/guide/throughput.md``). Rollout ``k + 1`` is therefore collected by the policy from
before update ``k``: one update old. PPO's ratio is taken against the log-probabilities the
buffer stored, i.e. against the policy that acted, so the clipped objective stays a trust
region around the behaviour policy, as in asynchronous PPO implementations (e.g. Sample
Factory's APPO).

The schedule does not depend on timing, so a run is as reproducible as a plain one: the
learner process starts from a copy of the model (weights, optimizer state, hyperparameters)
and numpy's global generator state (which draws the minibatches), trains on each rollout in
the order it is sent, and its result is taken in at fixed points: after the next rollout
(:meth:`panda_rapier.learning.ppo.PPO.learn`). The learner's logger values (``train/...``) are
recorded in the main process's logger, so logs, TensorBoard and callbacks see what a plain
run shows, one rollout later. Callbacks that change the model between rollouts reach the
learner only through the parameters' ``requires_grad`` flags, sent with each rollout (what
:class:`panda_rapier.learning.finetune.CriticWarmup` changes); other changes to the main process's
model are overwritten by the next update's result. When training is stopped inside a
rollout (a callback returned ``False``), the update in flight is dropped, so the model is the
one the callbacks saw last.
A run resumed from a checkpoint starts a new learner from the checkpoint's model: the update
that was in flight when the checkpoint was written is not in it.

The two processes exchange the rollout buffer's arrays and the state dicts of the policy and
its optimizer through two pipes, pickled by this module and read only from the learner
process this module started.
"""

from __future__ import annotations

import io
import os
import pickle
import subprocess
import sys
import threading
import traceback
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.buffers import DictRolloutBuffer, RolloutBuffer
from stable_baselines3.common.logger import Logger

from ..errors import PandaRapierError

__all__ = ["LearnerProcessError", "UpdateProcess"]


class LearnerProcessError(PandaRapierError, RuntimeError):
    """PPO's learner process failed or ended (its traceback is in the message), or the
    overlapped schedule was broken."""


#: The rollout buffer's arrays the update reads (besides the observations).
_FIELDS = ("actions", "rewards", "returns", "episode_starts", "values", "log_probs", "advantages")


def _buffer_arrays(buffer: RolloutBuffer | DictRolloutBuffer) -> dict[str, Any]:
    observations = buffer.observations
    return {
        "observations": dict(observations) if isinstance(observations, dict) else observations,
        **{name: getattr(buffer, name) for name in _FIELDS},
    }


def _fill_buffer(buffer: RolloutBuffer | DictRolloutBuffer, arrays: dict[str, Any]) -> None:
    buffer.reset()
    observations = arrays["observations"]
    if isinstance(buffer.observations, dict):
        for key, value in observations.items():
            buffer.observations[key][...] = value
    else:
        buffer.observations[...] = observations
    for name in _FIELDS:
        getattr(buffer, name)[...] = arrays[name]
    buffer.pos = buffer.buffer_size
    buffer.full = True


#: What the learner process runs: ``python -c _LEARNER_COMMAND PACKAGE_ROOT READ_FD WRITE_FD``.
#: It first asks to run only on cores nothing else wants (Linux ``SCHED_IDLE``; elsewhere the
#: lowest ``nice``), before importing torch: the environments step on every core with a barrier
#: per step, so a learner taking a core from one of their threads would stall them all.
_LEARNER_COMMAND = """\
import os, sys
try:
    os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
except (AttributeError, OSError):
    try:
        os.nice(19)
    except OSError:
        pass
sys.path.append(sys.argv[1])
from multiprocessing.connection import Connection
from panda_rapier.learning.overlap import _learner
_learner(Connection(int(sys.argv[2]), writable=False), Connection(int(sys.argv[3]), readable=False))
"""


def _learner(receive: Connection, send: Connection) -> None:
    """The learner process: loads the model, then trains it on each rollout it receives and
    sends back the policy's and optimizer's state, the logger's values and the update count."""
    try:
        th.set_num_threads(1)
        saved, model_class, numpy_state = pickle.loads(receive.recv_bytes())
        model = model_class.load(io.BytesIO(saved), device="cpu")
        model.set_logger(Logger(folder=None, output_formats=[]))
        # SB3's rollout buffer draws its minibatches from numpy's global generator.
        np.random.set_state(numpy_state)  # noqa: NPY002
        send.send_bytes(pickle.dumps(("ready", None)))
        while True:
            message = pickle.loads(receive.recv_bytes())
            if message is None:
                return
            arrays, progress, trainable = message
            for name, parameter in model.policy.named_parameters():
                parameter.requires_grad_(trainable[name])
            _fill_buffer(model.rollout_buffer, arrays)
            model._current_progress_remaining = progress
            model.train()
            logger = model.logger
            logs = {
                key: (value, logger.name_to_excluded.get(key))
                for key, value in logger.name_to_value.items()
            }
            logger.name_to_value.clear()
            logger.name_to_count.clear()
            logger.name_to_excluded.clear()
            reply = {
                "policy": model.policy.state_dict(),
                "optimizer": model.policy.optimizer.state_dict(),
                "logs": logs,
                "n_updates": model._n_updates,
            }
            send.send_bytes(pickle.dumps(("update", reply)))
    except EOFError:  # the main process went away
        return
    except BaseException:  # reported to the main process, which raises it
        try:
            send.send_bytes(pickle.dumps(("error", traceback.format_exc())))
        except OSError:
            pass


class UpdateProcess:
    """A learner process that trains a copy of a PPO model on the rollouts :meth:`start`
    sends it; :meth:`finish` takes each update's result back into the model. Use it as a
    context manager: leaving the block stops the process.

    The process starts at once and imports its libraries meanwhile (a few seconds, on cores
    nothing else wants); :meth:`load` (or passing ``model`` here) gives it the model to start
    from without waiting for it. It is a new Python running :func:`_learner` with two pipes
    (not ``multiprocessing``, whose ``spawn`` re-imports the caller's main module: a script
    without an ``if __name__ == "__main__"`` guard would train twice)."""

    def __init__(self, model: Any | None = None) -> None:
        down_read, down_write = os.pipe()
        up_read, up_write = os.pipe()
        # The package's directory goes last on the child's path (it may have been added to
        # this process's path at run time), so it shadows nothing.
        package_root = str(Path(__file__).resolve().parents[1])
        fds = (down_read, up_write)
        try:
            self._process = subprocess.Popen(
                [sys.executable, "-c", _LEARNER_COMMAND, package_root, *map(str, fds)],
                pass_fds=fds,
            )
        finally:
            os.close(down_read)
            os.close(up_write)
        self._send = Connection(down_write, readable=False)
        self._receive_end = Connection(up_read, writable=False)
        self._pending = False
        self._ready = False  # the learner has loaded its model (start() waits for it)
        self._loader: threading.Thread | None = None
        if model is not None:
            self.load(model)

    def load(self, model: Any) -> None:
        """Gives the learner the model to start from: its weights, optimizer state and
        hyperparameters (its SB3 save) and numpy's global generator state, which draws PPO's
        minibatches. Returns at once: a thread writes them while the learner may still be
        importing its libraries."""
        if self._loader is not None:
            raise LearnerProcessError("the learner process was given its model already")
        saved = io.BytesIO()
        model.save(saved)
        numpy_state = np.random.get_state()  # noqa: NPY002 (SB3's minibatches draw from it)
        payload = pickle.dumps((saved.getvalue(), type(model), numpy_state))
        self._loader = threading.Thread(
            target=self._write_model, args=(payload,), name="panda-rapier-learner-load", daemon=True
        )
        self._loader.start()

    def _write_model(self, payload: bytes) -> None:
        try:
            self._send.send_bytes(payload)
        except OSError:  # the learner ended: start() reports it (no reply), close() knows
            pass

    def __enter__(self) -> UpdateProcess:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()

    def _receive(self) -> Any:
        try:
            kind, payload = pickle.loads(self._receive_end.recv_bytes())
        except (EOFError, OSError) as error:
            code = self._process.poll()
            raise LearnerProcessError(
                f"PPO's learner process ended without a reply (exit code {code})"
            ) from error
        if kind == "error":
            raise LearnerProcessError(f"PPO's learner process failed:\n{payload}")
        return payload

    def start(self, model: Any) -> None:
        """Sends ``model``'s rollout buffer (full, with its returns and advantages computed) to
        be trained on, with the schedules' progress and which of the policy's parameters are
        trainable (``requires_grad``: callbacks such as
        :class:`panda_rapier.learning.finetune.CriticWarmup` freeze some); the buffer may be
        refilled right away."""
        if self._pending:
            raise LearnerProcessError("the previous update has not been taken back (finish)")
        if not self._ready:
            if self._loader is None:
                raise LearnerProcessError("the learner process has no model yet (load)")
            self._loader.join()
            self._receive()  # an ended learner raises here, with its exit code
            self._ready = True
        trainable = {name: p.requires_grad for name, p in model.policy.named_parameters()}
        progress = float(model._current_progress_remaining)
        payload = pickle.dumps((_buffer_arrays(model.rollout_buffer), progress, trainable))
        self._send.send_bytes(payload)
        self._pending = True

    def finish(self, model: Any, apply: bool = True) -> None:
        """Waits for the update in flight, if any, and (``apply``) loads its result into
        ``model``: the policy's weights, the optimizer's state, the update count and the
        logger's ``train/...`` values; ``apply=False`` drops it."""
        if not self._pending:
            return
        self._pending = False
        reply = self._receive()
        if not apply:
            return
        model.policy.load_state_dict(reply["policy"])
        model.policy.optimizer.load_state_dict(reply["optimizer"])
        model._n_updates = int(reply["n_updates"])
        for key, (value, excluded) in reply["logs"].items():
            model.logger.record(key, value, exclude=excluded)

    def close(self) -> None:
        """Stops the learner process (an update in flight is dropped)."""
        if self._process.poll() is None:
            # An update in flight (e.g. an exception left the loop: nobody will read the
            # reply), or a learner still loading (the loader thread may be writing to it).
            if self._pending or not self._ready:
                self._process.kill()
            else:
                try:
                    self._send.send_bytes(pickle.dumps(None))
                except OSError:
                    pass
            try:
                self._process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        if self._loader is not None:
            self._loader.join()  # a killed learner's pipe ends the write at once
        self._send.close()
        self._receive_end.close()
