"""Quaternion complementary filter with adaptive gain: the thesis' filter (§3.3-3.5, eq. 3.4-3.19, listing
``Hand::updateJoint``), the readable reference shared with the firmware (firmware/lib/glove_core/
complementary_filter.cpp, compared per quaternion component in tests/test_fusion_firmware.py).

One step for IMU i, in this order (docs/fusion.md has the derivation):
1. a = median of the last 12 accelerometer samples, this one included (recorder/fusion/median.py).
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

from recorder import quat
from recorder.fusion.base import Filter, as_mask
from recorder.fusion.gravity import attitude_from_gravity, gain_factor
from recorder.fusion.median import MedianBuffer

UP = np.array([0.0, 0.0, 1.0])


@dataclass
class ComplementarySettings:
    static_gain: float = 0.005  # alpha-bar of eq. 3.18 (thesis §4.2.4)
    threshold1: float = 0.1  # t1 of eq. 3.19
    threshold2: float = 0.2  # t2 of eq. 3.19
    median_window: int = 12  # thesis §4.2.2; 1 disables the median filter


def adaptive_gain(settings, accel_norm) -> np.ndarray:
    """Eq. 3.17-3.19 with the accelerometer in g: the gain for each |a|; 0 for NaN."""
    return settings.static_gain * gain_factor(accel_norm, settings.threshold1, settings.threshold2)


def to_up(g) -> np.ndarray:
    """Eq. 3.13 as in the firmware: the shortest rotation taking the direction of g (n, 3) onto (0, 0, 1)."""
    g = np.asarray(g, float)
    a = g / np.linalg.norm(g, axis=-1, keepdims=True)
    c = a[..., 2]
    q = quat.normalize(np.stack((1.0 + c, a[..., 1], -a[..., 0], np.zeros_like(c)), axis=-1))
    # opposite: a half turn about a x (1, 0, 0), or a x (0, 1, 0) when that is too short
    ax = np.stack((np.zeros_like(c), a[..., 2], -a[..., 1]), axis=-1)
    ay = np.stack((-a[..., 2], np.zeros_like(c), a[..., 0]), axis=-1)
    axis = np.where((np.linalg.norm(ax, axis=-1) < 1e-3)[..., None], ay, ax)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    half = np.concatenate((np.zeros_like(c)[..., None], axis), axis=-1)
    return np.where((c < -0.999999)[..., None], half, q)


def propagate(q, gyro, dt) -> np.ndarray:
    """Eq. 3.4 then normalisation: q + q (x) (0, dt/2 gyro), normalised."""
    h = 0.5 * np.asarray(dt, float).reshape(-1, 1) * gyro
    return quat.normalize(q + quat.mul(q, np.concatenate((np.zeros((len(h), 1)), h), axis=1)))


class ComplementaryFilter(Filter):
    name = "complementary"

    def __init__(self, n: int = 12, settings: ComplementarySettings | None = None):
        super().__init__(n)
        self.settings = settings or ComplementarySettings()
        self.median = MedianBuffer(self.n, self.settings.median_window)
        self.gain = np.zeros(self.n)

    def observe(self, accel, mask=None) -> None:
        self.median.push(accel, mask)

    def reset(self, accel=None, mask=None) -> None:
        """Eq. 3.5-3.6 from ``accel`` or, when None, from the median of the samples observed (the reset button)."""
        m = as_mask(mask, self.n)
        a = self.median.value() if accel is None else np.asarray(accel, float).reshape(self.n, 3)
        self.q[m] = attitude_from_gravity(a[m])

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        m = as_mask(mask, self.n)
        dt = np.broadcast_to(np.asarray(dt, float), (self.n,))[m]
        a = self.median.push(accel, m)[m]  # 1
        qw = propagate(self.q[m], np.asarray(gyro, float).reshape(self.n, 3)[m], dt)  # 2
        an = np.linalg.norm(a, axis=1)
        alpha = adaptive_gain(self.settings, an)  # 3
        on = alpha > 0.0  # 4
        gp = quat.rotate(qw[on], a[on] / an[on, None])  # 5
        dq = to_up(gp)  # 6
        k = alpha[on, None]
        dq = quat.normalize((1.0 - k) * quat.IDENTITY + k * dq)  # 7
        qw[on] = quat.normalize(quat.mul(dq, qw[on]))  # 8
        self.q[m] = qw
        self.gain[m] = alpha
        return self.q

    def state(self) -> dict:
        return super().state() | {
            "buf": self.median.buf.copy(),
            "head": self.median.head.copy(),
            "count": self.median.count.copy(),
            "gain": self.gain.copy(),
        }

    def load_state(self, state: dict) -> None:
        state = dict(state)
        for k in ("buf", "head", "count"):
            setattr(self.median, k, np.array(state.pop(k), dtype=getattr(self.median, k).dtype, copy=True))
        super().load_state(state)
