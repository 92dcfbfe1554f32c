"""The glove's filter: tilt from the accelerometer low-passed in an almost-inertial frame (the idea of Laidig &
Seel's VQF, Information Fusion 2023, written here from the idea, not from their code), shared with the firmware
(firmware/lib/glove_core/complementary_filter.cpp, FilterMode::Inertial; the same bits in a double build,
tests/test_fusion_firmware.py). The maths: ``inertial_step`` below; the class holds the settings and the state.

Why: an accelerometer reads gravity plus the linear acceleration of the hand. In a frame that does not turn,
the linear acceleration integrates to a velocity, which stays small for a hand that goes back and forth, so its
average over a few seconds is almost zero there, and the average of the readings is gravity. In the IMU's own
axes that is not true (the axes turn with the hand). And gating the accelerometer by its magnitude (thesis eq.
3.19) is worse than not gating: it keeps the half of a back-and-forth motion whose magnitude happens to be near
1 g and drops the other, so the average no longer cancels (bench/fusion_real.py shows both on real recordings).

The orientation is split into q = q_c (x) q_g. For IMU i, one step:
1. q_g = normalise(q_g (x) exp(dt/2 gyro)): the gyro alone (strapdown) from the IMU's axes into the
   almost-inertial frame I, which drifts only as slowly as the gyro's errors. exp by its Taylor series to the
   4th power of the half angle (no libm call: the Cortex-M7 gives the same bits as the host).
2. a_I = q_g a q_g*: the accelerometer in I.
3. Three first-order low-pass stages with time constant tau each: y1 += k (a_I - y1), y2 += k (y1 - y2),
   y3 += k (y2 - y3), k = min(dt / tau, 1).
4. g_I = y3 + ramp (y2 - y3). With ramp = 3 this is (1 + 3 s tau) / (1 + s tau)^3: a low-pass that follows a
   ramp without lag (the derivative of the 3rd stage, (y2 - y3) / tau, times the cascade's delay 3 tau), so a
   slow, steady drift of q_g (a gyro bias) costs no lag; it still falls off with the square of the frequency.
   ramp = 0 is the plain 3rd-order low-pass.
5. g_E = q_c g_I; q_c = normalise(dq (x) q_c) with dq the shortest rotation taking g_E onto (0, 0, 1), the
   whole of it each step: q_c holds the tilt of the low-passed gravity exactly, and never turns the heading
   (dq is about a horizontal axis).
6. q = normalise(q_c (x) q_g).
``reset`` (eq. 3.5-3.6, yaw 0): q_g = identity, q_c from gravity, from the accelerometer given (the stages
restart there) or from the low-passed estimate (the glove's reset button: the stages are kept, in the new I).
``observe`` (while the gyro is calibrated) sets the stages to the mean of the samples seen since the last update.
``bias`` stays zero: the host's bias tracker (recorder/fusion/bias.py) and the glove's calibration remove it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from recorder.fusion.base import Filter, as_mask
from recorder.fusion.kernels import _mul, _rotate
from recorder.fusion.registry import register_filter


@dataclass
class InertialSettings:
    tau_s: float = 4.0  # s, each of the three low-pass stages (chosen leave-one-trial-out: docs/fusion.md)
    ramp: float = 3.0  # 3: follows a ramp without lag; 0: plain low-pass


# The kernels: the twin of the glove's filter (firmware/lib/glove_core/complementary_filter.cpp,
# FilterMode::Inertial): every operation below is the C++ one in the same order (the firmware's normalized()
# multiplies by 1 / norm, its rotate() is v + w t + u x t), so a double build of the core gives the same bits
# (tests/test_fusion_firmware.py). No libm call but sqrt in a step: the emulated Cortex-M7 matches the host too.


@njit(cache=True)
def _unit(w, x, y, z):
    """quaternion.h normalized(): q / |q| as q * (1 / |q|); the identity for a zero or non-finite q."""
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not (n > 1e-12) or not math.isfinite(n):
        return 1.0, 0.0, 0.0, 0.0
    s = 1.0 / n
    return w * s, x * s, y * s, z * s


@njit(cache=True)
def _exp_half(hx, hy, hz):
    """exp of the rotation whose half-angle vector is h: (cos |h|, sin |h| / |h| h) by their Taylor series to
    |h|^4 (the firmware's exp_half; |h| < 0.1 rad at 100 Hz and 20 rad/s, where the next term is 1e-10)."""
    t = hx * hx + hy * hy + hz * hz
    c = 1.0 - t * (0.5 - t * (1.0 / 24.0))
    s = 1.0 - t * (1.0 / 6.0 - t * (1.0 / 120.0))
    return c, s * hx, s * hy, s * hz


@njit(cache=True)
def _from_gravity(ax, ay, az):
    """Thesis eq. 3.5-3.6 (yaw 0) without trigonometric functions, as complementary_filter.cpp
    attitude_from_gravity: (cos, sin) of half the roll atan2(ay, az) is the direction of (r + az, ay), or of
    (|ay|, +-(r - az)) when az < 0 (r = sqrt(ay^2 + az^2)); of half the pitch atan2(-ax, r) that of (|a| + r, -ax).
    Gravity along x: roll 0; the identity for a zero vector."""
    r = math.sqrt(ay * ay + az * az)
    n = math.sqrt(ax * ax + r * r)
    if not (n > 0.0):
        return 1.0, 0.0, 0.0, 0.0
    cr, sr = 1.0, 0.0
    if r > 0.0:
        neg = math.copysign(1.0, ay) < 0.0
        u = r + az if az >= 0.0 else abs(ay)
        v = ay if az >= 0.0 else ((az - r) if neg else (r - az))
        k = 1.0 / math.sqrt(u * u + v * v)
        cr, sr = u * k, v * k
    u, v = n + r, -ax
    k = 1.0 / math.sqrt(u * u + v * v)
    cp, sp = u * k, v * k
    return cr * cp, sr * cp, cr * sp, -sr * sp


@njit(cache=True)
def _inertial_output(q, qg, qc, i):
    q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _unit(
        *_mul(qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3], qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3])
    )


