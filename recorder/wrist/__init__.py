"""The wrist's pose from a tracker (issue 24): its config (``WristConfig.parse("udp:9100")``), the message format
(recorder/wrist/format.py), the sources, and what `gloverec wrist` reports. ``open_wrist(spec)`` is the one factory,
as ``make_glove`` is for gloves."""

from __future__ import annotations

from recorder import GloverecError
from recorder.wrist.config import SCRIPTED, WristConfig


def open_wrist(spec, camera_file: str | None = None, marker_mm: float = 40.0, paced: bool = True, glove=None):
    """The unopened source ``spec`` names (a context manager: ``with open_wrist("udp:9100") as w: w.take()``);
    a marker source needs its camera's calibration (``camera_file``, JSON: recorder/wrist/marker.py CameraModel;
    default: the one `gloverec calibrate --camera CAMERA` saved) and the marker's size; ``paced``: a video file
    or a log plays at its recorded rate (False: as fast as it reads, stamped with video time); ``glove``: the
    recording's GloveConfig: a log that is also the glove keeps its poses on the glove's clock (re-recording)."""
    config = WristConfig.parse(spec)
    if config.kind == SCRIPTED:
        raise GloverecError("the scripted wrist is the task's: there is no tracker to open (pass udp:PORT)")
    if config.kind == "mcap":
        from recorder.wrist.log import LogWrist, same_log

        return LogWrist(config.file, paced, glove_clock=same_log(config.file, glove))
    if config.kind == "marker":
        from recorder.wrist.camera import MarkerWrist
        from recorder.wrist.marker import CameraModel, MarkerSpec

        if not camera_file:
            from recorder.paths import calibration_dir
            from recorder.wrist.calibration import camera_file as saved

            camera_file = saved(calibration_dir(), config.camera)
            if not camera_file.exists():
                raise GloverecError(f"{config} needs its camera's calibration: run gloverec calibrate --camera "
                                    f"{config.camera}, or pass --wrist-camera FILE.json")  # fmt: skip
        return MarkerWrist(config.camera, CameraModel.load(camera_file), MarkerSpec(size_m=marker_mm / 1000.0), paced)
    from recorder.wrist.udp import UdpWrist

    return UdpWrist(config.host, config.port)
