"""Benches and reports: :mod:`~panda_rapier.tools.bench` (``panda-rapier bench``),
:mod:`~panda_rapier.tools.train_bench` (``panda-rapier bench-train``) and
:mod:`~panda_rapier.tools.reporting` (``curves``, ``models-table``).

May import any layer; only :mod:`panda_rapier.cli` imports it.
"""
