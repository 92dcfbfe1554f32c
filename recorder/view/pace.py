"""How fast a view draws: up to its frame rate while the command keeps time, backing off (down to MIN_FPS) when
the command reports late ticks (``late_ms``, against ``period_ms``). A view in the idle scheduling class takes no
CPU the command needs, but what it feeds does (the X server of a native window, the browser showing the web page):
drawing less then leaves more.
``note`` is the line that tells the person when the view draws less than it would, and why."""

from __future__ import annotations

import time
from collections import deque

MIN_FPS = 4.0
LATE_MS = 1.0  # a loop tick this late (ms) in the command's last ticks: back off ...
LATE_SHARE = 0.1  # ... or this share of its frame period, when the status gives it (``period_ms``): at 30 fps a
# tick 2-3 ms late (what a loaded machine gives even in the real-time class) is harmless, at 100 fps it is not
SLOW = 0.6  # drawn at under this share of the frame rate: say so
WINDOW_S = 2.0  # the drawn rate is counted over this many seconds


class Pace:
    def __init__(self, fps: float):
        self.max_fps = float(fps)
        self.fps = float(fps)
        self.backed_off = False  # the last frame's status said the command was late
        self._drawn: deque = deque()

    def period(self, status: dict, now: float | None = None) -> float:
        """The time to the next frame, given the newest frame's status (its ``late_ms``); a call per frame drawn
        (at ``now``, default the monotonic clock's)."""
        now = time.monotonic() if now is None else now
        self._drawn.append(now)
        while self._drawn and self._drawn[0] < now - WINDOW_S:
            self._drawn.popleft()
        late = max(LATE_MS, LATE_SHARE * float(status.get("period_ms") or 0.0))
        self.backed_off = float(status.get("late_ms") or 0.0) > late
        if self.backed_off:
            self.fps = max(MIN_FPS, self.fps / 2.0)
        else:
            self.fps = min(self.max_fps, self.fps * 1.1)
        return 1.0 / self.fps

    @property
    def drawn_fps(self) -> float:
        """Frames drawn per second over the last WINDOW_S."""
        n = len(self._drawn)
        span = self._drawn[-1] - self._drawn[0] if n > 1 else 0.0
        return (n - 1) / span if span > 0 else 0.0

    def note(self) -> str | None:
        """What the person should know about the view's rate, or None while it draws at its full rate."""
        drawn = self.drawn_fps
        if len(self._drawn) < 3 or drawn >= SLOW * self.max_fps:
            return None
        if self.backed_off or self.fps < SLOW * self.max_fps:
            return f"slowed to {drawn:.0f} frames/s to keep the recording on time"
        return f"{drawn:.0f} frames/s: the view draws with the CPU the recording and other programs leave"
