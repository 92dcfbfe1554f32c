"""Mahony's passive complementary filter with integral gyro-bias estimation, in the discrete form of Santaera et
al. Algorithm 1 (accelerometer only: no magnetometer, lambda_mag = 0), on quaternions.

One step for IMU i:
1. a_n = a / |a| (step 2).
2. v = R(q)^T (0, 0, 1), the up direction predicted in the IMU's axes (step 3).
3. e = a_n x v, the gravity error (step 5), weighted by the accelerometer trust f(e_m) of thesis eq. 3.19
   (thresholds t1, t2; Santaera et al. use the accelerometer always: t2 = inf).
4. I = I + ki e dt (step 8; the paper writes ki / dt, which for a fixed rate is the same law with another ki),
   only while |e| < integral_limit (anti-windup: a large error is a wrong attitude, e.g. at start, not a bias).
5. w = gyro + kp e + I (steps 9-10).
6. q = q (x) exp(w dt / 2) (steps 11-12: the paper integrates R + R w dt and projects back onto SO(3); the
   exponential is the exact rotation for a constant rate).
``bias`` is -I, the estimated gyro bias (rad/s). The maths: recorder/fusion/kernels.py ``mahony_step`` (one IMU:
``_mahony_step``, also the relative filter's root).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder.fusion import kernels
from recorder.fusion.base import Filter


@dataclass
class MahonySettings:
    kp: float = 0.5  # rad/s per unit error: correction time constant 1 / kp seconds
    ki: float = 0.002  # rad/s^2 per unit error: bias estimation
    integral_limit: float = 0.1  # |e| (about radians) above which the integral holds
    threshold1: float = 0.1  # accelerometer trust, thesis eq. 3.19 (e_m in g)
    threshold2: float = 0.2


class MahonyFilter(Filter):
    name = "mahony"

    def __init__(self, n: int = 12, settings: MahonySettings | None = None):
        super().__init__(n)
        self.settings = settings or MahonySettings()

    def params(self) -> tuple:
        s = self.settings
        return float(s.kp), float(s.ki), float(s.threshold1), float(s.threshold2), float(s.integral_limit)

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        kernels.mahony_step(self.q, self.bias, *self._sample(gyro, accel, dt, mask), *self.params())
        return self.q

    def block(self, gyro, accel, dt, mask, out) -> None:
        kernels.mahony(self.q, self.bias, gyro, accel, dt, mask, *self.params(), out)
