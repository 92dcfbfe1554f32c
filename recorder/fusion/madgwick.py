"""Madgwick's gradient-descent orientation filter, IMU form (accelerometer and gyro; Madgwick 2010 §3-4).

One step for IMU i (q = (w, x, y, z) maps IMU axes to the world, as Madgwick's q-dot = q (x) omega / 2):
1. a_n = a / |a|; f = R(q)^T (0, 0, 1) - a_n, the objective; J its Jacobian in q.
2. s = J^T f / |J^T f|, the normalised gradient, weighted by the accelerometer trust f(e_m) of thesis eq. 3.19.
3. q = normalise(q + (q (x) (0, gyro) / 2 - beta s) dt).
With d = (0, 0, 1) (Madgwick eq. 25-26): f = (2 (x z - w y) - a_x, 2 (w x + y z) - a_y, 1 - 2 (x^2 + y^2) - a_z)
and J^T f = (-2y f1 + 2x f2, 2z f1 + 2w f2 - 4x f3, -2w f1 + 2z f2 - 4y f3, 2x f1 + 2y f2); no step when the
accelerometer is not trusted or reads zero. The maths: recorder/fusion/kernels.py ``madgwick_step``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder.fusion import kernels
from recorder.fusion.base import Filter


@dataclass
class MadgwickSettings:
    beta: float = 0.01  # rad/s: gradient step (Madgwick: sqrt(3/4) x gyro error)
    threshold1: float = 0.1  # accelerometer trust, thesis eq. 3.19
    threshold2: float = 0.2


class MadgwickFilter(Filter):
    name = "madgwick"

    def __init__(self, n: int = 12, settings: MadgwickSettings | None = None):
        super().__init__(n)
        self.settings = settings or MadgwickSettings()

    def params(self) -> tuple:
        s = self.settings
        return float(s.beta), float(s.threshold1), float(s.threshold2)

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        kernels.madgwick_step(self.q, *self._sample(gyro, accel, dt, mask), *self.params())
        return self.q

    def block(self, gyro, accel, dt, mask, out) -> None:
        kernels.madgwick(self.q, gyro, accel, dt, mask, *self.params(), out)
