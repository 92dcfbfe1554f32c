"""UdpWrist: wrist poses from a tracker over UDP (recorder/wrist/format.py), read by a thread. Datagrams that are
not wrist poses are counted and skipped; late ones (an older ``seq`` than the newest) are dropped."""

from __future__ import annotations

import socket
import threading
import time
from collections import deque

from recorder import GloverecError
from recorder.wrist.format import WristFormatError, WristPose, decode


class UdpWrist:
    def __init__(self, host: str, port: int):
        self.host, self.port = host, port
        self.name = f"udp:{host}:{port}"
        self.bad = 0  # datagrams that were not wrist poses
        self.late = 0  # older than the newest pose
        self.last_error: str | None = None
        self.finished = False  # a live stream never finishes
        self._queue: deque[tuple[WristPose, float]] = deque(maxlen=4096)  # (pose, arrival, Unix time)
        self._sock: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._newest_seq: int | None = None

    def open(self) -> UdpWrist:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind((self.host, self.port))
        except OSError as exc:
            sock.close()
            raise GloverecError(f"cannot listen for wrist poses on {self.name}: {exc.strerror or exc}") from None
        sock.settimeout(0.05)
        self._sock = sock
        self._thread = threading.Thread(target=self._run, name="wrist-udp", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def __enter__(self) -> UdpWrist:
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

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

    def take(self) -> list[tuple[WristPose, float]]:
        """The poses that arrived since the last call, each with its arrival time (Unix s)."""
        out = []
        while self._queue:
            out.append(self._queue.popleft())
        return out
