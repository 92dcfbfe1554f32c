"""Per-axis running median of the last ``window`` accelerometer samples of every IMU (thesis §3.3.2, §4.2.2:
a circular buffer of 12, ``a_filtered = median(a_buffer)``).

Definition shared with the firmware (firmware/lib/glove_core/median_filter.cpp): a push writes the sample at the
buffer head, the head advances modulo the window and the count grows to the window; the value is, per axis, the
median of the samples held: the middle one for an odd count, the mean of the two middle ones for an even count
(12 when full); (0, 0, 0) while empty. Each IMU has its own buffer and count; only the masked IMUs are pushed.
"""

from __future__ import annotations

import numpy as np

from recorder.fusion.base import as_mask


class MedianBuffer:
    def __init__(self, n: int, window: int = 12):
        if not 1 <= int(window) <= 64:
            raise ValueError(f"median window must be 1..64, got {window}")
        self.n = int(n)
        self.window = int(window)
        self.buf = np.zeros((self.n, self.window, 3))
        self.head = np.zeros(self.n, np.int64)
        self.count = np.zeros(self.n, np.int64)

    def clear(self, mask=None) -> None:
        m = as_mask(mask, self.n)
        self.head[m] = 0
        self.count[m] = 0

    def push(self, samples, mask=None) -> np.ndarray:
        """Add one sample (n, 3) for the masked IMUs; returns the medians (n, 3) of every IMU."""
        m = as_mask(mask, self.n)
        idx = np.flatnonzero(m)
        self.buf[idx, self.head[idx]] = np.asarray(samples, float).reshape(self.n, 3)[idx]
        self.head[idx] = (self.head[idx] + 1) % self.window
        self.count[idx] = np.minimum(self.count[idx] + 1, self.window)
        return self.value()

    def value(self) -> np.ndarray:
        """The medians (n, 3) of the samples held."""
        if np.all(self.count == self.window):
            return np.median(self.buf, axis=1)
        out = np.zeros((self.n, 3))
        for i in range(self.n):  # only while buffers fill up
            if self.count[i]:
                out[i] = np.median(self.buf[i, : self.count[i]], axis=0)
        return out
