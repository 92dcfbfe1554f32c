"""The glove's recent hand poses on the host clock, and the pose at any frame time (SLERP between the
samples around it). Fed with (sample time, 16 parent-relative quaternions) by the recording loop."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from recorder import quat


@dataclass
class PoseAt:
    quats: np.ndarray  # (16, 4) parent-relative quaternions at the asked time
    newest_s: float  # sample time of the newest sample used (latency is measured from it)
    held: bool  # no sample after the asked time yet: the newest pose was held (a late glove frame)
    age_s: float  # asked time minus the newest sample time used (0 when interpolating)
    extra: object = None  # what was pushed with the newest sample used


class PoseTrack:
    """A short history of timestamped poses. ``at(t)`` interpolates; samples must come in time order."""

    def __init__(self, horizon: int = 256):
        self._t: deque[float] = deque(maxlen=horizon)
        self._q: deque[np.ndarray] = deque(maxlen=horizon)
        self._extra: deque = deque(maxlen=horizon)

    def push(self, t: float, quats: np.ndarray, extra=None) -> None:
        if self._t and t <= self._t[-1]:
            return  # out of order or duplicate: keep the track monotonic
        self._t.append(t)
        self._q.append(np.asarray(quats, np.float64))
        self._extra.append(extra)

    def __len__(self) -> int:
        return len(self._t)

    @property
    def newest_s(self) -> float | None:
        return self._t[-1] if self._t else None

    def at(self, t: float) -> PoseAt | None:
        """The pose at host time ``t``; None before the first sample."""
        if not self._t:
            return None
        ts = self._t
        if t >= ts[-1]:
            return PoseAt(self._q[-1], ts[-1], t > ts[-1], t - ts[-1], self._extra[-1])
        if t <= ts[0]:
            return PoseAt(self._q[0], ts[0], False, 0.0, self._extra[0])
        i = int(np.searchsorted(np.fromiter(ts, float, len(ts)), t))  # ts[i-1] < t <= ts[i]
        w = (t - ts[i - 1]) / (ts[i] - ts[i - 1])
        return PoseAt(quat.slerp(self._q[i - 1], self._q[i], w), ts[i], False, 0.0, self._extra[i])

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
            self._q.popleft()
            self._extra.popleft()
