"""Where a training run's wall time goes: environment stepping, the policy's forward passes
during rollouts, the rest of the rollout loop (stable-baselines3's buffers and callbacks) and
the updates (with :attr:`panda_rapier.learning.ppo.PPO.overlap_updates`, the time the rollouts wait
for the learner process, its start-up included: its updates otherwise run while the next
rollout is collected).

:class:`PhaseClock` is a stable-baselines3 callback. It times each rollout (from
``on_rollout_start`` to ``on_rollout_end``) and each update (the time between a rollout's end
and the next one's start, and after the last), reads how long the vector environment spent
stepping (:attr:`panda_rapier.sb3.PandaVecEnv.step_seconds`) and times the policy's forward
passes with module hooks (in PPO's rollouts ``policy(obs)`` is the only ``forward`` call;
updates call ``evaluate_actions``; SAC and TQC act through ``predict``, so their forward
passes count as other rollout work). Time spent in periodic evaluations and checkpoints
(``excluded``) is taken out of the rollouts. ``panda-rapier train`` records the split in
``run.json`` (``wall_time_split``) and prints it at the end.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback

__all__ = ["PHASES", "PhaseClock", "describe_split"]

#: The phases of :meth:`PhaseClock.split`, in the order they are reported.
PHASES = ("env_step", "policy_forward", "rollout_other", "update")
_LABELS = {
    "env_step": "env stepping",
    "policy_forward": "policy in rollouts",
    "rollout_other": "other rollout work",
    "update": "updates",
}


class PhaseClock(BaseCallback):
    """Times the phases of training (see the module's documentation). ``excluded`` returns
    the seconds spent so far in work that is not training (evaluations, checkpoints)."""

    def __init__(self, excluded: Callable[[], float] | None = None, verbose: int = 0) -> None:
        super().__init__(verbose)
        self._excluded = excluded or (lambda: 0.0)
        self.seconds = dict.fromkeys(PHASES, 0.0)
        self._rollout = 0.0
        self._mark: float | None = None  # start of the phase under way
        self._in_rollout = False
        self._env_mark = 0.0
        self._skip_mark = 0.0
        self._forward_began = 0.0
        self._forward = 0.0
        self._hooks: list[Any] = []

    def _env_seconds(self) -> float:
        env = self.training_env
        return float(getattr(getattr(env, "unwrapped", env), "step_seconds", 0.0))

    def _on_training_start(self) -> None:
        policy = self.model.policy
        self._hooks = [
            policy.register_forward_pre_hook(self._before_forward),
            policy.register_forward_hook(self._after_forward),
        ]

    def _before_forward(self, *_: Any) -> None:
        self._forward_began = time.perf_counter()

    def _after_forward(self, *_: Any) -> None:
        if self._in_rollout:
            self._forward += time.perf_counter() - self._forward_began

    def _close_update(self, now: float) -> None:
        if self._mark is not None and not self._in_rollout:
            self.seconds["update"] += now - self._mark - (self._excluded() - self._skip_mark)

    def _on_rollout_start(self) -> None:
        now = time.perf_counter()
        self._close_update(now)
        self._in_rollout = True
        self._mark = now
        self._env_mark = self._env_seconds()
        self._skip_mark = self._excluded()
        self._forward = 0.0

    def _on_rollout_end(self) -> None:
        now = time.perf_counter()
        if self._mark is not None and self._in_rollout:
            total = now - self._mark - (self._excluded() - self._skip_mark)
            env = self._env_seconds() - self._env_mark
            self.seconds["env_step"] += env
            self.seconds["policy_forward"] += self._forward
            self.seconds["rollout_other"] += max(total - env - self._forward, 0.0)
        self._in_rollout = False
        self._mark = now
        self._skip_mark = self._excluded()

    def _on_step(self) -> bool:
        return True

    def _on_training_end(self) -> None:
        if self._in_rollout:  # stopped inside a rollout (early stop)
            self._on_rollout_end()
        else:
            self._close_update(time.perf_counter())
        self._mark = None
        for hook in self._hooks:
            hook.remove()
        self._hooks = []

    def split(self) -> dict[str, float]:
        """Seconds per phase so far, rounded to milliseconds."""
        return {phase: round(self.seconds[phase], 3) for phase in PHASES}


def describe_split(split: dict[str, float]) -> str:
    """One line: each phase's share of the timed wall time (e.g. ``env stepping 45 %``)."""
    total = sum(float(split.get(phase, 0.0)) for phase in PHASES)
    if total <= 0:
        return "no time recorded"
    return (
        ", ".join(
            f"{_LABELS[phase]} {100 * float(split.get(phase, 0.0)) / total:.0f} %"
            for phase in PHASES
        )
        + f" (of {total / 60:.1f} min)"
    )
