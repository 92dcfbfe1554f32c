"""Online gyro-bias tracking: a slowly drifting bias (the MPU9250's zero-rate output moves with temperature,
±0.03 deg/s/°C) must not become drifting joints (Kortier et al. carry the bias in their state for this).

The tracker holds b (n, 3) rad/s, subtracted from the gyro on top of the static calibration (thesis eq. 3.20).
Each step it learns from three sources:
1. gravity (filters without a bias state of their own: complementary, madgwick): b -= ki e dt with
   e = trust (a_n x R(q)^T z), the integral term of Mahony's filter (Santaera et al. Algorithm 1 step 8) run
   beside the filter; observes the two components of b that are horizontal in the world;
2. stillness: after ``still_time_s`` with |gyro - b| < still_rate and full accelerometer trust, the IMU is taken
   as resting and b moves towards the measured rate with time constant ``still_tau_s`` (all three components);
3. the joint constraints (recorder/fusion/host.py): the heading correction the hand model asks for, along the
   part of a vertical rotation each joint can see, mapped into the IMU's axes: the component of b about the
   vertical, which gravity never sees.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.fusion.base import as_mask

UP = np.array([0.0, 0.0, 1.0])


@dataclass
class BiasSettings:
    ki: float = 0.001  # rad/s^2 per unit gravity error (source 1; 0 disables)
    still_rate: float = 0.03  # rad/s (source 2)
    still_time_s: float = 0.5
    still_tau_s: float = 2.0
    max_bias: float = 0.2  # rad/s: the estimate is clamped to this per axis


class BiasTracker:
    def __init__(self, n: int = 12, settings: BiasSettings | None = None, use_gravity: bool = True):
        self.n = int(n)
        self.settings = settings or BiasSettings()
        self.use_gravity = bool(use_gravity)
        self.b = np.zeros((self.n, 3))
        self.still_for = np.zeros(self.n)

    def update(self, gyro, accel, q, trust, dt, mask=None) -> np.ndarray:
        """One step after the filter's: gyro (n, 3) rad/s with the static bias but not b removed, accel (n, 3)
        g, q (n, 4) the filter's new orientations, trust (n,) the accelerometer trust in [0, 1]."""
        s = self.settings
        m = as_mask(mask, self.n)
        dt = np.broadcast_to(np.asarray(dt, float), (self.n,))
        rate = np.asarray(gyro, float) - self.b
        if self.use_gravity and s.ki > 0.0:
            a = np.asarray(accel, float)
            an = np.linalg.norm(a, axis=1, keepdims=True)
            a_n = np.where(an > 0.0, a / np.where(an > 0.0, an, 1.0), 0.0)
            e = np.asarray(trust, float)[:, None] * np.cross(a_n, quat.rotate(quat.conj(q), UP))
            self.b = np.where(m[:, None], self.b - s.ki * e * dt[:, None], self.b)
        still = m & (np.max(np.abs(rate), axis=1) < s.still_rate) & (np.asarray(trust) >= 1.0)
        self.still_for = np.where(still, self.still_for + dt, 0.0)
        learn = still & (self.still_for >= s.still_time_s)
        k = np.minimum(dt / s.still_tau_s, 1.0)[:, None]
        self.b = np.where(learn[:, None], self.b + k * rate, self.b)
        self.b = np.clip(self.b, -s.max_bias, s.max_bias)
        return self.b

    def add_heading(self, seen, q, gain, mask=None) -> None:
        """Source 3: ``seen`` (n, 3) the heading correction the joint constraints ask for (rad) times the world
        direction of a rotation about the vertical that the joints can see (a hinge cannot see the part about its
        own axis: learning it would only turn the joint); b moves by -gain seen, mapped into the IMU's axes."""
        m = as_mask(mask, self.n)
        u = quat.rotate(quat.conj(q), np.asarray(seen, float))
        self.b = np.where(m[:, None], self.b - np.asarray(gain)[..., None] * u, self.b)
