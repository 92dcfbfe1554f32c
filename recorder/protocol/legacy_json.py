"""The thesis prototype's JSON lines (§4.3): one object per line, parent-relative joint quaternions.

    {"wrists": {"w":..,"x":..,"y":..,"z":..}, "fingers": [{"joints": [q, q, q]}, ... x5]}

Fingers are thumb first; joints are proximal, intermediate, distal (for the thumb: metacarpal, proximal,
distal), which maps onto segments 1 + 3*finger + joint. "wrist" is accepted for "wrists". The lines carry
no sequence number or device time: the link stamps them with the host receive time.
"""

from __future__ import annotations

import json
import math

import numpy as np

from recorder.protocol.frames import PoseFrame

_KEYS = ("w", "x", "y", "z")


class JsonFrameError(ValueError):
    pass


def _quat(obj) -> tuple[float, float, float, float]:
    if not isinstance(obj, dict):
        raise JsonFrameError("quaternion is not an object")
    try:
        q = tuple(float(obj[k]) for k in _KEYS)
    except (KeyError, TypeError, ValueError):
        raise JsonFrameError("quaternion needs numeric w, x, y, z") from None
    n = math.sqrt(sum(c * c for c in q))
    if not math.isfinite(n) or n < 1e-6:
        raise JsonFrameError("quaternion is zero or not finite")
    return q


def decode_line(line: bytes | str, seq: int = -1) -> PoseFrame:
    """Parse one JSON line into a PoseFrame (t_us = -1: no device time). Raises JsonFrameError."""
    try:
        obj = json.loads(line)
    except (ValueError, UnicodeDecodeError) as exc:
        raise JsonFrameError(f"malformed JSON: {exc}") from None
    if not isinstance(obj, dict):
        raise JsonFrameError("not a JSON object")
    wrist = obj.get("wrists", obj.get("wrist"))
    fingers = obj.get("fingers")
    if wrist is None or not isinstance(fingers, list) or len(fingers) != 5:
        raise JsonFrameError('needs "wrists" and 5 "fingers"')
    quats = np.empty((16, 4), np.float32)
    quats[0] = _quat(wrist)
    for f, finger in enumerate(fingers):
        joints = finger.get("joints") if isinstance(finger, dict) else None
        if not isinstance(joints, list) or len(joints) != 3:
            raise JsonFrameError(f"finger {f} needs 3 joints")
        for j, q in enumerate(joints):
            quats[1 + 3 * f + j] = _quat(q)
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    return PoseFrame(seq, -1, quats)


def encode_line(quats: np.ndarray, decimals: int = 6) -> bytes:
    """The thesis' payload for 16 parent-relative quaternions, newline-terminated."""

    def q(i):
        return {k: round(float(v), decimals) for k, v in zip(_KEYS, quats[i])}

    obj = {"wrists": q(0), "fingers": [{"joints": [q(1 + 3 * f + j) for j in range(3)]} for f in range(5)]}
    return json.dumps(obj, separators=(",", ":")).encode() + b"\n"
