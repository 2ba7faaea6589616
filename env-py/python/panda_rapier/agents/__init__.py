"""Agents: trained policies as files, and how they are acted out and evaluated.

- :mod:`~panda_rapier.agents.model_file`: model files and run records, read by data;
- :mod:`~panda_rapier.agents.inference`: policies acted out natively (``PolicyNetwork``) and
  what ``--policy`` names (``resolve_policy``);
- :mod:`~panda_rapier.agents.student_model`: the network of a policy that sees;
- :mod:`~panda_rapier.agents.evaluation`: seeded evaluation (``panda-rapier eval``).

Imports only the environment layer (:mod:`panda_rapier`); torch and stable-baselines3 only
where a model needs them (the native inference needs neither).
"""
