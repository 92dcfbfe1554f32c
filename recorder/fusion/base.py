"""What every orientation filter provides: one object filters all IMUs of the glove at once.

Conventions (recorder/hand/kinematics.py): quaternions are (w, x, y, z) arrays, ``q`` maps vectors from an IMU's
own axes into the world frame (z up), gyro in rad/s in the IMU's axes, accelerometer in g as specific force
(+1 on z when the IMU lies flat and still). ``dt`` in seconds, a scalar or one value per IMU. ``mask`` (n,) bool
selects the IMUs that take part in a call; the others keep their state untouched (a dead IMU is not fused).

A filter is its settings, its state arrays and its numba step kernel, registered together (recorder/fusion/
registry.py): ``update`` runs the step on one sample, ``block`` the loop generated around the same step over T
samples (recorder/fusion/dispatch.py).
"""

from __future__ import annotations

import numpy as np

from recorder.fusion.gravity import attitude_from_gravity


def as_mask(mask, n: int) -> np.ndarray:
    """(n,) bool from None (all), a bool array or an int bit mask."""
    if mask is None:
        return np.ones(n, bool)
    if isinstance(mask, (int, np.integer)):
        return (int(mask) >> np.arange(n)) & 1 == 1
    return np.ascontiguousarray(np.asarray(mask, bool).reshape(n))


class Filter:
    """Base of the glove filters: ``q`` (n, 4), ``bias`` (n, 3) rad/s (the filter's own gyro bias estimate,
    zero for filters without one), ``reset``, ``observe``, ``update`` and ``block``."""

    name = "filter"  # set by register_filter, with ``spec`` (the registry's FilterSpec)
    STATE = ("q", "bias")  # the state arrays by name (``state``, ``load_state``)

    def __init__(self, n: int):
        self.n = int(n)
        self.q = np.tile([1.0, 0.0, 0.0, 0.0], (self.n, 1))
        self.bias = np.zeros((self.n, 3))

    def params(self) -> tuple:
        """The settings as the kernels take them, in their order (after the state and the sample)."""
        raise NotImplementedError

    def observe(self, accel, mask=None) -> None:
        """See an accelerometer sample without filtering (while the gyro is being calibrated)."""

    def reset(self, accel, mask=None) -> None:
        """Attitude from gravity (thesis eq. 3.5-3.6, yaw 0) for the masked IMUs; the bias estimate is cleared."""
        m = as_mask(mask, self.n)
        self.q[m] = attitude_from_gravity(np.asarray(accel, float).reshape(self.n, 3)[m])
        self.bias[m] = 0.0

    def kernel_state(self) -> tuple:
        """The filter's state arrays other than ``q`` and ``bias``, as its step kernel takes them (``state``)."""
        return ()

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        """One step for the masked IMUs (the filter's step kernel); returns ``q``."""
        sample = self._sample(gyro, accel, dt, mask)
        self.spec.step(self.q, self.bias, self.kernel_state(), *sample, self.kernel_params())
        return self.q

    def block(self, gyro, accel, dt, mask, out) -> None:
        """T steps (the block loop around the step kernel, recorder/fusion/dispatch.py): gyro, accel (T, n, 3), dt
        (T, n), mask (T, n) bool, all C contiguous; q after each step into out (T, n, 4). ``filter_block``
        prepares the arguments."""
        from recorder.fusion.dispatch import loops  # generated per filter, once per process

        loops(self.spec).block(self.q, self.bias, self.kernel_state(), self.kernel_params(), gyro, accel, dt, mask, out)

    def kernel_params(self) -> np.ndarray:
        """``params()`` as the step kernel takes them."""
        return np.array(self.params(), float)

    def _sample(self, gyro, accel, dt, mask):
        """One sample as the step kernels take it: gyro, accel (n, 3), dt (n,), mask (n,) bool."""
        n = self.n
        return (
            np.ascontiguousarray(np.reshape(gyro, (n, 3)), float),
            np.ascontiguousarray(np.reshape(accel, (n, 3)), float),
            np.ascontiguousarray(np.broadcast_to(np.asarray(dt, float), (n,))),
            as_mask(mask, n),
        )

    def state(self) -> dict:
        """Every state array by name (copies), for checkpoints."""
        return {k: getattr(self, k).copy() for k in self.STATE}

    def load_state(self, state: dict) -> None:
        for k, v in state.items():
            setattr(self, k, np.array(v, dtype=getattr(self, k).dtype, copy=True))
