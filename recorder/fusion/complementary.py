"""Quaternion complementary filter with adaptive gain: the thesis' filter (§3.3-3.5, eq. 3.4-3.19, listing
``Hand::updateJoint``), shared with the firmware (firmware/lib/glove_core/complementary_filter.cpp, compared per
quaternion component in tests/test_fusion_firmware.py). The maths: recorder/fusion/kernels.py
``complementary_step``; this class holds the settings and the state (q, the median windows, the last gain).

One step for IMU i, in this order (docs/fusion.md has the derivation):
1. a = per-axis median of the last 12 accelerometer samples, this one included (thesis §3.3.2, §4.2.2; the
   firmware's median_filter.cpp): a push writes the sample at the IMU's buffer head, the head advances modulo
   the window, the count grows to the window; the median of the samples held is the middle one for an odd count,
   the mean of the two middle ones for an even count (12 when full), (0, 0, 0) while empty. Only fused samples
   are pushed (``observe`` pushes without filtering). The kernel keeps each window sorted (remove the sample
   overwritten, insert the new one): the same values as sorting the buffer.
2. Eq. 3.4, attitude propagation with h = dt/2 * gyro: q_w = q + q (x) (0, h), then normalised (eq. 3.12 uses
   "the normalised predicted quaternion").
3. Eq. 3.17-3.19, gain: e_m = | |a| - 1 | (a in g); alpha = static_gain if e_m <= t1, 0 if e_m >= t2 (or NaN),
   else static_gain (t2 - e_m) / (t2 - t1) (the thesis writes / t1: the same for t1 = 0.1, t2 = 0.2).
4. alpha == 0: q = q_w, done (gyro only).
5. Eq. 3.12: g_p = q_w (a / |a|) q_w*, the measured up direction in the world frame.
6. Eq. 3.13: dq = shortest rotation taking g_p onto (0, 0, 1) (Eigen's FromTwoVectors, as in the listing).
7. Eq. 3.14-3.15: dq = normalise((1 - alpha) (1, 0, 0, 0) + alpha dq).
8. Eq. 3.16: q = normalise(dq (x) q_w). The correction is a world-frame rotation, so with q mapping IMU axes to
   the world it multiplies from the left; the listing's q_w (x) dq (right) applies it about the wrong axis once
   the heading is not zero and diverges at 180 degrees (tests/test_fusion_filters.py shows both).
Initial attitude and the reset button: eq. 3.5-3.6 from the median-filtered accelerometer (recorder/fusion/
gravity.py). dt: the time since this IMU's previous update, from the device clock (recorder/fusion/host.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder.fusion import kernels
from recorder.fusion.base import Filter, as_mask
from recorder.fusion.gravity import attitude_from_gravity, gain_factor


@dataclass
class ComplementarySettings:
    static_gain: float = 0.005  # alpha-bar of eq. 3.18 (thesis §4.2.4)
    threshold1: float = 0.1  # t1 of eq. 3.19
    threshold2: float = 0.2  # t2 of eq. 3.19
    median_window: int = 12  # thesis §4.2.2; 1 disables the median filter


def adaptive_gain(settings, accel_norm) -> np.ndarray:
    """Eq. 3.17-3.19 with the accelerometer in g: the gain for each |a|; 0 for NaN (the kernel's step 3)."""
    return settings.static_gain * gain_factor(accel_norm, settings.threshold1, settings.threshold2)


class ComplementaryFilter(Filter):
    name = "complementary"
    STATE = Filter.STATE + ("buf", "head", "count", "gain")

    def __init__(self, n: int = 12, settings: ComplementarySettings | None = None):
        super().__init__(n)
        self.settings = s = settings or ComplementarySettings()
        if not 1 <= int(s.median_window) <= 64:
            raise ValueError(f"median window must be 1..64, got {s.median_window}")
        self.buf = np.zeros((self.n, int(s.median_window), 3))  # the median windows, circular
        self.head = np.zeros(self.n, np.int64)
        self.count = np.zeros(self.n, np.int64)
        self.gain = np.zeros(self.n)  # alpha of the last step

    def params(self) -> tuple:
        s = self.settings
        return float(s.static_gain), float(s.threshold1), float(s.threshold2)

    def observe(self, accel, mask=None) -> None:
        a = np.ascontiguousarray(np.reshape(accel, (self.n, 3)), float)
        kernels.median_push(self.buf, self.head, self.count, a, as_mask(mask, self.n))

    def median(self) -> np.ndarray:
        """The per-axis medians (n, 3) of the accelerometer samples held (step 1)."""
        return kernels.median_value(self.buf, self.count)

    def reset(self, accel=None, mask=None) -> None:
        """Eq. 3.5-3.6 from ``accel`` or, when None, from the median of the samples observed (the reset button)."""
        m = as_mask(mask, self.n)
        a = self.median() if accel is None else np.asarray(accel, float).reshape(self.n, 3)
        self.q[m] = attitude_from_gravity(a[m])

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        srt = kernels._sorted_windows(self.buf, self.count)  # the windows sorted, as the block loop keeps them
        args = self._sample(gyro, accel, dt, mask)
        kernels.complementary_step(
            self.q, self.buf, self.head, self.count, self.gain, srt, np.empty(3), *args, *self.params()
        )
        return self.q

    def block(self, gyro, accel, dt, mask, out) -> None:
        kernels.complementary(
            self.q, self.buf, self.head, self.count, self.gain, gyro, accel, dt, mask, *self.params(), out
        )
