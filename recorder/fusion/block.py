"""Filter a whole recording in one call: ``filter_block(filt, gyro, accel, dt)`` with gyro, accel (T, n, 3)
returns the orientations (T, n, 4) after every sample and leaves ``filt`` in its final state, exactly as T calls
of ``filt.update`` would (the numpy reference, ``engine="numpy"``), but compiled (``engine="numba"``, the default
when numba is installed). dt: a scalar, (T,) or (T, n); mask: None, (T,) int bit masks or (T, n) bool.
Non-finite samples must be masked out (HostFusion flags and masks them), as for ``update``.
"""

from __future__ import annotations

import numpy as np

from recorder.fusion import kernels
from recorder.fusion.base import Filter
from recorder.fusion.complementary import ComplementaryFilter
from recorder.fusion.madgwick import MadgwickFilter
from recorder.fusion.mahony import MahonyFilter
from recorder.fusion.relative import RelativeFilter


def _masks(mask, T: int, n: int) -> np.ndarray:
    if mask is None:
        return np.ones((T, n), bool)
    m = np.asarray(mask)
    if m.ndim == 1:
        return ((m.astype(np.int64)[:, None] >> np.arange(n)) & 1) == 1
    return np.ascontiguousarray(m, bool).reshape(T, n)


def filter_block(filt: Filter, gyro, accel, dt, mask=None, engine: str = "auto") -> np.ndarray:
    gyro = np.ascontiguousarray(gyro, float)
    accel = np.ascontiguousarray(accel, float)
    T, n = gyro.shape[:2]
    dts = np.ascontiguousarray(
        np.broadcast_to(np.asarray(dt, float).reshape((-1, 1) if np.ndim(dt) == 1 else np.shape(dt)), (T, n))
    )
    masks = _masks(mask, T, n)
    if engine not in ("auto", "numba", "numpy"):
        raise ValueError(f"engine must be auto, numba or numpy, got {engine!r}")
    if engine == "numba" and not kernels.AVAILABLE:
        raise RuntimeError("numba is not installed")
    out = np.empty((T, n, 4))
    if engine == "numpy" or not kernels.AVAILABLE:
        for t in range(T):
            out[t] = filt.update(gyro[t], accel[t], dts[t], masks[t])
        return out
    s = filt.settings
    if isinstance(filt, ComplementaryFilter):
        m = filt.median
        kernels.complementary(
            filt.q,
            m.buf,
            m.head,
            m.count,
            filt.gain,
            gyro,
            accel,
            dts,
            masks,
            s.static_gain,
            s.threshold1,
            s.threshold2,
            out,
        )
    elif isinstance(filt, MahonyFilter):
        kernels.mahony(
            filt.q, filt.bias, gyro, accel, dts, masks, s.kp, s.ki, s.threshold1, s.threshold2, s.integral_limit, out
        )
    elif isinstance(filt, MadgwickFilter):
        kernels.madgwick(filt.q, gyro, accel, dts, masks, s.beta, s.threshold1, s.threshold2, out)
    elif isinstance(filt, RelativeFilter):
        kernels.relative(
            filt.q,
            filt.rel,
            filt.root.q,
            filt.root.bias,
            filt.bias,
            filt.parents.astype(np.int64),
            np.asarray(filt.order, np.int64),
            gyro,
            accel,
            dts,
            masks,
            s.kp,
            s.ki,
            s.root_kp,
            s.root_ki,
            s.threshold1,
            s.threshold2,
            s.integral_limit,
            bool(s.rotate_parent_rate),
            out,
        )
    else:  # a filter without a kernel: the reference loop
        for t in range(T):
            out[t] = filt.update(gyro[t], accel[t], dts[t], masks[t])
    return out
