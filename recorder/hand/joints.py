"""Relative segment orientations -> the 20 joint angles, with the joints' dimensionality (Kortier et al., "Joint
dimensionality constraint") and anatomical limits; distal interpolation (thesis eq. 3.3); fingertips.

Every measured rotation is projected onto the rotations its joint can make, the closest one in the Frobenius
(chordal) sense, so noise never shows up as impossible motion:
- hinges (finger PIP, thumb MCP and IP, and DIP when measured) turn about the segment's y only: the closest
  rotation about y to R is the twist of R about y, angle atan2(R02 - R20, R00 + R22) = 2 atan2(q_y, q_w);
- 2-DoF joints (finger MCP, thumb CMC after removing its rest frame) are Rz(abduction) Ry(flexion): the closest
  such rotation maximises tr(Ry(f)^T Rz(a)^T R); for a given a the best f is closed-form and a is found by a
  few Newton steps on the remaining one-dimensional problem. Twist about the finger's own axis (pronation-
  supination) is what is dropped. Near 90 degrees of MCP flexion, where abduction and twist become the same
  rotation (gimbal lock), the projection stays well conditioned.
Angles are then clamped to kinematics.LIMITS; finger DIPs without an IMU follow eq. 3.3.
"""

from __future__ import annotations

import numpy as np

from recorder import quat
from recorder.hand.kinematics import (
    DIP,
    JOINTS,
    N_JOINTS,
    REST,
    HandSize,
    clip,
    forward,
    interpolate_dip,
    relative_quats,
)
from recorder.hand.skeleton import FINGER_SEGMENTS, FINGERS, N_SEGMENTS

# (segment, flexion joint, abduction joint or -1): every joint of the model, by the segment it moves.
SWING = tuple(
    [(FINGER_SEGMENTS["thumb"][0], 0, 1)]
    + [(FINGER_SEGMENTS[f][0], 4 + 4 * k, 5 + 4 * k) for k, f in enumerate(FINGERS[1:])]
)
HINGE = tuple(
    [(FINGER_SEGMENTS["thumb"][1], 2, -1), (FINGER_SEGMENTS["thumb"][2], 3, -1)]
    + [(FINGER_SEGMENTS[f][1], 6 + 4 * k, -1) for k, f in enumerate(FINGERS[1:])]
    + [(FINGER_SEGMENTS[f][2], 7 + 4 * k, -1) for k, f in enumerate(FINGERS[1:])]
)
NEWTON_STEPS = 4


def matrix_terms(q):
    """The rotation matrix entries of unit quats (..., 4) that the projections use, as a dict."""
    w, x, y, z = np.moveaxis(np.asarray(q, float), -1, 0)
    return {
        "00": 1 - 2 * (y * y + z * z),
        "01": 2 * (x * y - w * z),
        "02": 2 * (x * z + w * y),
        "10": 2 * (x * y + w * z),
        "11": 1 - 2 * (x * x + z * z),
        "12": 2 * (y * z - w * x),
        "20": 2 * (x * z - w * y),
        "22": 1 - 2 * (x * x + y * y),
    }


def hinge_angle(q) -> np.ndarray:
    """Angle (...) in (-pi, pi] of the rotation about y closest to q (...,4): its twist about y."""
    q = np.asarray(q, float)
    return _wrap(2.0 * np.arctan2(q[..., 2], q[..., 0]))


def _wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def swing_angles(q) -> tuple[np.ndarray, np.ndarray]:
    """(flexion, abduction) of the rotation Rz(abd) Ry(flex) closest to q (..., 4)."""
    r = matrix_terms(q)
    a = np.arctan2(-r["01"], r["11"])  # exact when there is no twist; a good start otherwise
    for _ in range(NEWTON_STEPS):
        ca, sa = np.cos(a), np.sin(a)
        p = ca * r["00"] + sa * r["10"] + r["22"]
        s = ca * r["02"] + sa * r["12"] - r["20"]
        dp = -sa * r["00"] + ca * r["10"]
        ds = -sa * r["02"] + ca * r["12"]
        n = np.sqrt(p * p + s * s) + 1e-300
        g1 = (p * dp + s * ds) / n - sa * r["11"] - ca * r["01"]
        g2 = (
            (dp * dp - p * (p - r["22"]) + ds * ds - s * (s + r["20"])) / n
            - (p * dp + s * ds) ** 2 / n**3
            - ca * r["11"]
            + sa * r["01"]
        )
        a = a - np.where(g2 < -1e-9, g1 / np.where(g2 < -1e-9, g2, -1.0), -0.5 * g1)
    ca, sa = np.cos(a), np.sin(a)
    f = np.arctan2(ca * r["02"] + sa * r["12"] - r["20"], ca * r["00"] + sa * r["10"] + r["22"])
    return f, _wrap(a)


def joint_angles(rel_quats, limits: bool = True, interpolate: bool = True) -> np.ndarray:
    """The 20 joint angles (..., 20) in radians from parent-relative quats (..., 16, 4).

    Projects every joint onto its degrees of freedom (see the module docstring); ``limits`` clamps to LIMITS;
    ``interpolate`` sets the finger DIPs from the PIPs (eq. 3.3), as for a glove without distal IMUs."""
    rel = np.asarray(rel_quats, float)
    local = quat.mul(quat.conj(REST), rel)  # REST is the identity but for the thumb metacarpal
    out = np.zeros(rel.shape[:-2] + (N_JOINTS,))
    seg = [s for s, _, _ in SWING]
    flex, abd = swing_angles(local[..., seg, :])
    out[..., [j for _, j, _ in SWING]] = flex
    out[..., [j for _, _, j in SWING]] = abd
    seg = [s for s, _, _ in HINGE]
    out[..., [j for _, j, _ in HINGE]] = hinge_angle(local[..., seg, :])
    if limits:
        out = clip(out)
    if interpolate:
        out = interpolate_dip(out)
    return out


def constrained_relative(angles) -> np.ndarray:
    """Parent-relative quats (..., 16, 4) of the model at ``angles`` (palm row: identity)."""
    g, _, _ = forward(angles, quat.IDENTITY)
    return relative_quats(g)


def fingertips(angles, palm_quat=quat.IDENTITY, size: HandSize = HandSize()) -> np.ndarray:
    """Fingertip positions (..., 5, 3) in metres from the palm origin, world axes (kinematics.forward)."""
    return forward(angles, palm_quat, size)[2]


def twist(rel_quats) -> np.ndarray:
    """Residual the projection removed, per segment (..., 16) radians: angle between each measured relative
    rotation and the constrained one (0 for the palm and interpolated distals). A quality measure."""
    rel = np.asarray(rel_quats, float)
    return quat.angle_between(rel, constrained_relative(joint_angles(rel, limits=False, interpolate=False)))


__all__ = [
    "DIP",
    "HINGE",
    "JOINTS",
    "N_SEGMENTS",
    "SWING",
    "constrained_relative",
    "fingertips",
    "hinge_angle",
    "joint_angles",
    "swing_angles",
    "twist",
]
