"""The built-in wrist sources (recorder/wrist/config.py ``register_wrist_source``): a tracker's UDP pose stream, a
printed marker seen by a camera, the emulated webcam filming the emulated wearer's marker, and a session log's
tracker poses played back. Each opener builds the source it names, unopened; OpenCV and the log reader load when
one of theirs opens."""

from __future__ import annotations

import numpy as np

from recorder import GloverecError, quat
from recorder.config import ConfigError
from recorder.paths import calibration_dir
from recorder.wrist.config import register_wrist_source, specs
from recorder.wrist.track import EmulatedMarker
from recorder.wrist.udp import UdpWrist


def udp_address(address: str) -> str:
    """``PORT`` or ``HOST:PORT`` as HOST:PORT (host 0.0.0.0 when only the port is given)."""
    host, _, port = address.rpartition(":")
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(f"bad wrist source {f'udp:{address}'!r}: the port must be 1-65535 ({specs()})")
    return f"{host or '0.0.0.0'}:{int(port)}"


@register_wrist_source("udp", spec="udp:PORT, udp:HOST:PORT", check=udp_address)
def udp(config, **options):
    host, _, port = config.address.rpartition(":")
    return UdpWrist(host, int(port))


@register_wrist_source("marker", spec="marker:CAMERA (a device index, video file or stream URL)", seen="marker")
def marker(config, *, camera_file=None, marker_mm: float = 40.0, paced: bool = True, **options):
    from recorder.wrist.calibration import camera_file as saved  # OpenCV: loaded when a camera opens
    from recorder.wrist.camera import MarkerWrist
    from recorder.wrist.marker import CameraModel, MarkerSpec

    if not camera_file:
        camera_file = saved(calibration_dir(), config.address)
        if not camera_file.exists():
            raise GloverecError(f"{config} needs its camera's calibration: run gloverec calibrate --camera "
                                f"{config.address}, or pass --wrist-camera FILE.json")  # fmt: skip
    return MarkerWrist(config.address, CameraModel.load(camera_file), MarkerSpec(size_m=marker_mm / 1000.0), paced)


def emulated_mount(address: str) -> np.ndarray:
    """The emulated marker's mounting on the palm (wxyz): flat on the back of the hand for ``marker:emulated``;
    ``marker:emulated:RX,RY,RZ`` glues it off by that rotation vector (degrees, the palm's axes: x toward the
    fingers, z out of the back of the hand), to try `gloverec calibrate --wrist` on (docs/wrist.md)."""
    if not address:
        return quat.IDENTITY.copy()
    try:
        rv = np.radians([float(v) for v in address.split(",")])
    except ValueError:
        rv = np.zeros(0)
    if rv.shape != (3,) or not np.all(np.isfinite(rv)):
        raise ConfigError(f"bad wrist source {f'marker:emulated:{address}'!r}: marker:emulated:RX,RY,RZ glues the "
                          "emulated marker off by that rotation vector, three numbers in degrees")  # fmt: skip
    return quat.from_rotvec(rv)


def _mount(address: str) -> str:
    emulated_mount(address)  # a bad mounting: ConfigError now
    return address


@register_wrist_source("marker:emulated", spec="marker:emulated[:RX,RY,RZ] (the emulated wearer's marker, filmed)",
                       check=_mount, bare=True, wearer=True, seen="marker")  # fmt: skip
def emulated(config, *, wearer, **options):
    return EmulatedMarker(wearer, mount=emulated_mount(config.address))


@register_wrist_source("mcap", spec="mcap:FILE (a session log's tracker poses)")
def mcap(config, *, paced: bool = True, glove=None, **options):
    from recorder.wrist.log import LogWrist, same_log  # the log reader (mcap): loaded when a log opens

    return LogWrist(config.address, paced, glove_clock=same_log(config.address, glove))
