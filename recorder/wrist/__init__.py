"""The wrist's pose from a tracker (issue 24): its config (``WristConfig.parse("udp:9100")``), the message format
(recorder/wrist/format.py), the sources, and what `gloverec wrist` reports. ``open_wrist(spec)`` is the one factory,
as ``make_glove`` is for gloves."""

from __future__ import annotations

from recorder import GloverecError
from recorder.wrist.config import SCRIPTED, WristConfig


def open_wrist(spec):
    """The unopened source ``spec`` names (a context manager: ``with open_wrist("udp:9100") as w: w.take()``)."""
    config = WristConfig.parse(spec)
    if config.kind == SCRIPTED:
        raise GloverecError("the scripted wrist is the task's: there is no tracker to open (pass udp:PORT)")
    from recorder.wrist.udp import UdpWrist

    return UdpWrist(config.host, config.port)
