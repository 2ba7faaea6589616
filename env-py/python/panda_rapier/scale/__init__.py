"""Scale-out on Ray (the ``rllib`` extra): :mod:`~panda_rapier.scale.rllib` (RLlib on the
native vector env), :mod:`~panda_rapier.scale.rllib_recipe` (the SB3 PPO recipe as an RLlib
module), :mod:`~panda_rapier.scale.rllib_training` (``panda-rapier train --backend rllib``)
and :mod:`~panda_rapier.scale.tuning` (Ray Tune sweeps over the recipes).

Imports the environment layer, :mod:`panda_rapier.agents` and :mod:`panda_rapier.learning`.
"""
