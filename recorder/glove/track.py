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
