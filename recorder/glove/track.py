"""The glove's recent hand poses on the loop's clock, and the pose at any frame time: joint angles interpolated
linearly and the palm by SLERP between the samples around it (HandPose.between). Fed with (sample time,
HandPose) by recorder.glove.Glove."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from recorder.hand.pose import HandPose


@dataclass
class PoseAt:
    pose: HandPose  # the hand at the asked time (stamps of the newest sample used)
    newest_s: float  # sample time of the newest sample used (latency is measured from it)
    held: bool  # no sample after the asked time yet: the newest pose was held (a late glove frame)
    age_s: float  # asked time minus the newest sample time used (0 when interpolating)


class PoseTrack:
    """A short history of timestamped poses. ``at(t)`` interpolates; samples must come in time order."""

    def __init__(self, horizon: int = 256):
        self._t: deque[float] = deque(maxlen=horizon)
        self._p: deque[HandPose] = deque(maxlen=horizon)

    def push(self, t: float, pose: HandPose) -> None:
        if self._t and t <= self._t[-1]:
            return  # out of order or duplicate: keep the track monotonic
        self._t.append(t)
        self._p.append(pose)

    def __len__(self) -> int:
        return len(self._t)

    @property
    def newest_s(self) -> float | None:
        return self._t[-1] if self._t else None

    @property
    def newest(self) -> HandPose | None:
        return self._p[-1] if self._p else None

    def at(self, t: float) -> PoseAt | None:
        """The pose at time ``t``; None before the first sample."""
        if not self._t:
            return None
        ts = self._t
        if t >= ts[-1]:
            return PoseAt(self._p[-1], ts[-1], t > ts[-1], t - ts[-1])
        if t <= ts[0]:
            return PoseAt(self._p[0], ts[0], False, 0.0)
        i = int(np.searchsorted(np.fromiter(ts, float, len(ts)), t))  # ts[i-1] < t <= ts[i]
        w = (t - ts[i - 1]) / (ts[i] - ts[i - 1])
        return PoseAt(self._p[i - 1].between(self._p[i], w), ts[i], False, 0.0)

    def interval_s(self, default: float) -> float:
        """The glove's sample interval: median spacing of the last samples (``default`` before there are any)."""
        if len(self._t) < 8:
            return default
        recent = np.fromiter(self._t, float, len(self._t))[-33:]
        return float(np.median(np.diff(recent)))

    def drop_before(self, t: float) -> None:
        """Forget samples older than the one just before ``t`` (keeps what interpolation at >= t needs)."""
        while len(self._t) > 2 and self._t[1] <= t:
            self._t.popleft()
            self._p.popleft()


class FrameRate:
    """Frames per second of glove time over the last ``window_s``: a count over a window, not a median of the
    intervals, so a glove whose frames arrive in bursts (an emulator or a USB stack catching up: intervals of
    0.1 ms, then 50 ms) reads as the rate it really sends, and a glove resting before host fusion starts (no poses
    yet) as sending."""

    def __init__(self, window_s: float = 1.0):
        self.window_s = float(window_s)
        self._t: deque[float] = deque()
        self._full = False  # frames older than the window have come: it is covered from end to end

    def add(self, t: float) -> None:
        self._t.append(t)
        while self._t[0] <= t - self.window_s:
            self._t.popleft()
            self._full = True

    def hz(self, default: float = 0.0) -> float:
        """The rate: frames in the last ``window_s`` over its length, or over the time since the first frame while
        the window is not yet covered (``default`` before two frames)."""
        t = self._t
        if self._full:
            return len(t) / self.window_s
        if len(t) < 2 or t[-1] <= t[0]:
            return default
        return (len(t) - 1) / (t[-1] - t[0])
