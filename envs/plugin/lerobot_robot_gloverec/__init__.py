"""Imported by LeRobot's plugin discovery (distribution name `lerobot_robot_gloverec`): registers the robot type
``gloverec_sim`` (GloverecSimConfig) and exports its class, which LeRobot finds by name (GloverecSim), and the
environment type ``gloverec`` (GloverecEnvConfig: lerobot-eval's and lerobot-train's ``--env.type``). LeRobot imports
every ``lerobot_robot_*`` and ``lerobot_env_*`` distribution alike, so one distribution carries both."""

from lerobot_robot_gloverec.config_gloverec_env import GloverecEnvConfig
from lerobot_robot_gloverec.config_gloverec_sim import GloverecSimConfig, SimCameraConfig
from lerobot_robot_gloverec.gloverec_sim import GloverecSim

__all__ = ["GloverecEnvConfig", "GloverecSim", "GloverecSimConfig", "SimCameraConfig"]
