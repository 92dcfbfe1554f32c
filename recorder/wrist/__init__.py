"""The wrist's pose from a tracker (issue 24): its config (``WristConfig.parse("udp:9100")``), the registered sources
(recorder/wrist/config.py, recorder/wrist/sources.py), the message format (recorder/wrist/format.py), and what
`gloverec wrist` reports. ``open_wrist(spec)`` is the one factory, as ``make_glove`` is for gloves."""

from __future__ import annotations

from recorder import GloverecError
from recorder.wrist.config import SCRIPTED, WristConfig


def open_wrist(spec, camera_file: str | None = None, marker_mm: float = 40.0, paced: bool = True, glove=None,
               wearer=None):  # fmt: skip
    """The unopened source ``spec`` names (a context manager: ``with open_wrist("udp:9100") as w: w.take()``);
    a marker source needs its camera's calibration (``camera_file``, JSON: recorder/wrist/marker.py CameraModel;
    default: the one `gloverec calibrate --camera CAMERA` saved) and the marker's size; ``paced``: a video file
    or a log plays at its recorded rate (False: as fast as it reads, stamped with video time); ``glove``: the
    recording's GloveConfig: a log that is also the glove keeps its poses on the glove's clock (re-recording);
    ``wearer``: the emulated wearer's palm, ``wearer(t) -> (position, quat)`` in the robot's world, for a source
    that follows it (``marker:emulated``)."""
    config = WristConfig.parse(spec)
    if config.kind == SCRIPTED:
        raise GloverecError("the scripted wrist is the task's: there is no tracker to open (pass udp:PORT)")
    source = config.source
    if source.wearer and wearer is None:
        raise GloverecError(f"{config} follows the emulated wearer: `gloverec record` or `gloverec calibrate "
                            "--wrist` with --glove emulator opens it")  # fmt: skip
    return source.opener(config, camera_file=camera_file, marker_mm=marker_mm, paced=paced, glove=glove, wearer=wearer)
