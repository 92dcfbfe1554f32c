"""WristConfig: where the wrist's position comes from, parsed once from the spec people type (``--wrist`` of
record, view, calibrate and `gloverec wrist`):

    scripted                 the task scripts the hand's base (today's tasks; the default)
    udp:9100, udp:HOST:9100  6-DoF poses from any tracker, one datagram each (recorder/wrist/format.py)
    marker:CAMERA            a printed marker on the glove seen by a camera: a device index (0), a video file or
                             a stream URL, as cv2.VideoCapture opens it (recorder/wrist/camera.py)
    marker:emulated          the emulated webcam filming the emulated wearer's marker (recorder/wrist/emulated.py);
    marker:emulated:RX,RY,RZ its marker glued off flat by that rotation vector (degrees, the palm's axes)
    mcap:FILE                the tracker's poses of a session log, played back (recorder/wrist/log.py)

An unknown kind lists these.
"""

from __future__ import annotations

from dataclasses import dataclass

from recorder.config import ConfigError

SCRIPTED = "scripted"
KINDS = (SCRIPTED, "udp", "marker", "mcap")
SPECS = (
    "scripted, udp:PORT, udp:HOST:PORT or marker:CAMERA (a device index, video file or stream URL), or mcap:FILE "
    "(a session log's tracker poses)"
)


@dataclass(frozen=True)
class WristConfig:
    """A wrist source. ``kind``: scripted, udp, marker or mcap; ``host``, ``port``: where a udp source listens;
    ``camera``: what a marker source opens (a device index, a video file or a stream URL); ``file``: the session
    log an mcap source plays back."""

    kind: str = SCRIPTED
    host: str = "0.0.0.0"
    port: int = 0
    camera: str = ""
    file: str = ""

    @classmethod
    def parse(cls, spec: str | WristConfig) -> WristConfig:
        if isinstance(spec, WristConfig):
            return spec
        text = str(spec).strip()
        if text == SCRIPTED:
            return cls()
        kind, sep, rest = text.partition(":")
        if kind == "marker" and rest:
            config = cls("marker", camera=rest)
            if config.emulated:
                _ = config.emulated_mount  # a bad mounting of the emulated marker: ConfigError now
            return config
        if kind == "mcap" and rest:
            return cls("mcap", file=rest)
        if kind != "udp" or not sep:
            raise ConfigError(f"unknown wrist source {text!r}; valid: {SPECS}")
        host, _, port = rest.rpartition(":")
        if not port.isdigit() or not 0 < int(port) < 65536:
            raise ConfigError(f"bad wrist source {text!r}: the port must be 1-65535 ({SPECS})")
        return cls("udp", host or "0.0.0.0", int(port))

    @property
    def emulated(self) -> bool:
        """``marker:emulated``: the emulated webcam filming the emulated wearer (recorder/wrist/track.py)."""
        return self.kind == "marker" and (self.camera == "emulated" or self.camera.startswith("emulated:"))

    @property
    def emulated_mount(self):
        """The emulated marker's mounting on the palm (wxyz): flat on the back of the hand for ``marker:emulated``;
        ``marker:emulated:RX,RY,RZ`` glues it off by that rotation vector (degrees, the palm's axes: x toward the
        fingers, z out of the back of the hand), to try `gloverec calibrate --wrist` on (docs/wrist.md)."""
        import numpy as np  # not at start-up

        from recorder import quat

        _, _, degrees = self.camera.partition(":")
        if not self.emulated or not degrees:
            return quat.IDENTITY.copy()
        try:
            rv = np.radians([float(v) for v in degrees.split(",")])
        except ValueError:
            rv = np.zeros(0)
        if rv.shape != (3,) or not np.all(np.isfinite(rv)):
            raise ConfigError(f"bad wrist source {str(self)!r}: marker:emulated:RX,RY,RZ glues the emulated marker "
                              "off by that rotation vector, three numbers in degrees")  # fmt: skip
        return quat.from_rotvec(rv)

    def __str__(self) -> str:
        if self.kind == "marker":
            return f"marker:{self.camera}"
        if self.kind == "mcap":
            return f"mcap:{self.file}"
        return SCRIPTED if self.kind == SCRIPTED else f"udp:{self.host}:{self.port}"
