"""GloveConfig: which glove a command opens and how, parsed once from the spec people type (``--glove``, a
``glove:`` key in a YAML file):

    emulator                    the built-in emulator on a pseudo-terminal in this process
    serial:/dev/ttyACM0         a serial device (a bare device path works too)
    udp:9000, udp:HOST:9000     a wireless glove or a bridge, one datagram per frame
    mcap:session.mcap           a session log played back as a glove

Every kind is a registered glove source (``@register_glove_source``: its name, whether it is a device on a wire
that runs in real time, whether it takes an address and how to check it, and how to open its link); the built-in
emulator, serial, udp and mcap are registered in recorder/glove/sources.py, others come from plugins
(recorder/plugins.py; docs/recording.md, "Adding a glove source"). This module imports no link: a source's
``opener`` imports what it opens when it runs, and one in a layer above this one (the emulator's) is named as
"module:function", imported when a glove of its kind opens.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Annotated, Literal

from recorder.config import STRICT, ConfigError, Positive, setting

EMULATOR = "emulator"  # the default kind: the built-in emulator, in this process (recorder/emulator/source.py)
EMULATOR_MODES = ("pose", "raw", "compact", "json")
EMULATOR_MOTIONS = ("gestures", "random", "demonstrations", "calibration", "calibration_pinch", "doctor")
PROTOCOLS = ("auto", "binary", "json")


@dataclass(frozen=True)
class GloveSource:
    """A kind of glove that ``--glove KIND:ADDRESS`` (``--glove KIND`` when it takes no ``address``) opens.
    ``opener(config, realtime, **link_options)`` returns the unopened link (a recorder.link.base.GloveSource: the
    frames, a reader thread, reconnects), or is its "module:function" name; ``device``: the glove is on a wire and
    runs in real time (serial, UDP), else it can play faster (a log, the emulator); ``check`` raises ConfigError
    for a bad address; ``present`` raises GloverecError when the address names nothing there now (a port not
    plugged in, a missing file); ``spec``: how it is written, for help and errors."""

    name: str
    opener: Callable | str
    device: bool
    spec: str
    check: Callable[[str], None] | None = None
    address: bool = True
    present: Callable[[str], None] | None = None

    def link(self, config: GloveConfig, realtime: bool = True, **options):
        """The opener's unopened link for ``config`` (an opener named by a string is imported now)."""
        opener = self.opener
        if isinstance(opener, str):
            module, _, name = opener.partition(":")
            opener = getattr(importlib.import_module(module), name)
        return opener(config, realtime, **options)


_SOURCES: dict[str, GloveSource] = {}


def register_glove_source(name: str, *, device: bool, spec: str | None = None, check=None, address: bool = True,
                          present=None):  # fmt: skip
    """Decorator of a source's ``opener(config, realtime, **link_options)`` (or called on its "module:function"
    name): glove kind ``name``; ``address=False``: written as the name alone (``emulator``)."""

    def register(opener):
        if name in _SOURCES and _qualname(_SOURCES[name].opener) != _qualname(opener):
            raise ConfigError(f"glove source {name!r} is registered already")
        _SOURCES[name] = GloveSource(name, opener, device, spec or (f"{name}:ADDRESS" if address else name), check,
                                     address, present)  # fmt: skip
        return opener

    return register


def _qualname(opener: Callable | str) -> str:
    return opener if isinstance(opener, str) else opener.__qualname__


def glove_source(kind: str) -> GloveSource:
    """The registered source ``kind``; an unknown one: one-line ConfigError listing the kinds."""
    source = _registered(kind)
    if source is None:
        raise ConfigError(f"unknown glove kind {kind!r}; valid: {', '.join(kinds())}")
    return source


def _registered(kind: str) -> GloveSource | None:
    """Source ``kind`` or None; the plugins load only for a kind that is not built in."""
    _load(plugins=False)
    if kind not in _SOURCES:
        _load()
    return _SOURCES.get(kind)


def kinds() -> tuple[str, ...]:
    _load()
    return tuple(_SOURCES)


def specs() -> str:
    """How gloves are written, for help texts and errors."""
    _load()
    return ", ".join(s.spec for s in _SOURCES.values())


def _load(plugins: bool = True) -> None:
    import recorder.glove.sources  # noqa: F401  (the built-in sources register on import; they import this module)

    if plugins:
        from recorder.plugins import load_plugins  # importlib.metadata (17 ms): not at start-up

        load_plugins()


SPECS = "emulator, serial:PORT (or a device path), udp:PORT, udp:HOST:PORT, mcap:FILE, or a plugin's KIND:ADDRESS"


