"""Madgwick's gradient-descent orientation filter, IMU form (accelerometer and gyro; Madgwick 2010 §3-4).

One step for IMU i (q = (w, x, y, z) maps IMU axes to the world, as Madgwick's q-dot = q (x) omega / 2):
1. a_n = a / |a|; f = R(q)^T (0, 0, 1) - a_n, the objective; J its Jacobian in q.
2. s = J^T f / |J^T f|, the normalised gradient, weighted by the accelerometer trust f(e_m) of thesis eq. 3.19.
3. q = normalise(q + (q (x) (0, gyro) / 2 - beta s) dt).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.fusion.base import Filter


@dataclass
class MadgwickSettings:
    beta: float = 0.01  # rad/s: gradient step (Madgwick: sqrt(3/4) x gyro error)
    threshold1: float = 0.1  # accelerometer trust, thesis eq. 3.19
    threshold2: float = 0.2


def gradient(q, a_n) -> np.ndarray:
    """J^T f of Madgwick eq. 25-26 with d = (0, 0, 1): (n, 4)."""
    w, x, y, z = q.T
    ax, ay, az = a_n.T
    f1 = 2.0 * (x * z - w * y) - ax
    f2 = 2.0 * (w * x + y * z) - ay
    f3 = 1.0 - 2.0 * (x * x + y * y) - az
    return np.stack(
        (
            -2.0 * y * f1 + 2.0 * x * f2,
            2.0 * z * f1 + 2.0 * w * f2 - 4.0 * x * f3,
            -2.0 * w * f1 + 2.0 * z * f2 - 4.0 * y * f3,
            2.0 * x * f1 + 2.0 * y * f2,
        ),
        axis=1,
    )


class MadgwickFilter(Filter):
    name = "madgwick"

    def __init__(self, n: int = 12, settings: MadgwickSettings | None = None):
        super().__init__(n)
        self.settings = settings or MadgwickSettings()

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        s = self.settings
        m, dt, a, an, trust = self._inputs(accel, dt, mask, s.threshold1, s.threshold2)
        q = self.q[m]
        grad = gradient(q, np.where(trust > 0.0, a / np.where(an > 0.0, an, 1.0), 0.0))  # 1
        gn = np.linalg.norm(grad, axis=1, keepdims=True)
        step = trust * np.where(gn > 0.0, grad / np.where(gn > 0.0, gn, 1.0), 0.0)  # 2
        g = np.asarray(gyro, float).reshape(self.n, 3)[m]
        qdot = 0.5 * quat.mul(q, np.concatenate((np.zeros((len(g), 1)), g), axis=1)) - s.beta * step
        self.q[m] = quat.normalize(q + qdot * dt)  # 3
        return self.q