@njit(cache=True)
def _gravity_estimate(lp, i, ramp):
    """The accelerometer low-passed in the almost-inertial frame: y3 + ramp (y2 - y3) (inertial.py step 4)."""
    return (
        lp[i, 2, 0] + ramp * (lp[i, 1, 0] - lp[i, 2, 0]),
        lp[i, 2, 1] + ramp * (lp[i, 1, 1] - lp[i, 2, 1]),
        lp[i, 2, 2] + ramp * (lp[i, 1, 2] - lp[i, 2, 2]),
    )


@njit(cache=True)
def inertial_observe(qg, lp, nobs, accel, mask):
    """recorder/fusion/inertial.py ``observe``: the masked IMUs' low-pass stages become the mean of the samples
    observed since the last update (in the almost-inertial frame)."""
    for i in range(qg.shape[0]):
        if not mask[i]:
            continue
        ax, ay, az = _rotate(qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3], accel[i, 0], accel[i, 1], accel[i, 2])
        if nobs[i] < 65535:
            nobs[i] += 1
        n = float(nobs[i])
        y0 = lp[i, 0, 0] + (ax - lp[i, 0, 0]) / n
        y1 = lp[i, 0, 1] + (ay - lp[i, 0, 1]) / n
        y2 = lp[i, 0, 2] + (az - lp[i, 0, 2]) / n
        for s in range(3):
            lp[i, s, 0], lp[i, s, 1], lp[i, s, 2] = y0, y1, y2


@njit(cache=True)
def inertial_reset(q, qg, qc, lp, nobs, accel, use_accel, mask, ramp):
    """recorder/fusion/inertial.py ``reset``: attitude from gravity (eq. 3.5-3.6) for the masked IMUs, from accel
    (n, 3) when use_accel (the low-pass stages restart there) or else from the low-passed estimate (the stages
    are kept, re-expressed in the new almost-inertial frame, which is the IMU's own at this moment)."""
    for i in range(qg.shape[0]):
        if not mask[i]:
            continue
        if use_accel:
            for s in range(3):
                lp[i, s, 0], lp[i, s, 1], lp[i, s, 2] = accel[i, 0], accel[i, 1], accel[i, 2]
        else:
            for s in range(3):
                lp[i, s, 0], lp[i, s, 1], lp[i, s, 2] = _rotate(
                    qg[i, 0], -qg[i, 1], -qg[i, 2], -qg[i, 3], lp[i, s, 0], lp[i, s, 1], lp[i, s, 2]
                )
        gx, gy, gz = _gravity_estimate(lp, i, ramp)
        qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3] = _from_gravity(gx, gy, gz)
        qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3] = 1.0, 0.0, 0.0, 0.0
        nobs[i] = 0
        _inertial_output(q, qg, qc, i)


