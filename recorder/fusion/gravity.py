"""Attitude from the gravity direction (thesis §3.3.2 eq. 3.5-3.6 and its listing ``anglesFromGravity``).

For a still IMU the accelerometer reads the "up" direction in its own axes, a = (ax, ay, az). The rotation about
x is atan2(ay, az) and the one about y is atan2(-ax, sqrt(ay^2 + az^2)); eq. 3.5 names them theta and phi but
eq. 3.6 and the listing use them as roll (about x) and pitch (about y). Yaw is unknown and set to 0; eq. 3.6
(ZYX Tait-Bryan) with yaw 0 is q = (cr cp, sr cp, cr sp, -sr sp) with cr = cos(roll/2), sp = sin(pitch/2), ...
A zero (or non-finite) vector gives the identity, as in the firmware (firmware/lib/glove_core).
"""

from __future__ import annotations

import numpy as np

from recorder.fusion import kernels


def roll_pitch(accel) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 3.5: (roll about x, pitch about y) in radians from accelerometer readings (..., 3)."""
    a = np.asarray(accel, dtype=float)
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    return np.arctan2(ay, az), np.arctan2(-ax, np.sqrt(ay * ay + az * az))


def attitude_from_gravity(accel) -> np.ndarray:
    """Eq. 3.6 with yaw 0: unit quaternions (..., 4) whose z axis is the measured up direction."""
    a = np.asarray(accel, dtype=float)
    roll, pitch = roll_pitch(a)
    cr, sr = np.cos(0.5 * roll), np.sin(0.5 * roll)
    cp, sp = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    q = np.stack((cr * cp, sr * cp, cr * sp, -sr * sp), axis=-1)
    n = np.linalg.norm(a, axis=-1)
    bad = ~(np.isfinite(n) & (n > 0.0))
    return np.where(bad[..., None], np.array([1.0, 0.0, 0.0, 0.0]), q)


def gain_factor(accel_norm, t1: float = 0.1, t2: float = 0.2) -> np.ndarray:
    """Eq. 3.17 and 3.19, how far to trust the accelerometer: e_m = | |a| - 1 | (a in g); 1 up to t1, falling
    linearly to 0 at t2 ((t2 - e_m) / (t2 - t1); the thesis writes / t1, the same for its 0.1 / 0.2), 0 beyond
    and for NaN. The kernels' own function (recorder/fusion/kernels.py ``_gain_factor``) for every value."""
    a = np.asarray(accel_norm, float)
    return kernels.gain_factors(np.ascontiguousarray(a.ravel()), float(t1), float(t2)).reshape(a.shape)
