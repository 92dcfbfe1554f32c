"""The wrist pose message: how any tracker (a VR tracker bridge, a phone's AR session, a mocap system) sends the
wrist's 6-DoF pose to gloverec, one message per UDP datagram, as a JSON line or its binary twin.

JSON (one object, UTF-8, a trailing newline optional)::

    {"seq": 17, "t": 1764684000.125, "p": [0.31, -0.02, 0.95], "q": [1, 0, 0, 0], "tracked": true}

  seq      message counter (uint32, wraps): gaps are lost messages
  t        when the pose was measured, seconds on the sender's clock; a sender on this machine (or with a synced
           clock) uses Unix time (Python's time.time()), and gloverec reports the latency as arrival - t
  p        position, metres, in the tracker's frame
  q        orientation, unit quaternion w, x, y, z, the tracker's frame to the wrist's
  tracked  optional, default true: false when the tracker has lost the wrist (p and q then repeat the last pose)

Binary (little-endian, 45 bytes)::

    magic b"GWR1" | seq uint32 | t float64 | p 3 x float32 | q 4 x float32 | flags uint8 (bit 0: tracked)

Written by hand: it is a dozen lines over ``json`` and ``struct``, and no tracker library defines a format both a
phone app and a mocap bridge already speak.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass

import numpy as np

from recorder import GloverecError

MAGIC = b"GWR1"
_BINARY = struct.Struct("<4sId3f4fB")
BINARY_SIZE = _BINARY.size  # 45


class WristFormatError(GloverecError):
    """A datagram that is not a wrist pose (counted and skipped by the sources, never fatal)."""


@dataclass(frozen=True)
class WristPose:
    """One tracked wrist pose: ``seq``, ``t`` (sender's clock, s), ``position`` (3, m), ``quat`` (4, wxyz, unit),
    ``tracked``; a marker's also ``alternative``, the other pose its square's image allows ((position, quat)),
    and ``errors_px``, the reprojection error of each (px), neither sent over UDP: recorder/wrist/fusion.py picks
    between the two."""

    seq: int
    t: float
    position: np.ndarray
    quat: np.ndarray
    tracked: bool = True
    alternative: tuple | None = None
    errors_px: tuple | None = None


def encode_json(pose: WristPose) -> bytes:
    return (
        json.dumps(
            {
                "seq": int(pose.seq),
                "t": float(pose.t),
                "p": [float(v) for v in pose.position],
                "q": [float(v) for v in pose.quat],
                "tracked": bool(pose.tracked),
            }
        )
        + "\n"
    ).encode()


def encode_binary(pose: WristPose) -> bytes:
    return _BINARY.pack(MAGIC, int(pose.seq) & 0xFFFFFFFF, float(pose.t), *map(float, pose.position),
                        *map(float, pose.quat), int(bool(pose.tracked)))  # fmt: skip


def decode(data: bytes) -> WristPose:
    """A datagram's pose (binary when it starts with the magic, else JSON); WristFormatError saying what is wrong."""
    if data[:4] == MAGIC:
        if len(data) != BINARY_SIZE:
            raise WristFormatError(f"binary wrist pose of {len(data)} bytes, expected {BINARY_SIZE}")
        _, seq, t, *rest = _BINARY.unpack(data)
        position, quat, flags = rest[:3], rest[3:7], rest[7]
        return _checked(seq, t, position, quat, bool(flags & 1))
    try:
        msg = json.loads(data.decode())
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise WristFormatError(f"not a wrist pose: {data[:32]!r}") from None
    if not isinstance(msg, dict):
        raise WristFormatError("a wrist pose is a JSON object")
    missing = [k for k in ("seq", "t", "p", "q") if k not in msg]
    if missing:
        raise WristFormatError(f"wrist pose without {', '.join(missing)}")
    tracked = msg.get("tracked", True)
    if not isinstance(tracked, bool):
        raise WristFormatError("wrist pose 'tracked' must be true or false")
    seq = msg["seq"]
    if not isinstance(seq, int) or isinstance(seq, bool) or not 0 <= seq < 2**32:
        raise WristFormatError("wrist pose 'seq' must be an integer in 0..2^32-1")
    return _checked(seq, msg["t"], msg["p"], msg["q"], tracked)


def _numbers(value, n: int, name: str) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise WristFormatError(f"wrist pose '{name}' must be {n} numbers")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise WristFormatError(f"wrist pose '{name}' must be {n} numbers")
    out = np.asarray(value, float)
    if not np.all(np.isfinite(out)):
        raise WristFormatError(f"wrist pose '{name}' is not finite")
    return out


def _checked(seq, t, position, quat, tracked: bool) -> WristPose:
    if not isinstance(t, (int, float)) or isinstance(t, bool) or not math.isfinite(t):
        raise WristFormatError("wrist pose 't' must be a finite number of seconds")
    p, q = _numbers(position, 3, "p"), _numbers(quat, 4, "q")
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > 0.01:
        raise WristFormatError(f"wrist pose 'q' is not a unit quaternion (norm {norm:.3g})")
    return WristPose(int(seq), float(t), p, q / norm, tracked)
