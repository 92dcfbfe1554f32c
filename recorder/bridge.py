"""Serial -> UDP bridge (the thesis' serial_bridge.py, framing-aware).

Each complete frame (binary, up to its 0x00) or JSON line is sent as its own datagram, so a lost datagram
costs one frame and a receiver never joins pieces of two frames. Commands the UDP peer sends back are
forwarded to the glove.
"""

from __future__ import annotations

import socket

from recorder.link.base import GloveSource


class Bridge:
    def __init__(self, source: GloveSource, host: str, port: int):
        self.source = source
        self.target = (host, port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(0.0)
        self.datagrams = 0
        self.send_errors = 0  # counted, not raised: this runs in the reader thread
        self._buf = b""
        source.taps.append(self._on_bytes)

    def _on_bytes(self, data: bytes, rx_ns: int, frames: list) -> None:
        sep = b"\n" if self.source.decoder.protocol == "json" else b"\x00"
        self._buf += data
        *whole, self._buf = self._buf.split(sep)
        for piece in whole:
            if piece:
                try:
                    self.sock.sendto(piece + sep, self.target)
                    self.datagrams += 1
                except OSError:
                    self.send_errors += 1
        if len(self._buf) > 65536:
            self._buf = b""

    def forward_commands(self) -> None:
        """Pass datagrams that came back from the UDP side (host commands) on to the glove."""
        while True:
            try:
                data = self.sock.recv(2048)
            except (BlockingIOError, OSError):
                return
            self.source.send(data)
