"""The numba helpers every filter's kernels share (quaternions as four floats, the accelerometer trust of thesis
eq. 3.19) and the host's bias tracker kernels (recorder/fusion/bias.py). Each filter's own kernels live in its
module (recorder/fusion/complementary.py, mahony.py, madgwick.py, relative.py, inertial.py), with the step the
registry runs (recorder/fusion/registry.py). Every kernel updates its arrays in place (C contiguous float64,
int64 counts, bool masks). ``NUMBA_DISABLE_JIT=1`` runs the same code as plain Python (for a debugger).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _normalize(w, x, y, z):
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return w / n, x / n, y / n, z / n


@njit(cache=True)
def _mul(aw, ax, ay, az, bw, bx, by, bz):
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


@njit(cache=True)
def _rotate(w, x, y, z, vx, vy, vz):
    """q v q* as quat.rotate: v + w t + u x t with t = 2 u x v."""
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz), vz + w * tz + (x * ty - y * tx))


@njit(cache=True)
def _exp(rx, ry, rz):
    """quat.from_rotvec: (cos(a/2), r * 0.5 sinc(a / 2pi))."""
    a = math.sqrt(rx * rx + ry * ry + rz * rz)
    if a < 1e-8:
        s = 0.5 - a * a / 48.0
    else:
        s = math.sin(0.5 * a) / a
    return math.cos(0.5 * a), rx * s, ry * s, rz * s


@njit(cache=True)
def _gain_factor(norm, t1, t2):
    em = abs(norm - 1.0)
    if em <= t1:
        return 1.0
    if em < t2:
        return (t2 - em) / (t2 - t1)
    return 0.0  # also NaN


@njit(cache=True)
def gain_factors(norm, t1, t2):
    """_gain_factor for every value of the 1-D array norm."""
    out = np.empty(norm.shape[0])
    for k in range(norm.shape[0]):
        out[k] = _gain_factor(norm[k], t1, t2)
    return out


@njit(cache=True)
def bias_step(b, still_for, gyro, accel, q, trust, dt, mask, bp, use_gravity):
    """recorder/fusion/bias.py sources 1 and 2, one sample of every IMU: gyro (n, 3) with the static bias but not
    b removed, q (n, 4) the filter's new orientations, trust (n,), dt (n,), mask (n,); bp: BiasSettings (ki,
    still_rate, still_time_s, still_tau_s, max_bias). b and still_for are updated in place."""
    for i in range(b.shape[0]):
        r0, r1, r2 = gyro[i, 0] - b[i, 0], gyro[i, 1] - b[i, 1], gyro[i, 2] - b[i, 2]
        if use_gravity and bp[0] > 0.0 and mask[i]:
            ax, ay, az = accel[i, 0], accel[i, 1], accel[i, 2]
            an = math.sqrt(ax * ax + ay * ay + az * az)
            if an > 0.0:
                ax, ay, az = ax / an, ay / an, az / an
            else:
                ax = ay = az = 0.0
            vx, vy, vz = _rotate(q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3], 0.0, 0.0, 1.0)
            k = bp[0] * trust[i] * dt[i]
            b[i, 0] -= k * (ay * vz - az * vy)
            b[i, 1] -= k * (az * vx - ax * vz)
            b[i, 2] -= k * (ax * vy - ay * vx)
        still = mask[i] and max(abs(r0), abs(r1), abs(r2)) < bp[1] and trust[i] >= 1.0
        still_for[i] = still_for[i] + dt[i] if still else 0.0
        if still and still_for[i] >= bp[2]:
            k = min(dt[i] / bp[3], 1.0)
            b[i, 0] += k * r0
            b[i, 1] += k * r1
            b[i, 2] += k * r2
        for c in range(3):
            b[i, c] = min(max(b[i, c], -bp[4]), bp[4])


@njit(cache=True)
def bias_heading(b, q, seen, gain, mask):
    """recorder/fusion/bias.py source 3: b -= gain seen for the masked IMUs, seen (n, 3) mapped from the world
    into each IMU's axes by q (n, 4); gain (n,)."""
    for i in range(b.shape[0]):
        if mask[i]:
            ux, uy, uz = _rotate(q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3], seen[i, 0], seen[i, 1], seen[i, 2])
            b[i, 0] -= gain[i] * ux
            b[i, 1] -= gain[i] * uy
            b[i, 2] -= gain[i] * uz
