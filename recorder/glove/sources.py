"""The built-in glove sources (recorder/glove/config.py ``register_glove_source``): the emulator in this process, a
serial device, a UDP stream, an MCAP session log played back. Each opener builds the link it names, unopened; the
links load when used.

The emulator's opener sits in a layer above this one (recorder/emulator/source.py): it is named here, as the
task registry names a task's demonstrator, and imported when an emulated glove opens."""

from __future__ import annotations

import os

from recorder import GloverecError
from recorder.glove.config import EMULATOR, register_glove_source, udp_address

register_glove_source(EMULATOR, device=False, address=False)("recorder.emulator.source:emulated")


def _port_present(address: str) -> None:
    if not os.path.exists(address):  # as SerialSource.check says it when the glove opens
        raise GloverecError(f"cannot open serial:{address}: no such port")


def _log_present(address: str) -> None:
    if not os.path.isfile(address):
        raise GloverecError(f"cannot read {address}: no such file")


@register_glove_source("serial", device=True, spec="serial:PORT (or a device path)", present=_port_present)
def serial(config, realtime: bool = True, **options):
    from recorder.link.serial_source import (
        SerialSource,  # the link loads when a glove of this kind opens, not at start-up
    )

    return SerialSource(config.address, baudrate=config.baudrate, **options)


@register_glove_source("udp", device=True, spec="udp:PORT, udp:HOST:PORT", check=udp_address)
def udp(config, realtime: bool = True, **options):
    from recorder.link.udp_source import UdpSource  # the link loads when a glove of this kind opens, not at start-up

    host, port = udp_address(config.address)
    return UdpSource(port, host, **options)


@register_glove_source("mcap", device=False, spec="mcap:FILE (a session log)", present=_log_present)
def mcap(config, realtime: bool = True, **options):
    from recorder.log.playback import McapSource  # the link loads when a glove of this kind opens, not at start-up

    return McapSource(config.address, realtime=realtime, **options)
