"""Glove links: serial ports and UDP. Each delivers decoded frames stamped with host time (recorder/link/base.py);
recorder.glove opens the right one for a glove config."""

from recorder.link.base import GloveSource, LinkStats

__all__ = ["GloveSource", "LinkStats"]
