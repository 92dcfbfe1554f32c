"""A glove source: a background reader thread that turns transport bytes into timestamped frames.

Subclasses provide ``_connect``, ``_read`` (bytes, b"" on timeout) and ``_disconnect``; this class owns the
decoder, the bounded frame queue (the oldest frame is dropped and counted when the consumer falls behind),
the device clock, the counters and reconnection: when ``_read`` raises OSError the transport is closed and
reopened every ``retry_s`` until it comes back, and the decoder and clock restart.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

from recorder import GloverecError
from recorder.link.clock import DeviceClock
from recorder.protocol import CommandCode, StreamDecoder, encode_command
from recorder.protocol.frames import CLOCK_HOST_MONOTONIC, Frame, StatusFrame

# tap(data, rx_ns, frames): sees every chunk of bytes as read and the frames decoded from it (logging, bridging)
Tap = Callable[[bytes, int, list], None]


@dataclass
class LinkStats:
    protocol: str | None = None
    connected: bool = False
    reconnects: int = 0
    disconnected_s: float = 0.0
    queue_drops: int = 0
    clock_offset_s: float = 0.0
    clock_drift_ppm: float = 0.0
    decode: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return asdict(self)


class GloveSource:
    """Base of all glove sources. Use as a context manager; ``read()`` returns the next frame or None."""

    name = "glove"
    boundary = False  # True when each read is a whole datagram
    can_reconnect = True

    def __init__(self, queue_size: int = 4096, retry_s: float = 0.2, protocol: str = "auto"):
        self.decoder = StreamDecoder(protocol)
        self.clock = DeviceClock()
        self.taps: list[Tap] = []
        self.retry_s = retry_s
        self._queue: deque[Frame] = deque(maxlen=queue_size)
        self._cond = threading.Condition()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._connected = False
        self._reconnects = 0
        self._queue_drops = 0
        self._command_seq = 0
        self._down_since: float | None = None
        self._down_total = 0.0
        self.finished = False  # the source ended (a log played to its end); read() then returns None at once
        # a source that runs faster than real time (the emulator's bulk generation): the reader waits for room
        # in the queue instead of dropping the oldest frames, and the wait backs up to the sender (the pty fills)
        self.lossless = False
        # a source that knows its glove before it sends (the emulator in this process) says what host fusion is to
        # expect: SessionFusion.expect's glove_id, raw and rest_angles, or {} when its frames are read as they come,
        # unfused (the emulator calibrating); None: the glove is learnt from its frames
        self.expects: dict | None = None

    # ------------------------------------------------------------ lifecycle
    def check(self) -> None:
        """Raise GloverecError now if the link cannot open (a device that is not there), before a command spends
        time on anything else; what cannot be known without connecting is left to ``open``."""

    def open(self) -> GloveSource:
        if self._thread is not None:  # already open (open_source() opens; `with` may follow)
            return self
        try:
            self._connect()
        except OSError as exc:
            raise GloverecError(f"cannot open {self.name}: {exc.strerror or exc}") from None
        self._connected = True
        self._thread = threading.Thread(target=self._run, name=f"gloverec-{self.name}", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        with self._cond:
            self._cond.notify_all()  # a reader waiting for room (lossless) wakes and stops
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        if self._connected:
            self._safe_disconnect()
        with self._cond:
            self._cond.notify_all()

    def __enter__(self) -> GloveSource:
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------ consumer side
    def read(self, timeout: float | None = None) -> Frame | None:
        """The oldest queued frame, waiting up to ``timeout`` seconds (None: forever); None on timeout."""
        with self._cond:
            if not self._queue and not self.finished:
                self._cond.wait_for(lambda: self._queue or self.finished or self._stop.is_set(), timeout)
            if not self._queue:
                return None
            if self.lossless:
                self._cond.notify_all()  # room for a waiting reader
            return self._queue.popleft()

    def drain(self) -> list[Frame]:
        with self._cond:
            frames = list(self._queue)
            self._queue.clear()
            self._cond.notify_all()
            return frames

    def send(self, data: bytes) -> None:
        """Send bytes (an encoded command) to the glove."""
        raise GloverecError(f"{self.name} cannot send commands")

    def command(self, code: CommandCode, arg: int = 0) -> None:
        """Send a host command (docs/protocol.md), numbered with this host's own sequence."""
        self._command_seq = (self._command_seq + 1) & 0xFFFF
        self.send(encode_command(code, arg, self._command_seq))

    def host_time_s(self, frame: Frame) -> float:
        """Host monotonic time (s) at which the device sampled ``frame``; receive time when it has no clock."""
        if frame.t_us < 0:
            return frame.rx_ns * 1e-9
        return self.clock.to_host_s(self.clock.unwrap(frame.t_us, frame.rx_ns))

    @property
    def connected(self) -> bool:
        return self._connected

    def stats(self) -> LinkStats:
        down = self._down_total + (time.monotonic() - self._down_since if self._down_since else 0.0)
        return LinkStats(
            self.decoder.protocol,
            self._connected,
            self._reconnects,
            round(down, 3),
            self._queue_drops,
            self.clock.offset_s,
            self.clock.drift * 1e6,
            self.decoder.stats.as_dict(),
        )

    # ------------------------------------------------------------ reader thread
    def _run(self) -> None:
        while not self._stop.is_set():
            if not self._connected:
                self._try_reconnect()
                continue
            try:
                data = self._read()
            except OSError:
                self._on_lost()
                continue
            if data:
                self._ingest(data, time.monotonic_ns())

    def _ingest(self, data: bytes, rx_ns: int) -> None:
        frames = self.decoder.feed(data, boundary=self.boundary)
        for f in frames:
            f.rx_ns = rx_ns
            if isinstance(f, StatusFrame):
                self.clock.host_monotonic = bool(f.clock_flags & CLOCK_HOST_MONOTONIC)
            elif f.t_us >= 0:
                self.clock.update(self.clock.unwrap(f.t_us, rx_ns), rx_ns)
        if frames:
            with self._cond:
                if self.lossless:
                    room = max(self._queue.maxlen - len(frames), 0)
                    self._cond.wait_for(lambda: len(self._queue) <= room or self._stop.is_set())
                overflow = len(self._queue) + len(frames) - self._queue.maxlen
                if overflow > 0:
                    self._queue_drops += overflow
                self._queue.extend(frames)
                self._cond.notify_all()
        for tap in self.taps:  # after queueing, so logging adds no latency to the consumer
            tap(data, rx_ns, frames)

    def _on_lost(self) -> None:
        self._safe_disconnect()
        self._connected = False
        self._down_since = time.monotonic()
        self.decoder.reset()
        self.clock.reset()

    def _try_reconnect(self) -> None:
        if not self.can_reconnect:
            self._stop.wait(self.retry_s)
            return
        try:
            self._connect()
        except OSError:
            self._stop.wait(self.retry_s)
            return
        self._connected = True
        self._reconnects += 1
        if self._down_since is not None:
            self._down_total += time.monotonic() - self._down_since
            self._down_since = None

    def _safe_disconnect(self) -> None:
        try:
            self._disconnect()
        except OSError:
            pass

    def _finish(self) -> None:
        """Mark the source as ended (used by finite sources such as log playback)."""
        self.finished = True
        with self._cond:
            self._cond.notify_all()

    # ------------------------------------------------------------ transport (subclasses)
    def _connect(self) -> None:
        raise NotImplementedError

    def _read(self) -> bytes:
        raise NotImplementedError

    def _disconnect(self) -> None:
        raise NotImplementedError
