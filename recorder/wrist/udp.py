"""UdpWrist: wrist poses from a tracker over UDP (recorder/wrist/format.py), read by a thread. Datagrams that are
not wrist poses are counted and skipped; late ones (an older ``seq`` than the newest) are dropped."""

from __future__ import annotations

import socket
import time

from recorder import GloverecError
from recorder.wrist.base import WristSource
from recorder.wrist.format import WristFormatError, decode


class UdpWrist(WristSource):
    def __init__(self, host: str, port: int):
        super().__init__()
        self.host, self.port = host, port
        self.name = f"udp:{host}:{port}"
        self._sock: socket.socket | None = None
        self._newest_seq: int | None = None

    def _open(self) -> tuple:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind((self.host, self.port))
        except OSError as exc:
            sock.close()
            raise GloverecError(f"cannot listen for wrist poses on {self.name}: {exc.strerror or exc}") from None
        sock.settimeout(0.05)
        self._sock = sock
        return ()

    def _release(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self._sock.recv(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            arrived = time.time()
            try:
                pose = decode(data)
            except WristFormatError as exc:
                self.bad += 1
                self.last_error = str(exc)
                continue
            if self._newest_seq is not None and 0 < (self._newest_seq - pose.seq) % 2**32 < 2**31:
                self.late += 1
                continue
            self._newest_seq = pose.seq
            self._queue.append((pose, arrived))
