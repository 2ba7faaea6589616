"""A floor under the exploration noise of chosen action dimensions, for on-policy training.

PPO's Gaussian policy learns one state-independent standard deviation per action dimension.
On pick-and-place the gripper's shrinks quickly: closing early and holding on is what the
reward pays for during reach, lift and carry. By the time the cube is at the goal the gripper
command is almost never sampled open enough to let go (the fingers clear a 5 cm cube only
above about +0.25), so releasing, the last step of the task, is never discovered
(``docs/training.md``). :class:`MinActionStd` keeps the chosen dimensions' standard
deviation at or above a floor; the policy can still make the gripper reliable where it must
be by moving its mean (commands beyond the action bounds are clipped by the environment).

In a recipe (rl-zoo3 format)::

    callback:
      - panda_rapier.learning.exploration.MinActionStd:
          min_std: 0.4
          dims: [-1]          # the gripper command, last in ee and joints actions
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch as th
from stable_baselines3.common.callbacks import BaseCallback

__all__ = ["MinActionStd"]


class MinActionStd(BaseCallback):
    """Before every rollout (and at the start of training), raises the policy's ``log_std``
    entries for ``dims`` to at least ``log(min_std)``.

    Works with policies that hold a state-independent ``log_std`` parameter (SB3's PPO and
    A2C with diagonal Gaussian actions); anything else is a :class:`TypeError` at the start
    of training, not a silent no-op.
    """

    def __init__(self, min_std: float, dims: Sequence[int] = (-1,), verbose: int = 0) -> None:
        super().__init__(verbose)
        if not (isinstance(min_std, (int, float)) and math.isfinite(min_std) and min_std > 0):
            raise ValueError(f"min_std must be a positive finite number, got {min_std!r}")
        if not dims:
            raise ValueError("dims must name at least one action dimension")
        self.min_std = float(min_std)
        self.dims = [int(d) for d in dims]

    def _log_std(self) -> th.nn.Parameter:
        log_std = getattr(self.model.policy, "log_std", None)
        if not isinstance(log_std, th.nn.Parameter) or log_std.dim() != 1:
            raise TypeError(
                "MinActionStd needs a policy with a state-independent log_std parameter "
                f"(PPO/A2C with Box actions); {type(self.model.policy).__name__} has none"
            )
        size = log_std.shape[0]
        for d in self.dims:
            if not -size <= d < size:
                raise ValueError(f"action dimension {d} out of range for {size} dimensions")
        return log_std

    def _raise_floor(self) -> None:
        log_std = self._log_std()
        floor = math.log(self.min_std)
        with th.no_grad():
            for d in self.dims:
                log_std[d].clamp_(min=floor)

    def _on_training_start(self) -> None:
        self._raise_floor()

    def _on_rollout_start(self) -> None:
        self._raise_floor()

    def _on_step(self) -> bool:
        return True
