"""How the recording loop keeps time: one of two clocks, chosen once per session (``clock_for``), so the loop
itself never asks which.

- ``RealTimeClock`` (`--realtime`, serial and UDP gloves): frame k of an episode is taken at host time
  host0 + k / fps; the loop sleeps until then, counts its jitter and overruns, and reads the glove ``delay_s`` behind
  the tick (1.5 measured sample intervals) so that the sample after the frame time has nearly always arrived.
  Latency is measured (glove sample -> applied action), the device clock is mapped onto the host's, no cyclic
  garbage collection runs during an episode (a full collection of this heap stalls the loop for tens of ms), and
  the episode's latency path runs in the real-time scheduling class where the system allows
  (recorder/record/precedence.py), so that other programs, a browser showing the view among them, do not delay it.
- ``GloveClock`` (`--fast`, the emulator and logs): the loop ticks on the glove's own device clock and advances as
  fast as frames arrive; nothing is measured against a wall clock.
"""

from __future__ import annotations

import gc
import time
from contextlib import ExitStack, contextmanager

import numpy as np

from recorder.record import precedence

LOST, ENDED = "lost", "ended"  # what a tick may find instead of a frame time


@contextmanager
def _no_gc_pauses(enabled: bool):
    """No cyclic garbage collection inside (what an episode leaves is collected in the reset period); reference
    counting still frees everything else at once."""
    if not enabled or not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


class LoopClock:
    """What both clocks share: the glove, the frame period and the read delay (0 unless real time)."""

    realtime: bool
    label: str
    precedence = False  # whether episodes run in the real-time scheduling class (recorder/record/precedence.py)

    def __init__(self, glove, fps: int, nominal_rate_hz: float):
        self.glove, self.period, self.nominal_rate_hz = glove, 1.0 / fps, nominal_rate_hz
        self.delay_s = 0.0

    def pose_time(self, tick: float) -> float:
        """The glove time whose pose frame ``tick`` takes."""
        return tick - self.delay_s


class RealTimeClock(LoopClock):
    realtime = True
    label = "real time"

    def __init__(self, glove, fps: int, nominal_rate_hz: float):
        super().__init__(glove, fps, nominal_rate_hz)
        self.host0 = 0.0
        self.precedence, self._why_not = precedence.available()  # asked once: the live view's priority follows it

    def session(self) -> str | None:
        """Before the first episode: the heap of torch, lerobot and mujoco (~0.3 s to traverse) is never looked at
        by the collector again. Returns the line to say when the loop may not take precedence."""
        gc.collect()
        gc.freeze()
        return self._why_not

    @contextmanager
    def episode(self):
        """The context of an episode's frames: no cyclic collection, and the loop's precedence."""
        with ExitStack() as stack:
            stack.enter_context(_no_gc_pauses(True))
            stack.enter_context(precedence.precedence(self.precedence))
            yield

    def first_frames(self, timeout_s: float) -> bool:
        return True  # the reset period polls the link itself

    def advance(self) -> None:
        pass  # the host clock advances by itself

    def start(self, start: float) -> None:
        """Episode start at glove time ``start``: the read delay from the glove's measured sample interval."""
        g = self.glove
        self.delay_s = float(np.clip(1.5 * g.track.interval_s(1.0 / self.nominal_rate_hz), 1e-3, 0.05))
        self.host0 = time.monotonic() - (g.now() - start)

    def tick(self, k: int, tick: float, stats) -> float | str:
        """Wait for frame k (glove time ``tick``); its host time, or LOST when the glove went away."""
        host_tick = self.host0 + k * self.period
        delay = host_tick - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        late = time.monotonic() - host_tick
        stats.jitter_s.append(abs(late))
        if late > self.period:
            stats.overruns += 1
        self.glove.poll()
        return host_tick if self.glove.connected else LOST

    def latency(self, at) -> float:
        return time.monotonic() - at.newest_s

    def device_time(self, at, t: float) -> float:
        """The glove's device clock (s, unwrapped) at loop time ``t``; -1 for gloves without one."""
        return self.glove.device_time_s(at.pose, at.newest_s, t)

    def log_range(self, logger, start: float, frames: int) -> dict:
        """The episode's span in the MCAP log's time base (ns since the epoch)."""
        off = logger.log_time_offset_ns
        return {"start_ns": int(start * 1e9) + off, "end_ns": int((start + frames * self.period) * 1e9) + off}


class GloveClock(LoopClock):
    realtime = False
    label = "faster than real time"

    def session(self) -> str | None:
        return None

    def episode(self):
        return _no_gc_pauses(False)

    def first_frames(self, timeout_s: float) -> bool:
        return self.glove.wait_past(float("-inf"), timeout_s)

    def advance(self) -> None:
        self.glove.wait_past(self.glove.now() + self.period)  # let glove time advance

    def start(self, start: float) -> None:
        self.delay_s = 0.0

    def tick(self, k: int, tick: float, stats) -> float | str:
        return time.monotonic() if self.glove.wait_past(tick) else ENDED

    def latency(self, at) -> None:
        return None  # no wall clock to measure against

    def device_time(self, at, t: float) -> float:
        return t

    def log_range(self, logger, start: float, frames: int) -> dict:
        return {"glove_time_start_s": start, "glove_time_end_s": start + frames * self.period}


def clock_for(fast: bool, glove, fps: int, nominal_rate_hz: float) -> LoopClock:
    return (GloveClock if fast else RealTimeClock)(glove, fps, nominal_rate_hz)
