"""Frames over UDP (wireless gloves, or `gloverec bridge`). One datagram holds whole frames: a torn or lost
datagram costs its own frames only, and late datagrams are dropped by sequence number, never reassembled."""

from __future__ import annotations

import socket

from recorder.link.base import GloveSource


class UdpSource(GloveSource):
    boundary = True
    can_reconnect = False

    def __init__(self, port: int, host: str = "0.0.0.0", **kw):
        super().__init__(**kw)
        self.addr = (host, port)
        self.name = f"udp:{host}:{port}"
        self._sock: socket.socket | None = None
        self._peer: tuple | None = None

    def _connect(self) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        self._sock.bind(self.addr)
        self._sock.settimeout(0.05)

    def _read(self) -> bytes:
        try:
            data, self._peer = self._sock.recvfrom(65536)
        except TimeoutError:
            return b""
        return data

    def _disconnect(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def send(self, data: bytes) -> None:
        """Commands go back to whoever sent the last datagram (a wireless glove, or a bridge)."""
        if self._sock is not None and self._peer is not None:
            self._sock.sendto(data, self._peer)
