"""Filter a whole recording in one call: ``filter_block(filt, gyro, accel, dt)`` with gyro, accel (T, n, 3)
returns the orientations (T, n, 4) after every sample and leaves ``filt`` in its final state, exactly as T calls
of ``filt.update`` would: both run the filter's step kernel, here inside the block loop generated around it
(recorder/fusion/dispatch.py). dt: a scalar, (T,) or (T, n); mask: None, (T,) int bit masks or (T, n) bool.
Non-finite samples must be masked out (HostFusion flags and masks them), as for ``update``.
"""

from __future__ import annotations

import numpy as np

from recorder.fusion.base import Filter


def _masks(mask, T: int, n: int) -> np.ndarray:
    if mask is None:
        return np.ones((T, n), bool)
    m = np.asarray(mask)
    if m.ndim == 1:
        return ((m.astype(np.int64)[:, None] >> np.arange(n)) & 1) == 1
    return np.ascontiguousarray(m, bool).reshape(T, n)


def filter_block(filt: Filter, gyro, accel, dt, mask=None) -> np.ndarray:
    """``filt`` over T samples (its block kernel); returns q after each sample (T, n, 4)."""
    gyro = np.ascontiguousarray(gyro, float)
    accel = np.ascontiguousarray(accel, float)
    T, n = gyro.shape[:2]
    dts = np.ascontiguousarray(
        np.broadcast_to(np.asarray(dt, float).reshape((-1, 1) if np.ndim(dt) == 1 else np.shape(dt)), (T, n))
    )
    out = np.empty((T, n, 4))
    filt.block(gyro, accel, dts, _masks(mask, T, n), out)
    return out
