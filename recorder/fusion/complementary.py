"""Quaternion complementary filter with adaptive gain: the thesis' filter (§3.3-3.5, eq. 3.4-3.19, listing
``Hand::updateJoint``), shared with the firmware (firmware/lib/glove_core/complementary_filter.cpp, compared per
quaternion component in tests/test_fusion_firmware.py). The maths: ``complementary_step`` below; the class holds
the settings and the state (q, the median windows, the last gain).

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

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from recorder.fusion.base import Filter, as_mask
from recorder.fusion.gravity import attitude_from_gravity, gain_factor
from recorder.fusion.kernels import _gain_factor, _mul, _normalize, _rotate
from recorder.fusion.registry import register_filter


@dataclass
class ComplementarySettings:
    static_gain: float = 0.005  # alpha-bar of eq. 3.18 (thesis §4.2.4)
    threshold1: float = 0.1  # t1 of eq. 3.19
    threshold2: float = 0.2  # t2 of eq. 3.19
    median_window: int = 12  # thesis §4.2.2; 1 disables the median filter


def adaptive_gain(settings, accel_norm) -> np.ndarray:
    """Eq. 3.17-3.19 with the accelerometer in g: the gain for each |a|; 0 for NaN (the kernel's step 3)."""
    return settings.static_gain * gain_factor(accel_norm, settings.threshold1, settings.threshold2)


@njit(cache=True)
def _insert(v, n, x):
    """Insert x into the sorted v[:n] (room for n + 1)."""
    j = n
    while j > 0 and v[j - 1] > x:
        v[j] = v[j - 1]
        j -= 1
    v[j] = x


@njit(cache=True)
def _remove(v, n, x):
    """Remove one value equal to x from the sorted v[:n]."""
    j = 0
    while j < n - 1 and v[j] != x:
        j += 1
    while j < n - 1:
        v[j] = v[j + 1]
        j += 1


@njit(cache=True)
def _sorted_windows(buf, count):
    """Per IMU and axis, the samples held in sorted order (n, 3, window)."""
    n, window = buf.shape[0], buf.shape[1]
    srt = np.empty((n, 3, window))
    for i in range(n):
        for c in range(3):
            for k in range(count[i]):
                _insert(srt[i, c], k, buf[i, k, c])
    return srt


@njit(cache=True)
def _push(buf, head, count, i, x):
    """Write sample x (3,) at IMU i's buffer head; the head advances modulo the window, the count grows to it."""
    window = buf.shape[1]
    h = head[i]
    for c in range(3):
        buf[i, h, c] = x[c]
    head[i] = (h + 1) % window
    if count[i] < window:
        count[i] += 1


@njit(cache=True)
def _middle(v, m):
    """The median of the sorted v[:m]: the middle value (odd m), the mean of the two middle ones (even m), 0 for
    m = 0."""
    if m == 0:
        return 0.0
    return v[m // 2] if m & 1 else 0.5 * (v[m // 2 - 1] + v[m // 2])


@njit(cache=True)
def median_push(buf, head, count, accel, mask):
    """Push accel (n, 3) into the median windows of the masked IMUs, without filtering."""
    for i in range(buf.shape[0]):
        if mask[i]:
            _push(buf, head, count, i, accel[i])


@njit(cache=True)
def median_value(buf, count):
    """The per-axis medians (n, 3) of the samples held ((0, 0, 0) while a window is empty)."""
    srt = _sorted_windows(buf, count)
    out = np.empty((buf.shape[0], 3))
    for i in range(buf.shape[0]):
        for c in range(3):
            out[i, c] = _middle(srt[i, c], count[i])
    return out


@njit(cache=True)
def complementary_step(q, buf, head, count, gain, srt, a, gyro, accel, dt, mask, static_gain, t1, t2):
    """recorder/fusion/complementary.py, steps 1-8, one sample of every IMU (gyro, accel (n, 3), dt, mask (n,)).
    srt (n, 3, window): each median window kept sorted (from _sorted_windows): a push removes the sample it
    overwrites and inserts the new one, the same values as sorting the buffer; a (3,) scratch."""
    n, window = buf.shape[0], buf.shape[1]
    for i in range(n):
        if not mask[i]:
            continue
        h = head[i]
        m = count[i]
        for c in range(3):
            if m == window:
                _remove(srt[i, c], m, buf[i, h, c])
                _insert(srt[i, c], m - 1, accel[i, c])
            else:
                _insert(srt[i, c], m, accel[i, c])
        _push(buf, head, count, i, accel[i])
        m = count[i]
        for c in range(3):
            a[c] = _middle(srt[i, c], m)
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        hd = 0.5 * dt[i]
        hx, hy, hz = hd * gyro[i, 0], hd * gyro[i, 1], hd * gyro[i, 2]
        w, x, y, z = _normalize(
            w - hx * x - hy * y - hz * z,
            x + hx * w - hy * z + hz * y,
            y + hx * z + hy * w - hz * x,
            z - hx * y + hy * x + hz * w,
        )
        an = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
        alpha = static_gain * _gain_factor(an, t1, t2)
        if alpha > 0.0:
            gx, gy, gz = _rotate(w, x, y, z, a[0] / an, a[1] / an, a[2] / an)
            gn = math.sqrt(gx * gx + gy * gy + gz * gz)
            gx, gy, gz = gx / gn, gy / gn, gz / gn
            if gz < -0.999999:
                ax_, ay_, az_ = 0.0, gz, -gy
                if math.sqrt(ay_ * ay_ + az_ * az_) < 1e-3:
                    ax_, ay_, az_ = -gz, 0.0, gx
                an_ = math.sqrt(ax_ * ax_ + ay_ * ay_ + az_ * az_)
                dw, dx, dy, dz = 0.0, ax_ / an_, ay_ / an_, az_ / an_
            else:
                dw, dx, dy, dz = _normalize(1.0 + gz, gy, -gx, 0.0)
            dw, dx, dy, dz = _normalize((1.0 - alpha) + alpha * dw, alpha * dx, alpha * dy, alpha * dz)
            w, x, y, z = _normalize(*_mul(dw, dx, dy, dz, w, x, y, z))
        q[i, 0], q[i, 1], q[i, 2], q[i, 3] = w, x, y, z
        gain[i] = alpha


@njit(cache=True, inline="always")
def step(q, bias, state, gyro, accel, dt, mask, params):
    """The filter's step in the registry's signature (recorder/fusion/registry.py): state (buf, head, count, gain,
    srt, a), params (static_gain, t1, t2)."""
    buf, head, count, gain, srt, a = state
    complementary_step(q, buf, head, count, gain, srt, a, gyro, accel, dt, mask, params[0], params[1], params[2])


@register_filter("complementary", settings=ComplementarySettings, step=step, parent_share=0.0)
class ComplementaryFilter(Filter):
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

    def kernel_state(self) -> tuple:
        """(buf, head, count, gain) and, for the step, each window sorted (the step keeps it so while it runs)
        and a (3,) scratch array."""
        return self.buf, self.head, self.count, self.gain, _sorted_windows(self.buf, self.count), np.empty(3)

    def observe(self, accel, mask=None) -> None:
        a = np.ascontiguousarray(np.reshape(accel, (self.n, 3)), float)
        median_push(self.buf, self.head, self.count, a, as_mask(mask, self.n))

    def median(self) -> np.ndarray:
        """The per-axis medians (n, 3) of the accelerometer samples held (step 1)."""
        return median_value(self.buf, self.count)

    def reset(self, accel=None, mask=None) -> None:
        """Eq. 3.5-3.6 from ``accel`` or, when None, from the median of the samples observed (the reset button)."""
        m = as_mask(mask, self.n)
        a = self.median() if accel is None else np.asarray(accel, float).reshape(self.n, 3)
        self.q[m] = attitude_from_gravity(a[m])
