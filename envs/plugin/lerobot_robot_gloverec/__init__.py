"""Imported by LeRobot's plugin discovery (distribution name `lerobot_robot_gloverec`): registers the robot type
``gloverec_sim`` (GloverecSimConfig) and exports its class, which LeRobot finds by name (GloverecSim)."""

from lerobot_robot_gloverec.config_gloverec_sim import GloverecSimConfig, SimCameraConfig
from lerobot_robot_gloverec.gloverec_sim import GloverecSim

__all__ = ["GloverecSim", "GloverecSimConfig", "SimCameraConfig"]
