"""Learning: what ``panda-rapier train`` runs (needs the ``train`` extra: torch,
stable-baselines3).

- :mod:`~panda_rapier.learning.recipes`: the recipe files (``hyperparams/``) and validation
  settings;
- :mod:`~panda_rapier.learning.runs`: run directories, records and the periodic validation;
- :mod:`~panda_rapier.learning.runner`: :func:`~panda_rapier.learning.runner.train`, the
  stable-baselines3 runner;
- the algorithms and their parts: :mod:`~panda_rapier.learning.ppo`,
  :mod:`~panda_rapier.learning.overlap`, :mod:`~panda_rapier.learning.imitation`,
  :mod:`~panda_rapier.learning.student`, :mod:`~panda_rapier.learning.normalization`,
  :mod:`~panda_rapier.learning.exploration`, :mod:`~panda_rapier.learning.finetune`,
  :mod:`~panda_rapier.learning.threads`, :mod:`~panda_rapier.learning.phases`,
  :mod:`~panda_rapier.learning.checkpoint`;
- the expert's data: :mod:`~panda_rapier.learning.rollouts`,
  :mod:`~panda_rapier.learning.demos`.

Imports the environment layer and :mod:`panda_rapier.agents`, never the layers above.
"""
