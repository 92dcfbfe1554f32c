"""How fast a view draws: up to its frame rate while the command keeps time, backing off (down to MIN_FPS) when
the command reports late ticks. A view in the idle scheduling class takes no CPU the command needs, but what it
feeds does (the X server of a native window, the browser showing the web page): drawing less then leaves more."""

from __future__ import annotations

MIN_FPS = 4.0
LATE_MS = 1.0  # a loop tick this late (ms) in the command's last ticks: back off


class Pace:
    def __init__(self, fps: float):
        self.max_fps = float(fps)
        self.fps = float(fps)

    def period(self, status: dict) -> float:
        """The time to the next frame, given the newest frame's status (its ``late_ms``)."""
        if float(status.get("late_ms") or 0.0) > LATE_MS:
            self.fps = max(MIN_FPS, self.fps / 2.0)
        else:
            self.fps = min(self.max_fps, self.fps * 1.1)
        return 1.0 / self.fps
