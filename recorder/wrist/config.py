"""WristConfig: where the wrist's position comes from, parsed once from the spec people type (``--wrist`` of
record, view, calibrate and `gloverec wrist`):

    scripted                 the task scripts the hand's base (today's tasks; the default)
    udp:9100, udp:HOST:9100  6-DoF poses from any tracker, one datagram each (recorder/wrist/format.py)
    marker:CAMERA            a printed marker on the glove seen by a camera: a device index (0), a video file or
                             a stream URL, as cv2.VideoCapture opens it (recorder/wrist/camera.py)
    marker:emulated          the emulated webcam filming the emulated wearer's marker (recorder/wrist/emulated.py);
    marker:emulated:RX,RY,RZ its marker glued off flat by that rotation vector (degrees, the palm's axes)
    mcap:FILE                the tracker's poses of a session log, played back (recorder/wrist/log.py)

Every kind but ``scripted`` (no tracker) is a registered wrist source (``@register_wrist_source``: its name, how it
is written, how to check its address, what it needs and how to open it); the built-in udp, marker,
marker:emulated and mcap are registered in recorder/wrist/sources.py, others come from plugins
(recorder/plugins.py; docs/wrist.md, "Adding a wrist source"). A kind's name may hold a colon: the longest
registered name a spec starts with is its kind (``marker:emulated:7,0,0`` is marker:emulated's, ``marker:0``
marker's). An unknown kind lists them. This module imports no source: an ``opener`` imports what it opens when it
runs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from recorder.config import ConfigError
from recorder.plugins import load_plugins

SCRIPTED = "scripted"  # no tracker: the task's script (or a free-wrist task's demonstrator) moves the base
SPECS = (  # for help texts; errors list the registered kinds (specs())
    "scripted, udp:PORT, udp:HOST:PORT or marker:CAMERA (a device index, video file or stream URL), or mcap:FILE "
    "(a session log's tracker poses), or a plugin's KIND:ADDRESS"
)


@dataclass(frozen=True)
class WristKind:
    """A kind of wrist source that ``--wrist KIND:ADDRESS`` opens.

    ``opener(config, **options)`` returns the unopened source: a recorder.wrist.base.WristSource (a reader thread
    that queues poses stamped in Unix time, or in video time with ``video_clock``), or an object with ``name``,
    ``open()``, ``until(t)`` and ``close()`` that makes the poses up to the loop's time ``t`` itself, on the loop's
    clock (recorder/wrist/track.py EmulatedMarker). A source may say its ``latency_s`` (capture to stamp; the
    fusion takes it) and ``finished``. The options, which an opener takes or leaves (``**options``): ``paced`` (a
    file plays at its recorded rate; False: as fast as it reads), ``camera_file`` and ``marker_mm`` (a marker
    camera's calibration and the marker's size), ``glove`` (the recording's GloveConfig) and ``wearer`` (the
    emulated wearer's palm: ``wearer(t) -> (position, quat)`` in the robot's world at the loop's time t).

    ``spec``: how it is written, for help and errors; ``check(address) -> address``: the address as the config
    keeps it, ConfigError for a bad one (when the spec is parsed, before anything opens); ``bare``: the kind alone,
    with no address, is a source too; ``wearer``: it follows the emulated wearer, so it needs the emulator's
    demonstrator (`gloverec record` and `gloverec calibrate --wrist` with ``--glove emulator``; the views have
    none); ``seen``: what the tracker sees, as the views name it when it is lost ("marker lost: hold still")."""

    name: str
    opener: Callable
    spec: str
    check: Callable[[str], str] | None = None
    bare: bool = False
    wearer: bool = False
    seen: str = "tracker"


_SOURCES: dict[str, WristKind] = {}


def register_wrist_source(
    name: str, *, spec: str | None = None, check=None, bare: bool = False, wearer: bool = False, seen: str = "tracker"
):
    """Decorator of a source's ``opener(config, **options)``: wrist kind ``name`` (WristKind says the rest)."""

    def register(opener):
        if name == SCRIPTED or (name in _SOURCES and _SOURCES[name].opener.__qualname__ != opener.__qualname__):
            raise ConfigError(f"wrist source {name!r} is registered already")
        _SOURCES[name] = WristKind(name, opener, spec or f"{name}:ADDRESS", check, bare, wearer, seen)
        return opener

    return register


def wrist_source(kind: str) -> WristKind:
    """The registered source ``kind``; an unknown one: one-line ConfigError listing the kinds."""
    _load()
    if kind not in _SOURCES:
        raise ConfigError(f"unknown wrist source {kind!r}; valid: {specs()}")
    return _SOURCES[kind]


def kinds() -> tuple[str, ...]:
    _load()
    return (SCRIPTED, *_SOURCES)


def specs() -> str:
    """How wrist sources are written, for errors."""
    _load()
    return f"{SCRIPTED}, " + " or ".join(s.spec for s in _SOURCES.values())


def seen(kind: str) -> str:
    """What the source ``kind`` tracks, as the views name it when it is lost: "marker" or "tracker" (any other)."""
    _load()
    source = _SOURCES.get(kind)
    return source.seen if source is not None else "tracker"


def _load() -> None:
    import recorder.wrist.sources  # noqa: F401  (the built-in sources register on import; here: they import this)

    load_plugins()


@dataclass(frozen=True)
class WristConfig:
    """A wrist source. ``kind``: scripted or a registered source; ``address``: what it opens, as its check keeps
    it (udp: HOST:PORT; marker: the camera, a device index, a video file or a stream URL; marker:emulated: the
    marker's mounting, RX,RY,RZ or none; mcap: the session log)."""

    kind: str = SCRIPTED
    address: str = ""

    @classmethod
    def parse(cls, spec: str | WristConfig) -> WristConfig:
        if isinstance(spec, WristConfig):
            return spec
        text = str(spec).strip()
        if text == SCRIPTED:
            return cls()
        _load()
        kind = max((k for k in _SOURCES if text == k or text.startswith(f"{k}:")), key=len, default=None)
        address = text[len(kind) + 1 :] if kind is not None else ""
        if kind is None or not (address or _SOURCES[kind].bare):
            raise ConfigError(f"unknown wrist source {text!r}; valid: {specs()}")
        check = _SOURCES[kind].check
        return cls(kind, check(address) if check is not None else address)

    @property
    def source(self) -> WristKind | None:
        """The registered source (None: scripted, no tracker)."""
        return None if self.kind == SCRIPTED else wrist_source(self.kind)

    @property
    def follows_wearer(self) -> bool:
        """The source follows the emulated wearer (``marker:emulated``): only the emulator's demonstrator has one."""
        return self.kind != SCRIPTED and wrist_source(self.kind).wearer

    def __str__(self) -> str:
        return f"{self.kind}:{self.address}" if self.address else self.kind