@njit(cache=True)
def inertial_step(q, qg, qc, lp, nobs, gyro, accel, dt, mask, tau, ramp):
    """recorder/fusion/inertial.py steps 1-6, one sample of every IMU."""
    for i in range(q.shape[0]):
        if not mask[i]:
            continue
        h = 0.5 * dt[i]
        rw, rx, ry, rz = _exp_half(h * gyro[i, 0], h * gyro[i, 1], h * gyro[i, 2])
        gw, gx, gy, gz = _unit(*_mul(qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3], rw, rx, ry, rz))
        qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3] = gw, gx, gy, gz
        a = _rotate(gw, gx, gy, gz, accel[i, 0], accel[i, 1], accel[i, 2])
        k = dt[i] / tau
        if k > 1.0:
            k = 1.0
        for c in range(3):
            lp[i, 0, c] = lp[i, 0, c] + k * (a[c] - lp[i, 0, c])
            lp[i, 1, c] = lp[i, 1, c] + k * (lp[i, 0, c] - lp[i, 1, c])
            lp[i, 2, c] = lp[i, 2, c] + k * (lp[i, 1, c] - lp[i, 2, c])
        nobs[i] = 0
        ex, ey, ez = _gravity_estimate(lp, i, ramp)
        ex, ey, ez = _rotate(qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3], ex, ey, ez)
        n = math.sqrt(ex * ex + ey * ey + ez * ez)
        if n > 0.0 and math.isfinite(n):
            s = 1.0 / n
            ux, uy, uz = ex * s, ey * s, ez * s
            if 1.0 + uz > 1e-6:
                cw, cx, cy, cz = _unit(1.0 + uz, uy, -ux, 0.0)
                qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3] = _unit(
                    *_mul(cw, cx, cy, cz, qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3])
                )
        _inertial_output(q, qg, qc, i)


@njit(cache=True, inline="always")
def step(q, bias, state, gyro, accel, dt, mask, params):
    """The registry's step (recorder/fusion/registry.py): state (qg, qc, lp, nobs), params (tau_s, ramp)."""
    qg, qc, lp, nobs = state
    inertial_step(q, qg, qc, lp, nobs, gyro, accel, dt, mask, params[0], params[1])


@register_filter("inertial", settings=InertialSettings, step=step)
class InertialFilter(Filter):
    STATE = Filter.STATE + ("qg", "qc", "lp", "nobs")

    def __init__(self, n: int = 12, settings: InertialSettings | None = None):
        super().__init__(n)
        self.settings = s = settings or InertialSettings()
        if not s.tau_s > 0:
            raise ValueError(f"tau_s must be > 0, got {s.tau_s}")
        self.qg = self.q.copy()  # the IMU's axes -> I
        self.qc = self.q.copy()  # I -> the world
        self.lp = np.zeros((self.n, 3, 3))  # the low-pass stages y1, y2, y3 of a_I
        self.lp[:, :, 2] = 1.0
        self.nobs = np.zeros(self.n, np.int64)  # samples observed since the last update

    def params(self) -> tuple:
        return float(self.settings.tau_s), float(self.settings.ramp)

    def kernel_state(self) -> tuple:
        return self.qg, self.qc, self.lp, self.nobs

    def gravity(self) -> np.ndarray:
        """The low-passed accelerometer (n, 3) in the IMU's axes now (step 4, back from I)."""
        tau, ramp = self.params()
        g = self.lp[:, 2] + ramp * (self.lp[:, 1] - self.lp[:, 2])
        w, v = self.qg[:, :1], -self.qg[:, 1:]
        t = 2.0 * np.cross(v, g)
        return g + w * t + np.cross(v, t)

    def observe(self, accel, mask=None) -> None:
        a = np.ascontiguousarray(np.reshape(accel, (self.n, 3)), float)
        inertial_observe(self.qg, self.lp, self.nobs, a, as_mask(mask, self.n))

    def reset(self, accel=None, mask=None) -> None:
        """Eq. 3.5-3.6 from ``accel`` or, when None, from the low-passed estimate (the reset button)."""
        use = accel is not None
        a = np.ascontiguousarray(np.reshape(accel, (self.n, 3)) if use else np.zeros((self.n, 3)), float)
        inertial_reset(self.q, self.qg, self.qc, self.lp, self.nobs, a, use, as_mask(mask, self.n), self.params()[1])
        self.bias[as_mask(mask, self.n)] = 0.0
