"""Imported by LeRobot's plugin discovery (distribution name `lerobot_teleoperator_gloverec`): registers the
teleoperator type ``gloverec_glove`` (GloverecGloveConfig) and exports its class, which LeRobot finds by name."""

from lerobot_teleoperator_gloverec.config_gloverec_glove import GloverecGloveConfig
from lerobot_teleoperator_gloverec.gloverec_glove import GloverecGlove

__all__ = ["GloverecGlove", "GloverecGloveConfig"]
