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
``bias`` is -I, the estimated gyro bias (rad/s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.fusion.base import Filter

UP = np.array([0.0, 0.0, 1.0])


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

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        s = self.settings
        m, dt, a, an, trust = self._inputs(accel, dt, mask, s.threshold1, s.threshold2)
        a_n = np.where(trust > 0.0, a / np.where(an > 0.0, an, 1.0), 0.0)  # 1
        q = self.q[m]
        v = quat.rotate(quat.conj(q), UP)  # 2
        e = trust * np.cross(a_n, v)  # 3
        small = np.linalg.norm(e, axis=1, keepdims=True) < s.integral_limit
        bias = self.bias[m] - np.where(small, s.ki * e * dt, 0.0)  # 4
        w = np.asarray(gyro, float).reshape(self.n, 3)[m] + s.kp * e - bias  # 5
        self.q[m] = quat.normalize(quat.mul(q, quat.from_rotvec(w * dt)))  # 6
        self.bias[m] = bias
        return self.q
