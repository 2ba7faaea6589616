"""Deprecated: :mod:`panda_rapier.learning.exploration` (this path is removed in 0.4.0).

Importing it emits a :class:`FutureWarning` and gives the new module itself.
"""

from ._deprecated import alias

alias(__name__)
