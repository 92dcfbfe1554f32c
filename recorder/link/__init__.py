"""Glove sources: serial ports, UDP, MCAP playback. All deliver decoded frames stamped with host time."""

from recorder.link.base import GloveSource, LinkStats
from recorder.link.sources import open_source

__all__ = ["GloveSource", "LinkStats", "open_source"]
