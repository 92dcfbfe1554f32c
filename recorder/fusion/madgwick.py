"""Madgwick's gradient-descent orientation filter, IMU form (accelerometer and gyro; Madgwick 2010 §3-4).

One step for IMU i (q = (w, x, y, z) maps IMU axes to the world, as Madgwick's q-dot = q (x) omega / 2):
1. a_n = a / |a|; f = R(q)^T (0, 0, 1) - a_n, the objective; J its Jacobian in q.
2. s = J^T f / |J^T f|, the normalised gradient, weighted by the accelerometer trust f(e_m) of thesis eq. 3.19.
3. q = normalise(q + (q (x) (0, gyro) / 2 - beta s) dt).
With d = (0, 0, 1) (Madgwick eq. 25-26): f = (2 (x z - w y) - a_x, 2 (w x + y z) - a_y, 1 - 2 (x^2 + y^2) - a_z)
and J^T f = (-2y f1 + 2x f2, 2z f1 + 2w f2 - 4x f3, -2w f1 + 2z f2 - 4y f3, 2x f1 + 2y f2); no step when the
accelerometer is not trusted or reads zero. The maths: ``madgwick_step`` below.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit

from recorder.fusion.base import Filter
from recorder.fusion.kernels import _gain_factor, _mul, _normalize
from recorder.fusion.registry import register_filter


@dataclass
class MadgwickSettings:
    beta: float = 0.01  # rad/s: gradient step (Madgwick: sqrt(3/4) x gyro error)
    threshold1: float = 0.1  # accelerometer trust, thesis eq. 3.19
    threshold2: float = 0.2


@njit(cache=True)
def madgwick_step(q, gyro, accel, dt, mask, beta, t1, t2):
    """recorder/fusion/madgwick.py, steps 1-3, one sample of every IMU."""
    for i in range(q.shape[0]):
        if not mask[i]:
            continue
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        ax, ay, az = accel[i, 0], accel[i, 1], accel[i, 2]
        an = math.sqrt(ax * ax + ay * ay + az * az)
        trust = _gain_factor(an, t1, t2)
        sw = sx = sy = sz = 0.0
        if trust > 0.0 and an > 0.0:
            ax, ay, az = ax / an, ay / an, az / an
            f1 = 2.0 * (x * z - w * y) - ax
            f2 = 2.0 * (w * x + y * z) - ay
            f3 = 1.0 - 2.0 * (x * x + y * y) - az
            sw = -2.0 * y * f1 + 2.0 * x * f2
            sx = 2.0 * z * f1 + 2.0 * w * f2 - 4.0 * x * f3
            sy = -2.0 * w * f1 + 2.0 * z * f2 - 4.0 * y * f3
            sz = 2.0 * x * f1 + 2.0 * y * f2
            sn = math.sqrt(sw * sw + sx * sx + sy * sy + sz * sz)
            if sn > 0.0:
                sw, sx, sy, sz = trust * sw / sn, trust * sx / sn, trust * sy / sn, trust * sz / sn
            else:
                sw = sx = sy = sz = 0.0
        dw, dx, dy, dz = _mul(w, x, y, z, 0.0, gyro[i, 0], gyro[i, 1], gyro[i, 2])
        h = dt[i]
        q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _normalize(
            w + (0.5 * dw - beta * sw) * h,
            x + (0.5 * dx - beta * sx) * h,
            y + (0.5 * dy - beta * sy) * h,
            z + (0.5 * dz - beta * sz) * h,
        )


@njit(cache=True, inline="always")
def step(q, bias, state, gyro, accel, dt, mask, params):
    """The registry's step (recorder/fusion/registry.py): params (beta, t1, t2)."""
    madgwick_step(q, gyro, accel, dt, mask, params[0], params[1], params[2])


# Madgwick's normalised gradient step does not pull a tilt back in proportion to its error, so a bias learned
# wrongly from the joints lingers: it learns from them more slowly (a 4-minute run ran away at 1.0)
@register_filter("madgwick", settings=MadgwickSettings, step=step, heading_bias_rate=0.2)
class MadgwickFilter(Filter):
    def __init__(self, n: int = 12, settings: MadgwickSettings | None = None):
        super().__init__(n)
        self.settings = settings or MadgwickSettings()

    def params(self) -> tuple:
        s = self.settings
        return float(s.beta), float(s.threshold1), float(s.threshold2)
