"""The glove's filter: tilt from the accelerometer low-passed in an almost-inertial frame (the idea of Laidig &
Seel's VQF, Information Fusion 2023, written here from the idea, not from their code), shared with the firmware
(firmware/lib/glove_core/complementary_filter.cpp, FilterMode::Inertial; the same bits in a double build,
tests/test_fusion_firmware.py). The maths: recorder/fusion/kernels.py ``inertial_step``; this class holds the
settings and the state.

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

from dataclasses import dataclass

import numpy as np

from recorder.fusion import kernels
from recorder.fusion.base import Filter, as_mask


@dataclass
class InertialSettings:
    tau_s: float = 4.0  # s, each of the three low-pass stages (chosen leave-one-trial-out: docs/fusion.md)
    ramp: float = 3.0  # 3: follows a ramp without lag; 0: plain low-pass


class InertialFilter(Filter):
    name = "inertial"
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

    def gravity(self) -> np.ndarray:
        """The low-passed accelerometer (n, 3) in the IMU's axes now (step 4, back from I)."""
        tau, ramp = self.params()
        g = self.lp[:, 2] + ramp * (self.lp[:, 1] - self.lp[:, 2])
        w, v = self.qg[:, :1], -self.qg[:, 1:]
        t = 2.0 * np.cross(v, g)
        return g + w * t + np.cross(v, t)

    def observe(self, accel, mask=None) -> None:
        a = np.ascontiguousarray(np.reshape(accel, (self.n, 3)), float)
        kernels.inertial_observe(self.qg, self.lp, self.nobs, a, as_mask(mask, self.n))

    def reset(self, accel=None, mask=None) -> None:
        """Eq. 3.5-3.6 from ``accel`` or, when None, from the low-passed estimate (the reset button)."""
        use = accel is not None
        a = np.ascontiguousarray(np.reshape(accel, (self.n, 3)) if use else np.zeros((self.n, 3)), float)
        kernels.inertial_reset(
            self.q, self.qg, self.qc, self.lp, self.nobs, a, use, as_mask(mask, self.n), self.params()[1]
        )
        self.bias[as_mask(mask, self.n)] = 0.0

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        kernels.inertial_step(
            self.q, self.qg, self.qc, self.lp, self.nobs, *self._sample(gyro, accel, dt, mask), *self.params()
        )
        return self.q

    def block(self, gyro, accel, dt, mask, out) -> None:
        kernels.inertial(self.q, self.qg, self.qc, self.lp, self.nobs, gyro, accel, dt, mask, *self.params(), out)
