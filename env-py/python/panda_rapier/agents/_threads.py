"""torch's thread count for a block: the one helper behind behaviour cloning's fits
(re-exported as :func:`panda_rapier.learning.threads.torch_threads`) and a LeRobot policy's
calls (:class:`~panda_rapier.agents.lerobot_policy.LeRobotPolicy`). Imports torch only when
used, so the modules that import it stay light."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["torch_threads"]


@contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """torch runs on ``threads`` threads inside the block (``None``: unchanged), and on as
    many as before after it: for a phase in which no environment steps (behaviour cloning's
    fits), or for policy calls that are batches of one beside the environments' threads."""
    import torch as th

    found = th.get_num_threads()
    if threads is not None:
        th.set_num_threads(threads)
    try:
        yield
    finally:
        th.set_num_threads(found)
