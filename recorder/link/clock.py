"""Device -> host clock mapping: unwrap the device's 32-bit µs counter, estimate offset and drift.

host_time ≈ device_time + offset + drift * device_time. The offset is fitted on the lower envelope of
(host receive time - device time): the fastest frames of each one-second bucket, whose transport delay is
nearly constant. Latency measured against this mapping is therefore the delay *above* the fastest delivery.
When the device says its clock is the host's CLOCK_MONOTONIC (the emulator), the mapping is exact and
latency is absolute.
"""

from __future__ import annotations

from collections import deque

import numpy as np

WRAP = 1 << 32
BUCKET_S = 1.0
BUCKETS = 60


class DeviceClock:
    def __init__(self) -> None:
        self.host_monotonic = False
        self._last_raw: int | None = None
        self._epoch = 0  # µs added for wraps
        self._buckets: deque[tuple[float, float]] = deque(maxlen=BUCKETS)  # (device_s, min host-device)
        self._bucket_start: float | None = None
        self._bucket_min = np.inf
        self.offset_s = 0.0
        self.drift = 0.0  # s/s (ppm = drift * 1e6)
        self._ready = False

    def reset(self) -> None:
        """A new device session (reconnect): the counter may have restarted."""
        self._last_raw = None
        self._epoch = 0
        self._buckets.clear()
        self._bucket_start = None
        self._bucket_min = np.inf
        self._ready = False

    def unwrap(self, t_us: int, rx_ns: int) -> float:
        """Device time in seconds, continuous across 32-bit wraps. Callers may pass an older frame's time after a
        newer one's (the glove reads its pose samples and its frames apart): an older time never counts as a wrap,
        which once added two wraps (8590 s) when a pose sample from just before a wrap came after the frames past it
        (a faster-than-real-time session, whose device clock runs ahead, crossing a wrap)."""
        if self.host_monotonic:  # the device counter is host monotonic µs mod 2^32
            host_us = rx_ns // 1000
            return (host_us - ((host_us - t_us) % WRAP)) * 1e-6
        if self._last_raw is not None:
            if t_us > self._last_raw + WRAP // 2:  # an older frame's, from before the last wrap (a pose sample read
                return (t_us + self._epoch - WRAP) * 1e-6  # after newer frames): counted back, no wrap undone
            if t_us < self._last_raw - WRAP // 2:
                self._epoch += WRAP
            elif t_us < self._last_raw:
                return (t_us + self._epoch) * 1e-6  # an older frame's, same wrap: the newest stays the reference
        self._last_raw = t_us
        return (t_us + self._epoch) * 1e-6

    def update(self, device_s: float, rx_ns: int) -> None:
        if self.host_monotonic:
            return
        delta = rx_ns * 1e-9 - device_s
        if self._bucket_start is None:
            self._bucket_start = device_s
        if device_s - self._bucket_start >= BUCKET_S:
            self._buckets.append((self._bucket_start, self._bucket_min))
            self._bucket_start, self._bucket_min = device_s, np.inf
            self._fit()
        if delta < self._bucket_min:
            self._bucket_min = delta
            if not self._ready:  # until the first bucket closes, follow the running minimum
                self.offset_s = delta

    def _fit(self) -> None:
        t, d = np.array(self._buckets).T
        if len(t) >= 3:
            self.drift, intercept = np.polyfit(t - t[0], d, 1)
            self.offset_s = intercept - self.drift * t[0]
        else:
            self.offset_s, self.drift = float(d.min()), 0.0
        self._ready = True

    def to_host_s(self, device_s: float) -> float:
        """Host monotonic time (seconds) at which the device sampled ``device_s``."""
        if self.host_monotonic:
            return device_s
        return device_s + self.offset_s + self.drift * device_s
