"""Glove source specs, as the CLI takes them: ``serial:PORT`` (or a bare path), ``udp:PORT``,
``udp:HOST:PORT`` and ``mcap:FILE``."""

from __future__ import annotations

from recorder import GloverecError
from recorder.link.base import GloveSource

SPECS = "serial:PORT, a device path, udp:PORT, udp:HOST:PORT or mcap:FILE"


def open_source(spec: str, *, realtime: bool = True, **kw) -> GloveSource:
    """Create and open the source ``spec`` names. ``realtime`` paces log playback at recorded speed."""
    return make_source(spec, realtime=realtime, **kw).open()


def make_source(spec: str, *, realtime: bool = True, **kw) -> GloveSource:
    kind, _, rest = spec.partition(":")
    if kind == "udp":
        from recorder.link.udp_source import UdpSource

        host, _, port = rest.rpartition(":")
        if not port.isdigit() or not 0 < int(port) < 65536:
            raise GloverecError(f"bad UDP source {spec!r}: expected udp:PORT or udp:HOST:PORT")
        return UdpSource(int(port), host or "0.0.0.0", **kw)
    if kind == "mcap":
        from recorder.log.playback import McapSource

        return McapSource(rest, realtime=realtime, **kw)
    from recorder.link.serial_source import SerialSource

    port = rest if kind == "serial" else spec
    if not port:
        raise GloverecError(f"bad glove source {spec!r}: expected {SPECS}")
    return SerialSource(port, **kw)
