"""Cores for whichever half of an on-policy iteration is running.

An on-policy algorithm (PPO, A2C) alternates between two phases that never overlap: rollouts,
where the native vector env steps its environments on its own threads (all cores) and torch
only runs the policy's small forward pass, and the update, where the environments are idle
and torch runs every gradient step. One torch thread is right for rollouts: more fight the
environment's threads for the cores (gradient steps got about 28x slower on 2 cores). During
the update nothing else runs, so torch can have every core.

:class:`UpdateThreads` switches torch's thread count at the phase boundaries. Measured on
the 2-core development machine with the pick-and-place PPO recipe (64 environments, 10
epochs of 1,024-sample minibatches): the update took 6.0-6.3 s per 40,960 env steps on one
thread and 3.6-4.4 s on two, end to end 3,633-3,715 against 4,160-4,767 env steps/s
(``docs/training.md``). ``panda-rapier train`` uses it for PPO, and :func:`torch_threads`
for behaviour cloning's fits (``--update-threads``).
"""

from __future__ import annotations

import os

import torch as th
from stable_baselines3.common.callbacks import BaseCallback

from ..agents._threads import torch_threads

__all__ = ["UpdateThreads", "all_cores", "torch_threads"]


def all_cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


class UpdateThreads(BaseCallback):
    """Gives torch ``update`` threads (default: every core this process may use) while the
    policy is updated and ``rollout`` threads while the environments step; puts back the
    thread count it found when training ends."""

    def __init__(self, update: int | None = None, rollout: int = 1, verbose: int = 0) -> None:
        super().__init__(verbose)
        update = update if update is not None else all_cores()
        for name, value in (("update", update), ("rollout", rollout)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} threads must be an int >= 1, got {value!r}")
        self.update_threads = update
        self.rollout_threads = rollout
        self._found: int | None = None

    def _on_training_start(self) -> None:
        self._found = th.get_num_threads()

    def _on_rollout_start(self) -> None:
        th.set_num_threads(self.rollout_threads)

    def _on_rollout_end(self) -> None:
        th.set_num_threads(self.update_threads)

    def _on_step(self) -> bool:
        return True

    def _on_training_end(self) -> None:
        if self._found is not None:
            th.set_num_threads(self._found)
