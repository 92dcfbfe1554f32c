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
``bias`` is -I, the estimated gyro bias (rad/s). The maths: ``mahony_step`` below (one IMU: ``_mahony_step``, also
the relative filter's root).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit

from recorder.fusion.base import Filter
from recorder.fusion.kernels import _exp, _gain_factor, _mul, _normalize, _rotate
from recorder.fusion.registry import register_filter


@dataclass
class MahonySettings:
    kp: float = 0.5  # rad/s per unit error: correction time constant 1 / kp seconds
    ki: float = 0.002  # rad/s^2 per unit error: bias estimation
    integral_limit: float = 0.1  # |e| (about radians) above which the integral holds
    threshold1: float = 0.1  # accelerometer trust, thesis eq. 3.19 (e_m in g)
    threshold2: float = 0.2


@njit(cache=True)
def _mahony_step(w, x, y, z, b, gx, gy, gz, ax, ay, az, dt, kp, ki, t1, t2, il):
    """One Algorithm 1 step; b (3,) is updated in place; returns the new q."""
    an = math.sqrt(ax * ax + ay * ay + az * az)
    trust = _gain_factor(an, t1, t2)
    ex = ey = ez = 0.0
    if trust > 0.0 and an > 0.0:
        ax, ay, az = ax / an, ay / an, az / an
        vx, vy, vz = _rotate(w, -x, -y, -z, 0.0, 0.0, 1.0)
        ex = trust * (ay * vz - az * vy)
        ey = trust * (az * vx - ax * vz)
        ez = trust * (ax * vy - ay * vx)
    if math.sqrt(ex * ex + ey * ey + ez * ez) < il:
        b[0] -= ki * ex * dt
        b[1] -= ki * ey * dt
        b[2] -= ki * ez * dt
    rw, rx, ry, rz = _exp((gx + kp * ex - b[0]) * dt, (gy + kp * ey - b[1]) * dt, (gz + kp * ez - b[2]) * dt)
    return _normalize(*_mul(w, x, y, z, rw, rx, ry, rz))


@njit(cache=True)
def mahony_step(q, bias, gyro, accel, dt, mask, kp, ki, t1, t2, il):
    """recorder/fusion/mahony.py, steps 1-6, one sample of every IMU."""
    for i in range(q.shape[0]):
        if mask[i]:
            q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _mahony_step(
                q[i, 0],
                q[i, 1],
                q[i, 2],
                q[i, 3],
                bias[i],
                gyro[i, 0],
                gyro[i, 1],
                gyro[i, 2],
                accel[i, 0],
                accel[i, 1],
                accel[i, 2],
                dt[i],
                kp,
                ki,
                t1,
                t2,
                il,
            )


@njit(cache=True, inline="always")
def step(q, bias, state, gyro, accel, dt, mask, params):
    """The registry's step (recorder/fusion/registry.py): params (kp, ki, t1, t2, integral_limit)."""
    mahony_step(q, bias, gyro, accel, dt, mask, params[0], params[1], params[2], params[3], params[4])


@register_filter("mahony", settings=MahonySettings, step=step, own_bias=True)
class MahonyFilter(Filter):
    def __init__(self, n: int = 12, settings: MahonySettings | None = None):
        super().__init__(n)
        self.settings = settings or MahonySettings()

    def params(self) -> tuple:
        s = self.settings
        return float(s.kp), float(s.ki), float(s.threshold1), float(s.threshold2), float(s.integral_limit)