@dataclass(frozen=True)
class GloveConfig:
    """A glove. ``kind``: a registered source (the emulator by default); ``address``: the device path (serial),
    HOST:PORT (udp), the log file (mcap), none for the emulator. The emulator's ``rate_hz``, output ``mode`` (the
    wire format, the protocol's Mode; its flag is ``--output``) and ``motion``: the wearer moves between
    ``gestures``, moves ``random``ly, performs the scripted ``demonstrations`` of the task being recorded
    (recorder/demonstrator/performer.py), or the ``calibration`` steps (with the pinch step: ``calibration_pinch``;
    None: what the command needs). ``seed`` seeds the emulated motion. `gloverec emulate`'s flags are these fields'
    (``rate_hz``, ``mode``, ``motion``, ``seed``)."""

    __pydantic_config__ = STRICT

    kind: str = EMULATOR
    address: str = ""
    baudrate: Annotated[int, Positive] = setting(
        115200, "serial baud rate (USB serial ignores it)", flag="--baud", metavar="BAUD"
    )
    protocol: Literal["auto", "binary", "json"] = setting("auto", "wire protocol: binary frames, legacy JSON lines")
    # the emulator's: `gloverec emulate` takes these flags as they are named here; record and view as --glove-*
    rate_hz: Annotated[float, Positive] = setting(
        200.0, "the emulator's sensing and output rate (Hz)", flag="--rate", metavar="HZ"
    )
    mode: Literal["pose", "raw", "compact", "json"] = setting(
        "pose",
        "the emulator's output: fused poses, raw IMU frames (fused on the host), compact poses, legacy JSON",
        flag="--output",
        aliases=("--mode",),
    )
    motion: Literal["gestures", "random", "demonstrations", "calibration", "calibration_pinch", "doctor"] | None = (
        setting(
            None,
            "the emulated wearer: moves between gestures, moves at random, performs the task's scripted demonstrations "
            "(record), or (calibration) rests until `gloverec calibrate` asks for raw frames, then performs its steps "
            "(with the pinch step: calibration_pinch), then gestures, or (doctor) rests until `gloverec doctor` asks "
            "for raw frames, then performs its moves (default: gestures; record: demonstrations)",
        )
    )
    seed: int = setting(0, "seeds the emulated motion", metavar="N")

    def __post_init__(self):
        for name, valid in (("protocol", PROTOCOLS), ("mode", EMULATOR_MODES)):
            if getattr(self, name) not in valid:
                raise ConfigError(f"unknown glove {name} {getattr(self, name)!r}; valid: {', '.join(valid)}")
        if self.motion is not None and self.motion not in EMULATOR_MOTIONS:
            raise ConfigError(f"unknown emulator motion {self.motion!r}; valid: {', '.join(EMULATOR_MOTIONS)}")
        source = glove_source(self.kind)
        if source.address and not self.address:
            raise ConfigError(f"a {self.kind} glove needs an address: {source.spec}")
        if source.address and source.check is not None:
            source.check(self.address)  # checked now, not when it opens
        if not self.rate_hz > 0 or not self.baudrate > 0:
            raise ConfigError("the glove's rate and baud rate must be positive")

    @classmethod
    def decode_text(cls, spec: str) -> dict:
        """The fields a spec string sets: {"kind": ..., "address": ...}."""
        text = str(spec).strip()
        kind, sep, rest = text.partition(":")
        source = _registered(kind) if kind else None
        if source is not None and not source.address:  # the emulator: its name alone
            if sep:
                raise ConfigError(f"bad glove {text!r}: expected {specs()}")
            return {"kind": kind, "address": ""}
        if source is not None and sep:
            if not rest:
                raise ConfigError(f"bad glove {text!r}: expected {specs()}")
            return {"kind": kind, "address": rest}
        if not text or (sep and not text.startswith(("/", "."))):  # KIND:... with an unknown kind
            raise ConfigError(f"bad glove {text!r}: expected {specs()}")
        return {"kind": "serial", "address": text}  # a bare device path

    @classmethod
    def parse(cls, spec: str | GloveConfig, **options) -> GloveConfig:
        """The glove ``spec`` names (a GloveConfig passes through), with ``options`` (fields) set."""
        if isinstance(spec, GloveConfig):
            return replace(spec, **options)
        return cls(**{**cls.decode_text(spec), **options})

    def __str__(self) -> str:
        return f"{self.kind}:{self.address}" if glove_source(self.kind).address else self.kind

    def check_present(self) -> None:
        """A port that is not plugged in or a log that is not there: one line, before a command's heavy imports
        (opening the glove says it too, but only after them). A glove that goes away later is the link's to handle."""
        source = glove_source(self.kind)
        if source.address and source.present is not None:
            source.present(self.address)

    @property
    def is_device(self) -> bool:
        """A glove on a wire (serial, UDP): it runs in real time. The emulator and logs can run faster."""
        return glove_source(self.kind).device

    def udp_address(self) -> tuple[str, int]:
        """(host, port) of a udp glove (host 0.0.0.0 when only the port is given)."""
        return udp_address(self.address)


def udp_address(address: str) -> tuple[str, int]:
    """(host, port) of ``udp:PORT`` or ``udp:HOST:PORT`` (host 0.0.0.0 when only the port is given)."""
    host, _, port = address.rpartition(":")
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(f"bad UDP glove udp:{address}: expected udp:PORT or udp:HOST:PORT")
    return host or "0.0.0.0", int(port)


@dataclass
class LinkConfig:
    """What `gloverec monitor`, `log` and `bridge` read: a glove's frames as its link delivers them (no fusion), for
    a while. Their flags are generated from these fields (recorder/config.py); each command takes the ones it
    uses, and its own outputs (--out, --udp, --json) as flags of its own."""

    __pydantic_config__ = STRICT

    glove: GloveConfig = setting(
        default_factory=GloveConfig,
        help=f"the glove: {SPECS}",
        metavar="GLOVE",
        aliases=("--port",),
        flags={"protocol": "--protocol", "baudrate": "--baud"},
    )
    duration: Annotated[float, Positive] | None = setting(None, "seconds (default: until Ctrl-C)", metavar="S")
    fast: bool = setting(False, "play an mcap:FILE back as fast as it decodes", flag="--fast")
