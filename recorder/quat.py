"""Vectorised unit-quaternion helpers on numpy.

Quaternions are (w, x, y, z), Hamilton convention (thesis eq. 3.1 and 3.2), in arrays whose last axis has the
4 components; every function broadcasts over the leading axes. ``rotate(q, v)`` maps a vector from the frame
that ``q`` describes into its parent frame (v' = q v q*), so a segment's global orientation composes as
``mul(parent_global, child_relative)``. Rotation vectors are axis * angle in radians.
"""

from __future__ import annotations

import numpy as np

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


# mul, conj and rotate run in every per-frame path (the emulator's synthesis, fusion, retargeting): components are
# taken by indexing and written into one array, since np.moveaxis, np.stack and np.cross cost more than the
# arithmetic on small arrays; the arithmetic and its order are theirs, so the results are bit for bit the same.
_CONJ = np.array([1.0, -1.0, -1.0, -1.0])


def mul(p, q) -> np.ndarray:
    """Hamilton product p q (thesis eq. 3.2)."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(np.broadcast_shapes(p.shape, q.shape))
    out[..., 0] = pw * qw - px * qx - py * qy - pz * qz
    out[..., 1] = pw * qx + px * qw + py * qz - pz * qy
    out[..., 2] = pw * qy - px * qz + py * qw + pz * qx
    out[..., 3] = pw * qz + px * qy - py * qx + pz * qw
    return out


def conj(q) -> np.ndarray:
    """Conjugate, the inverse of a unit quaternion."""
    return np.asarray(q, dtype=float) * _CONJ


def normalize(q) -> np.ndarray:
    """Scale to unit norm."""
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def positive(q) -> np.ndarray:
    """The same rotation with w >= 0 (q and -q are one rotation)."""
    q = np.asarray(q, dtype=float)
    return np.where(q[..., :1] < 0.0, -q, q)


def rotate(q, v) -> np.ndarray:
    """Rotate 3-vectors v by unit quaternions q: q v q*."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * _cross(u, v)
    return v + w * t + _cross(u, t)


def _cross(a, b) -> np.ndarray:
    """np.cross of 3-vectors (..., 3), its formula without its axis handling."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def to_matrix(q) -> np.ndarray:
    """Rotation matrices (..., 3, 3) whose columns are the frame's axes in the parent frame."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack(
        (
            np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)), axis=-1),
            np.stack((2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)), axis=-1),
            np.stack((2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)), axis=-1),
        ),
        axis=-2,
    )


def from_rotvec(rv) -> np.ndarray:
    """Quaternion from a rotation vector (axis * angle, radians)."""
    rv = np.asarray(rv, dtype=float)
    angle = np.linalg.norm(rv, axis=-1, keepdims=True)
    # sin(angle/2)/angle == 0.5 * sinc(angle / 2pi), stable at 0
    return np.concatenate((np.cos(0.5 * angle), rv * (0.5 * np.sinc(angle / (2.0 * np.pi)))), axis=-1)


def to_rotvec(q) -> np.ndarray:
    """Rotation vector (axis * angle, angle in [0, pi]) of a unit quaternion."""
    q = positive(q)
    w = q[..., :1]
    v = q[..., 1:]
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(n, w)
    small = n < 1e-12
    scale = np.where(small, 2.0 / np.where(small, w, 1.0), angle / np.where(small, 1.0, n))
    return v * scale


def from_axis_angle(axis, angle) -> np.ndarray:
    """Quaternion for a rotation of ``angle`` radians about ``axis`` (normalised here)."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    return np.concatenate((np.cos(half) + 0.0 * axis[..., :1], np.sin(half) * axis), axis=-1)


def to_axis_angle(q) -> tuple[np.ndarray, np.ndarray]:
    """(unit axis (..., 3), angle (...,) in [0, pi]); the axis is x for a null rotation."""
    rv = to_rotvec(q)
    angle = np.linalg.norm(rv, axis=-1)
    safe = np.where(angle > 1e-12, angle, 1.0)[..., None]
    axis = np.where(angle[..., None] > 1e-12, rv / safe, np.array([1.0, 0.0, 0.0]))
    return axis, angle


def from_two_vectors(u, v) -> np.ndarray:
    """Shortest rotation taking the direction of u onto the direction of v."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    u, v = np.broadcast_arrays(u, v)
    # 1 + u.v as |u + v|^2 / 2: no cancellation when u and v are nearly opposite (1 + u.v lost the angle there)
    w = 0.5 * np.sum((u + v) ** 2, axis=-1, keepdims=True)
    axis = np.cross(u, v)
    # exactly opposite vectors: half turn about any axis perpendicular to u
    other = np.where(np.abs(u[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    perp = np.cross(u, other)
    opposite = w + np.linalg.norm(axis, axis=-1, keepdims=True) < 1e-15
    q = np.where(opposite, np.concatenate((np.zeros_like(w), perp), axis=-1), np.concatenate((w, axis), axis=-1))
    return normalize(q)


def slerp(q0, q1, t) -> np.ndarray:
    """Spherical linear interpolation (thesis eq. 3.10) along the shortest path; t in [0, 1] broadcasts."""
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    t = np.asarray(t, dtype=float)[..., None]
    d = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(d < 0.0, -q1, q1)
    d = np.abs(d)
    omega = np.arccos(np.clip(d, -1.0, 1.0))
    s = np.sin(omega)
    near = s < 1e-6
    safe = np.where(near, 1.0, s)
    w0 = np.where(near, 1.0 - t, np.sin((1.0 - t) * omega) / safe)
    w1 = np.where(near, t, np.sin(t * omega) / safe)
    return normalize(w0 * q0 + w1 * q1)


def angle_between(q0, q1) -> np.ndarray:
    """Angle in radians, in [0, pi], of the rotation taking q0 to q1."""
    d = mul(conj(q0), q1)
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))
