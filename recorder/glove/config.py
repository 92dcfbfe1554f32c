"""GloveConfig: which glove a command opens and how, parsed once from the spec people type (``--glove``,
``--port``, a ``glove:`` key in a YAML file):

    emulator                    the built-in emulator on a pseudo-terminal in this process
    serial:/dev/ttyACM0         a serial device (a bare device path works too)
    udp:9000, udp:HOST:9000     a wireless glove or a bridge, one datagram per frame
    mcap:session.mcap           a session log played back as a glove
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

from recorder.config import STRICT, ConfigError, setting

KINDS = ("emulator", "serial", "udp", "mcap")
SPECS = "emulator, serial:PORT (or a device path), udp:PORT, udp:HOST:PORT or mcap:FILE"
EMULATOR_MODES = ("pose", "raw", "compact", "json")
EMULATOR_MOTIONS = ("gestures", "random", "demonstrations", "calibration", "calibration_pinch")
PROTOCOLS = ("auto", "binary", "json")


@dataclass(frozen=True)
class GloveConfig:
    """A glove. ``address``: the device path (serial), HOST:PORT (udp) or the log file (mcap). The emulator's
    ``rate_hz``, output ``mode`` and ``motion``: the wearer moves between ``gestures``, moves ``random``ly,
    performs the scripted ``demonstrations`` of the task being recorded, or the ``calibration`` steps (with the
    pinch step: ``calibration_pinch``; None: what the command needs). ``seed`` seeds the emulated motion."""

    __pydantic_config__ = STRICT

    kind: Literal["emulator", "serial", "udp", "mcap"] = "emulator"
    address: str = ""
    baudrate: int = setting(115200, "serial baud rate (USB serial ignores it)")
    protocol: Literal["auto", "binary", "json"] = setting("auto", "wire protocol: binary frames, legacy JSON lines")
    rate_hz: float = setting(200.0, "the emulator's sensing and output rate (Hz)")
    mode: Literal["pose", "raw", "compact", "json"] = setting(
        "pose", "the emulator's output: fused poses, raw IMU frames (fused on the host), compact poses, legacy JSON"
    )
    motion: Literal["gestures", "random", "demonstrations", "calibration", "calibration_pinch"] | None = None
    seed: int = 0

    def __post_init__(self):
        for name, valid in (("kind", KINDS), ("protocol", PROTOCOLS), ("mode", EMULATOR_MODES)):
            if getattr(self, name) not in valid:
                raise ConfigError(f"unknown glove {name} {getattr(self, name)!r}; valid: {', '.join(valid)}")
        if self.motion is not None and self.motion not in EMULATOR_MOTIONS:
            raise ConfigError(f"unknown emulator motion {self.motion!r}; valid: {', '.join(EMULATOR_MOTIONS)}")
        if self.kind != "emulator" and not self.address:
            raise ConfigError(f"a {self.kind} glove needs an address: {SPECS}")
        if self.kind == "udp":
            self.udp_address()  # checked now, not when it opens
        if not self.rate_hz > 0 or not self.baudrate > 0:
            raise ConfigError("the glove's rate and baud rate must be positive")

    @classmethod
    def decode_text(cls, spec: str) -> dict:
        """The fields a spec string sets: {"kind": ..., "address": ...}."""
        text = str(spec).strip()
        kind, sep, rest = text.partition(":")
        if text == "emulator":
            return {"kind": "emulator", "address": ""}
        if sep and kind in ("serial", "udp", "mcap"):
            if not rest:
                raise ConfigError(f"bad glove {text!r}: expected {SPECS}")
            return {"kind": kind, "address": rest}
        if not text or sep and kind in KINDS:
            raise ConfigError(f"bad glove {text!r}: expected {SPECS}")
        return {"kind": "serial", "address": text}  # a bare device path

    @classmethod
    def parse(cls, spec: str | GloveConfig, **options) -> GloveConfig:
        """The glove ``spec`` names (a GloveConfig passes through), with ``options`` (fields) set."""
        if isinstance(spec, GloveConfig):
            return replace(spec, **options)
        return cls(**{**cls.decode_text(spec), **options})

    def __str__(self) -> str:
        return "emulator" if self.kind == "emulator" else f"{self.kind}:{self.address}"

    @property
    def is_device(self) -> bool:
        """A glove on a wire (serial, UDP): it runs in real time. The emulator and logs can run faster."""
        return self.kind in ("serial", "udp")

    def udp_address(self) -> tuple[str, int]:
        """(host, port) of a udp glove (host 0.0.0.0 when only the port is given)."""
        host, _, port = self.address.rpartition(":")
        if not port.isdigit() or not 0 < int(port) < 65536:
            raise ConfigError(f"bad UDP glove udp:{self.address}: expected udp:PORT or udp:HOST:PORT")
        return host or "0.0.0.0", int(port)
