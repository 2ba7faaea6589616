"""Fine-tuning a cloned policy with PPO: a value-function warm-up.

A policy cloned from the scripted expert (``panda-rapier train --algo bc``) acts well, but its
value function was never trained. PPO's first updates would then follow advantages that are
mostly the critic's noise and undo much of what cloning learned before the critic catches up.
:class:`CriticWarmup` trains the value function alone for the first ``steps`` environment
steps: the actor (and its action noise) stays exactly the cloned one while the critic learns
the returns that actor earns; afterwards PPO updates both as usual.

In a recipe (rl-zoo3 format), with ``panda-rapier train --algo ppo --init-from
models/bc-dagger-Stack-v0.zip``::

    callback:
      - panda_rapier.learning.finetune.CriticWarmup:
          steps: 200000
"""

from __future__ import annotations

from stable_baselines3.common.callbacks import BaseCallback

from .runs import VALUE_PREFIXES

__all__ = ["CriticWarmup"]


class CriticWarmup(BaseCallback):
    """For the first ``steps`` environment steps of training, PPO's updates train only the
    value function: every other policy parameter has ``requires_grad`` off, so it gets no
    gradient and the optimiser leaves it (and its moment estimates) untouched. From the first
    update after ``steps`` on, everything trains.

    Needs an actor-critic policy whose value-function parameters are named as in SB3's
    (``mlp_extractor.value_net``, ``value_net``); anything else is a :class:`TypeError` at the
    start of training, not a silent no-op.
    """

    def __init__(self, steps: int, verbose: int = 0) -> None:
        super().__init__(verbose)
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
            raise ValueError(f"steps must be a non-negative whole number, got {steps!r}")
        self.steps = steps
        self._frozen: bool | None = None

    def _set(self, frozen: bool) -> None:
        if self._frozen == frozen:
            return
        named = list(self.model.policy.named_parameters())
        value = [p for n, p in named if n.startswith(VALUE_PREFIXES)]
        if not value:
            raise TypeError(
                "CriticWarmup needs an actor-critic policy with a value network named as in "
                f"SB3's; {type(self.model.policy).__name__} has none"
            )
        for name, parameter in named:
            if not name.startswith(VALUE_PREFIXES):
                parameter.requires_grad_(not frozen)
        self._frozen = frozen
        if self.verbose:
            print("critic warm-up: " + ("actor frozen" if frozen else "actor trains again"))

    def _on_training_start(self) -> None:
        self._set(self.model.num_timesteps < self.steps)

    def _on_rollout_end(self) -> None:
        # Called after each rollout, before that rollout's update.
        self._set(self.model.num_timesteps < self.steps)

    def _on_step(self) -> bool:
        return True
