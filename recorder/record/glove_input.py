"""The glove side of the recording loop: a source (or the emulator driven by the scripted demonstrator),
host fusion of raw frames, the pose track on the loop's clock, and the glove's button events.

The loop's clock ("glove time") is the host's monotonic clock when recording in real time (device times are
mapped onto it), and the glove's own device clock when recording faster than real time (the loop then advances
as fast as the frames arrive).
"""

from __future__ import annotations

import time
from typing import NamedTuple

from recorder import GloverecError
from recorder.link.sources import make_source
from recorder.protocol import EventCode, EventFrame, PoseCompactFrame, PoseFrame, RawFrame
from recorder.record.pose_track import PoseTrack

TRANSITION_S = 0.8   # the emulated hand's move back to a demonstration's start pose


class Sample(NamedTuple):
    """What the pose track keeps beside each pose."""

    t_us: int               # device time stamp (-1: legacy JSON)
    rx_ns: int              # host receive time
    quality: float | None   # host fusion's disturbance estimate, None without host fusion


class GloveInput:
    def __init__(self, spec: str, fast: bool, *, rate_hz: float = 200.0, mode: str = "pose", seed: int = 0,
                 fusion=None):
        self.fast = fast
        self.fusion = fusion
        self.emulator = None
        self.session = None
        if spec == "emulator":
            from recorder.demonstrator.session import SessionMotion
            from recorder.emulator.emulator import Emulator

            self.session = SessionMotion(seed=seed, rate_hz=rate_hz)
            self.emulator = Emulator(rate_hz, mode, self.session, seed=seed)
            self.emulator.realtime = not fast  # before plug(): its first status frame states the clock
            spec = self.emulator.plug()
        self.source = make_source(spec, realtime=not fast)
        self.spec = spec if self.emulator is None else "emulator"
        self.track = PoseTrack()
        self.buttons: list[float] = []   # glove times of button presses not yet taken
        self.frames = 0
        self._thread = None

    # ------------------------------------------------------------ lifecycle
    def open(self) -> "GloveInput":
        self.source.open()
        if self.emulator is not None:
            import threading

            self._thread = threading.Thread(target=self.emulator.run, kwargs={"realtime": not self.fast},
                                            name="gloverec-emulator", daemon=True)
            self._thread.start()
        return self

    def close(self) -> None:
        if self.emulator is not None:
            self.emulator.stop()
            if self._thread is not None:
                self._thread.join(timeout=2.0)
            self.emulator.close()
        self.source.close()

    # ------------------------------------------------------------ the demonstrator (emulator only)
    def demonstrate(self, demo, lead_s: float = 0.0) -> None:
        """Have the emulated hand perform ``demo`` next; its glove presses the button as the demo starts."""
        start = self.emulator.horizon_s + TRANSITION_S + lead_s
        self.session.append(demo, start, TRANSITION_S)
        self.emulator.schedule_button(start)

    # ------------------------------------------------------------ frames in
    def time_of(self, frame) -> float:
        if frame.t_us < 0:  # legacy JSON: no device clock
            return frame.rx_ns * 1e-9
        if self.fast:
            return self.source.clock.unwrap(frame.t_us, frame.rx_ns)
        return self.source.host_time_s(frame)

    def poll(self, timeout: float = 0.0, until: float | None = None) -> int:
        """Take frames that have arrived (waiting up to ``timeout`` for the first); returns how many.

        Real time: everything queued. Fast: one frame at a time and only until the track reaches ``until``
        (default: one more frame), so the track never skips past the frame times the loop still needs."""
        n = 0
        if not self.fast:
            first = self.source.read(timeout) if timeout > 0 else None
            for f in ([first] if first is not None else []) + self.source.drain():
                self._take(f)
                n += 1
            return n
        while True:
            f = self.source.read(timeout if n == 0 else 0.0)
            if f is None:
                return n
            self._take(f)
            n += 1
            newest = self.track.newest_s
            if until is None or (newest is not None and newest >= until):
                return n

    def _take(self, f) -> None:
        if isinstance(f, PoseFrame):
            self.frames += 1
            self.track.push(self.time_of(f), f.quats, Sample(f.t_us, f.rx_ns, None))
        elif isinstance(f, PoseCompactFrame):
            self.frames += 1
            self.track.push(self.time_of(f), f.relative_quats(), Sample(f.t_us, f.rx_ns, None))
        elif isinstance(f, RawFrame):
            if self.fusion is None:
                raise GloverecError("the glove sends raw IMU frames but no host fusion is configured")
            fused = self.fusion.process(f)
            if fused is not None:
                self.frames += 1
                self.track.push(self.time_of(f), fused.quats, Sample(f.t_us, f.rx_ns, fused.quality))
        elif isinstance(f, EventFrame) and f.code == EventCode.BUTTON:
            self.buttons.append(self.time_of(f))

    def take_button(self) -> float | None:
        return self.buttons.pop(0) if self.buttons else None

    def now(self) -> float:
        """The loop's clock: host monotonic time, or (fast) the newest glove sample's time."""
        if not self.fast:
            return time.monotonic()
        return self.track.newest_s if self.track.newest_s is not None else float("-inf")

    def wait_past(self, t: float, timeout_s: float = 5.0) -> bool:
        """Fast mode: take frames until the track has a sample at or after ``t``; False if none comes."""
        end = time.monotonic() + timeout_s
        while self.track.newest_s is None or self.track.newest_s < t:
            if self.poll(timeout=0.05, until=t) == 0 and (self.source.finished or time.monotonic() > end):
                return False
        return True

    @property
    def connected(self) -> bool:
        return self.source.connected

    @property
    def finished(self) -> bool:
        return self.source.finished
