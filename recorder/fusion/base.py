"""What every orientation filter provides: one object filters all IMUs of the glove at once.

Conventions (recorder/hand/kinematics.py): quaternions are (w, x, y, z) arrays, ``q`` maps vectors from an IMU's
own axes into the world frame (z up), gyro in rad/s in the IMU's axes, accelerometer in g as specific force
(+1 on z when the IMU lies flat and still). ``dt`` in seconds, a scalar or one value per IMU. ``mask`` (n,) bool
selects the IMUs that take part in a call; the others keep their state untouched (a dead IMU is not fused).
"""

from __future__ import annotations

import numpy as np

from recorder.fusion.gravity import attitude_from_gravity, gain_factor


def as_mask(mask, n: int) -> np.ndarray:
    """(n,) bool from None (all), a bool array or an int bit mask."""
    if mask is None:
        return np.ones(n, bool)
    if isinstance(mask, (int, np.integer)):
        return (int(mask) >> np.arange(n)) & 1 == 1
    return np.asarray(mask, bool).reshape(n)


class Filter:
    """Base of the glove filters: ``q`` (n, 4), ``bias`` (n, 3) rad/s (the filter's own gyro bias estimate,
    zero for filters without one), ``reset``, ``observe`` and ``update``."""

    name = "filter"

    def __init__(self, n: int):
        self.n = int(n)
        self.q = np.tile([1.0, 0.0, 0.0, 0.0], (self.n, 1))
        self.bias = np.zeros((self.n, 3))

    def observe(self, accel, mask=None) -> None:
        """See an accelerometer sample without filtering (while the gyro is being calibrated)."""

    def reset(self, accel, mask=None) -> None:
        """Attitude from gravity (thesis eq. 3.5-3.6, yaw 0) for the masked IMUs; the bias estimate is cleared."""
        m = as_mask(mask, self.n)
        self.q[m] = attitude_from_gravity(np.asarray(accel, float).reshape(self.n, 3)[m])
        self.bias[m] = 0.0

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        """One step for the masked IMUs; returns ``q``."""
        raise NotImplementedError

    def _inputs(self, accel, dt, mask, t1: float, t2: float):
        """The masked step's inputs: (mask, dt (k, 1), accel (k, 3), its norm (k, 1), accelerometer trust
        (k, 1) from the thesis' eq. 3.19 ramp between thresholds ``t1`` and ``t2``)."""
        m = as_mask(mask, self.n)
        dt = np.broadcast_to(np.asarray(dt, float), (self.n,))[m, None]
        a = np.asarray(accel, float).reshape(self.n, 3)[m]
        an = np.linalg.norm(a, axis=1, keepdims=True)
        return m, dt, a, an, gain_factor(an[:, 0], t1, t2)[:, None]

    def state(self) -> dict:
        """Every state array by name (copies), for the block kernels and for checkpoints."""
        return {"q": self.q.copy(), "bias": self.bias.copy()}

    def load_state(self, state: dict) -> None:
        for k, v in state.items():
            setattr(self, k, np.array(v, dtype=getattr(self, k).dtype, copy=True))
