"""LeRobot's plugin for panda_rapier: importing it registers the env type ``panda_rapier``
(:class:`panda_rapier.learning.lerobot_env.PandaRapierEnv`)."""

from panda_rapier.learning.lerobot_env import LeRobotObservation, PandaRapierEnv

__all__ = ["LeRobotObservation", "PandaRapierEnv"]
