"""Bad input and per-frame quality. A flagged IMU is not fused (its filter holds its state) and the joints it
drives are marked invalid in the output: bad samples are flagged, never propagated silently into a dataset.

Flags per IMU and frame (bits of a uint8):
- MISSING: the raw frame's ok_mask bit is clear (the IMU did not answer; the firmware zeroes its row);
- NONFINITE: a NaN or infinite value (possible in converted or replayed data, never in int16 registers);
- SATURATED: an accelerometer or gyro register at -32768 or 32767 (full scale exceeded: the value is wrong);
- DEAD: all six accelerometer and gyro values exactly zero, or an accelerometer reading zero (an IMU that
  answers with an empty register file);
- STUCK: the same six values ``stuck_frames`` frames in a row (noise makes that impossible for a live sensor).
"""

from __future__ import annotations

import numpy as np

MISSING, NONFINITE, SATURATED, DEAD, STUCK = 1, 2, 4, 8, 16
NAMES = {MISSING: "missing", NONFINITE: "nonfinite", SATURATED: "saturated", DEAD: "dead", STUCK: "stuck"}
STUCK_FRAMES = 10


def describe(flags: int) -> list[str]:
    return [name for bit, name in NAMES.items() if int(flags) & bit]


class InputCheck:
    """Flags (T, n) uint8 for raw readings (T, n, 7) (int16 registers, or floats in the same layout) and
    ok_mask (T,) int bit masks (None: all answered). Keeps the last frame, so blocks can follow each other."""

    def __init__(self, n: int = 12, stuck_frames: int = STUCK_FRAMES):
        self.n = int(n)
        self.stuck_frames = int(stuck_frames)
        self.last = None
        self.repeats = np.zeros(self.n, np.int64)

    def __call__(self, raw, ok_mask=None) -> np.ndarray:
        raw = np.asarray(raw)
        T, n = raw.shape[:2]
        six = raw[..., :6]
        flags = np.zeros((T, n), np.uint8)
        if T == 0:
            return flags
        if ok_mask is not None:
            ok = (np.asarray(ok_mask, np.int64).reshape(T, 1) >> np.arange(n)) & 1
            flags |= np.where(ok == 0, MISSING, 0).astype(np.uint8)
        if raw.dtype.kind == "f":
            flags |= np.where(~np.all(np.isfinite(raw), axis=2), NONFINITE, 0).astype(np.uint8)
        with np.errstate(invalid="ignore"):
            flags |= np.where(np.any((six <= -32768) | (six >= 32767), axis=2), SATURATED, 0).astype(np.uint8)
            flags |= np.where(np.all(six[..., :3] == 0, axis=2), DEAD, 0).astype(np.uint8)
        same = np.empty((T, n), bool)
        same[0] = np.all(six[0] == self.last, axis=1) if self.last is not None else False
        same[1:] = np.all(six[1:] == six[:-1], axis=2)
        # run length of identical frames: frames since the last change (+ the previous block's run)
        t = np.arange(T)[:, None]
        start = np.maximum.accumulate(np.where(same, 0, t), axis=0)
        run = t - start + 1 + np.where((start == 0) & same[0], self.repeats, 0)
        self.repeats = run[-1].copy()
        self.last = six[-1].copy()
        flags |= np.where(run >= self.stuck_frames, STUCK, 0).astype(np.uint8)
        return flags
