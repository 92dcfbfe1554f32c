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

from recorder.config import STRICT
from recorder.fusion import kernels
from recorder.fusion.base import as_mask


@dataclass
class BiasSettings:
    __pydantic_config__ = STRICT

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

    def params(self) -> np.ndarray:
        """The settings as the kernels take them: (ki, still_rate, still_time_s, still_tau_s, max_bias)."""
        s = self.settings
        return np.array([s.ki, s.still_rate, s.still_time_s, s.still_tau_s, s.max_bias], float)

    def update(self, gyro, accel, q, trust, dt, mask=None) -> np.ndarray:
        """One step after the filter's: gyro (n, 3) rad/s with the static bias but not b removed, accel (n, 3)
        g, q (n, 4) the filter's new orientations, trust (n,) the accelerometer trust in [0, 1]."""
        kernels.bias_step(
            self.b,
            self.still_for,
            _rows(gyro, self.n, 3),
            _rows(accel, self.n, 3),
            _rows(q, self.n, 4),
            _each(trust, self.n),
            _each(dt, self.n),
            as_mask(mask, self.n),
            self.params(),
            self.use_gravity,
        )
        return self.b

    def add_heading(self, seen, q, gain, mask=None) -> None:
        """Source 3: ``seen`` (n, 3) the heading correction the joint constraints ask for (rad) times the world
        direction of a rotation about the vertical that the joints can see (a hinge cannot see the part about its
        own axis: learning it would only turn the joint); b moves by -gain seen, mapped into the IMU's axes."""
        kernels.bias_heading(
            self.b, _rows(q, self.n, 4), _rows(seen, self.n, 3), _each(gain, self.n), as_mask(mask, self.n)
        )


def _rows(x, n: int, k: int) -> np.ndarray:
    return np.ascontiguousarray(np.reshape(x, (n, k)), float)


def _each(x, n: int) -> np.ndarray:
    return np.ascontiguousarray(np.broadcast_to(np.asarray(x, float), (n,)))
