"""Forward and inverse kinematics of the thesis hand model (§3.1), segments indexed as in ``skeleton``.

Frames (right hand):
- World: z up; gravity is -z, so a still IMU lying flat reads +1 g on its accelerometer z.
- Palm: origin at the wrist joint centre, x toward the fingers, z out of the back of the hand (dorsal),
  y = z × x (toward the thumb). The open hand lying palm down has the palm frame equal to the world's.
- Every segment: origin at its proximal joint, x along the bone toward the tip, z dorsal (the nail side),
  y = z × x. Flexion is a positive rotation about the segment's y (the tip moves palmar, toward -z);
  abduction is a rotation about z (positive toward +y, the radial / thumb side).

A segment's orientation relative to its parent is REST[s] · Rz(abduction) · Ry(flexion). REST is the
identity for every segment except the thumb metacarpal, whose base frame on the palm points forward-radial,
tilted palmar and rolled about its axis so that thumb flexion (about the thumb's y) sweeps roughly across
the palm, perpendicular to the fingers' flexion plane; thumb CMC abduction (about the thumb's z) lifts it
palmar, away from the palm. So with all angles zero the relative quaternions are the identity except the
thumb metacarpal's, which is REST[1].

Joint angles are a 20-vector in radians, named in JOINTS.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.hand.skeleton import FINGER_SEGMENTS, FINGERS, N_SEGMENTS, PARENTS
from recorder.protocol.layout import JOINTS, N_JOINTS  # noqa: F401  (re-exported: the model's joints)

# Anatomical ranges in degrees (typical active adult ranges; abduction positive toward the thumb side).
_LIMITS_DEG = {
    "thumb_cmc_flex": (-20, 50),
    "thumb_cmc_abd": (0, 70),
    "thumb_mcp": (-10, 60),
    "thumb_ip": (-15, 80),
    "index_mcp_flex": (-20, 90),
    "index_mcp_abd": (-25, 25),
    "index_pip": (0, 110),
    "index_dip": (0, 70),
    "middle_mcp_flex": (-20, 90),
    "middle_mcp_abd": (-20, 20),
    "middle_pip": (0, 110),
    "middle_dip": (0, 70),
    "ring_mcp_flex": (-20, 90),
    "ring_mcp_abd": (-20, 20),
    "ring_pip": (0, 110),
    "ring_dip": (0, 70),
    "pinky_mcp_flex": (-20, 90),
    "pinky_mcp_abd": (-30, 30),
    "pinky_pip": (0, 110),
    "pinky_dip": (0, 70),
}
LIMITS = np.radians([_LIMITS_DEG[j] for j in JOINTS])  # (20, 2) low, high in radians

PIP = tuple(JOINTS.index(f"{f}_pip") for f in FINGERS[1:])
DIP = tuple(JOINTS.index(f"{f}_dip") for f in FINGERS[1:])
DIP_PER_PIP = 65.0 / 115.0  # thesis §3.2.1, table: curled finger 115° between phalanges, 65° distal

# Which joint angle drives each segment's flexion (about y) and abduction (about z); N_JOINTS = none.
_FLEX = np.full(N_SEGMENTS, N_JOINTS)
_ABD = np.full(N_SEGMENTS, N_JOINTS)
_FLEX[list(FINGER_SEGMENTS["thumb"])] = (0, 2, 3)
_ABD[FINGER_SEGMENTS["thumb"][0]] = 1
for _k, _f in enumerate(FINGERS[1:]):
    _FLEX[list(FINGER_SEGMENTS[_f])] = (4 + 4 * _k, 6 + 4 * _k, 7 + 4 * _k)
    _ABD[FINGER_SEGMENTS[_f][0]] = 5 + 4 * _k

_X, _Y, _Z = np.eye(3)


def _levels() -> list[tuple[list[int], list[int]]]:
    """The segments below the palm a depth at a time, each with its parents: the chains, walked level by level."""
    depth = [0] * N_SEGMENTS
    for s in range(1, N_SEGMENTS):  # PARENTS[s] < s
        depth[s] = depth[PARENTS[s]] + 1
    return [([s for s in range(N_SEGMENTS) if depth[s] == d], [PARENTS[s] for s in range(N_SEGMENTS) if depth[s] == d])
            for d in range(1, max(depth) + 1)]  # fmt: skip


_LEVELS = _levels()


def _thumb_rest() -> np.ndarray:
    """Thumb metacarpal rest frame on the palm: yaw 40° radial, tilt 15° palmar, roll 70° (nail radial)."""
    yaw = quat.from_axis_angle(_Z, np.radians(40.0))
    tilt = quat.from_axis_angle(_Y, np.radians(15.0))
    roll = quat.from_axis_angle(_X, np.radians(-70.0))
    return quat.mul(quat.mul(yaw, tilt), roll)


REST = np.tile(quat.IDENTITY, (N_SEGMENTS, 1))
REST[FINGER_SEGMENTS["thumb"][0]] = _thumb_rest()

# Buchholz, Armstrong & Goldstein 1992, segment lengths as fractions of hand length (wrist crease to the
# middle fingertip): (metacarpal, proximal, intermediate, distal); the thumb has no intermediate.
_BUCHHOLZ = {
    "thumb": (0.251, 0.196, None, 0.158),
    "index": (0.374, 0.265, 0.143, 0.097),
    "middle": (0.373, 0.277, 0.170, 0.108),
    "ring": (0.336, 0.259, 0.165, 0.107),
    "pinky": (0.295, 0.206, 0.117, 0.093),
}
# Chain bases on the palm (mm, palm frame) for a 190 mm hand: the thumb CMC, then the four MCP joints.
_BASES_MM = (
    (22.0, 20.0, -12.0),  # thumb CMC
    (68.0, 24.0, 0.0),  # index MCP
    (70.0, 5.0, 0.0),  # middle MCP
    (64.0, -13.0, 0.0),  # ring MCP
    (56.0, -30.0, 0.0),  # pinky MCP
)


REFERENCE_LENGTH_MM = 190.0  # the hand every robot's retargeting is fitted to (HandSize())
REFERENCE_BREADTH_MM = 85.0  # its breadth across the metacarpal heads (adult mean, about 0.45 of the length)


@dataclass(frozen=True)
class HandSize:
    """An adult right hand: hand_length_mm (wrist crease to middle fingertip) and hand_breadth_mm (across the
    metacarpal heads), both times ``scale``.

    Bone lengths follow Buchholz et al. 1992 proportions of the length unless ``segments_mm`` gives a finger's
    own ((finger, (three bone lengths in mm, base to tip; the thumb's metacarpal, proximal, distal)), ...).
    bases_mm are the chain bases of the 190 mm reference hand in the palm frame: along the hand (x) and
    through it (z) they scale with the length, across it (y) with the breadth. Thicknesses place the IMUs on
    the back of the segments. A wearer's HandSize comes from their hand profile (recorder/hand/profile.py)."""

    scale: float = 1.0
    hand_length_mm: float = REFERENCE_LENGTH_MM
    palm_thickness_mm: float = 30.0
    finger_thickness_mm: float = 14.0
    bases_mm: tuple = _BASES_MM  # chain bases for a 190 mm hand, thumb first
    hand_breadth_mm: float = REFERENCE_BREADTH_MM
    segments_mm: tuple = ()  # ((finger, (l1, l2, l3)), ...): measured bone lengths overriding Buchholz

    def lengths(self) -> np.ndarray:
        """Bone length of every segment in metres (16,); the palm's is its wrist-to-MCP length (middle)."""
        hl = self.hand_length_mm * self.scale / 1000.0
        out = np.zeros(N_SEGMENTS)
        out[0] = _BUCHHOLZ["middle"][0] * hl
        for f in FINGERS:
            m, p, i, d = _BUCHHOLZ[f]
            out[list(FINGER_SEGMENTS[f])] = (m, p, d) if f == "thumb" else (p, i, d)
        out[1:] *= hl
        for f, bones in self.segments_mm:
            out[list(FINGER_SEGMENTS[f])] = np.asarray(bones, float) * self.scale / 1000.0
        return out

    def bases(self) -> np.ndarray:
        """Chain base positions (5, 3) in metres, palm frame: thumb CMC, index..pinky MCP."""
        return np.array(self.bases_mm) * self.axes() / 1000.0

    def axes(self) -> np.ndarray:
        """This hand's size along the palm frame's axes (3,) relative to the reference hand: x and z by the
        length, y by the breadth."""
        k = self.scale * self.hand_length_mm / REFERENCE_LENGTH_MM
        return np.array([k, self.scale * self.hand_breadth_mm / REFERENCE_BREADTH_MM, k])


def clip(angles) -> np.ndarray:
    """Clamp joint angles (..., 20) to LIMITS."""
    return np.clip(angles, LIMITS[:, 0], LIMITS[:, 1])


def interpolate_dip(angles) -> np.ndarray:
    """Copy of ``angles`` (..., 20) with each finger's DIP set from its PIP by thesis eq. 3.3:
    DIP = 65/115 · PIP for PIP >= 0, else 0."""
    out = np.array(angles, dtype=float, copy=True)
    out[..., DIP] = DIP_PER_PIP * np.maximum(out[..., PIP], 0.0)
    return out


def relative_from_angles(angles, palm_quat=quat.IDENTITY) -> np.ndarray:
    """Parent-relative quats (..., 16, 4) of the model at joint ``angles`` (..., 20) rad, row 0 the palm's
    orientation ``palm_quat`` (what a pose frame carries, less each phalanx's twist; NaN angles, NaN rows)."""
    a = np.asarray(angles, dtype=float)
    ext = np.concatenate((a, np.zeros(a.shape[:-1] + (1,))), axis=-1)
    flex = ext[..., _FLEX]
    abd = ext[..., _ABD]
    swing = quat.mul(quat.from_axis_angle(_Z, abd), quat.from_axis_angle(_Y, flex))
    rel = quat.mul(REST, swing)
    rel[..., 0, :] = np.broadcast_to(np.asarray(palm_quat, dtype=float), rel.shape[:-2] + (4,))
    return rel


def global_from_relative(rel) -> np.ndarray:
    """Global quats (..., 16, 4) from parent-relative ones (the palm's is relative to the world)."""
    rel = np.asarray(rel, dtype=float)
    g = np.empty_like(rel)
    g[..., 0, :] = rel[..., 0, :]
    for segs, parents in _LEVELS:  # each level's parents are done first (a level at a time: numpy calls per block)
        g[..., segs, :] = quat.mul(g[..., parents, :], rel[..., segs, :])
    return g


def relative_quats(global_quats) -> np.ndarray:
    """Parent-relative quats (..., 16, 4): conj(parent) · segment; the palm's is its global quat."""
    g = np.asarray(global_quats, dtype=float)
    parent = g[..., [max(p, 0) for p in PARENTS], :].copy()
    parent[..., 0, :] = quat.IDENTITY
    return quat.mul(quat.conj(parent), g)


def forward(angles, palm_quat, size: HandSize = HandSize()):
    """Forward kinematics.

    angles (..., 20) radians, palm_quat (..., 4) palm orientation in the world.
    Returns global_quats (..., 16, 4); positions (..., 16, 3) of each segment's base (its proximal joint;
    the palm's is the wrist) in metres, relative to the palm origin but expressed in world axes; and
    tips (..., 5, 3) fingertip positions, same frame, thumb first.
    """
    rel = relative_from_angles(angles, palm_quat)
    g = global_from_relative(rel)
    lengths = size.lengths()
    bases = size.bases()
    pos = np.zeros(rel.shape[:-1] + (3,))
    offsets = np.zeros((N_SEGMENTS, 3))  # each segment's base in its parent's frame
    for s in range(1, N_SEGMENTS):
        offsets[s] = bases[(s - 1) // 3] if PARENTS[s] == 0 else (lengths[PARENTS[s]], 0.0, 0.0)
    for segs, parents in _LEVELS:
        pos[..., segs, :] = pos[..., parents, :] + quat.rotate(g[..., parents, :], offsets[segs])
    distal = [FINGER_SEGMENTS[f][-1] for f in FINGERS]
    tips = pos[..., distal, :] + quat.rotate(g[..., distal, :], np.outer(lengths[distal], _X))
    return g, pos, tips


def _left_product(p) -> np.ndarray:
    """The matrices (..., 4, 4) that multiply by ``p`` from the left: quat.mul(p, q) == _left_product(p) @ q."""
    w, x, y, z = np.moveaxis(np.asarray(p, float), -1, 0)
    return np.stack([np.stack(row, -1) for row in ((w, -x, -y, -z), (x, w, -z, y), (y, z, w, -x), (z, -y, x, w))], -2)


# joint_angles_from_relative runs on every glove frame (200 Hz and more when recording faster than real time): its
# constants are computed once, REST comes off in one batched matrix product, and the four terms of the two angles
# are quadratic forms of each segment's quaternion, taken in one product (a few numpy calls instead of dozens)
_UNREST = _left_product(quat.conj(REST))[1:]  # segments 1..15 (the palm has no joint)
_FLEX_OF = _FLEX[1:]  # the flexion joint of segments 1..15 (each has one)
_ABD_SEGS = np.flatnonzero(_ABD[1:] < N_JOINTS)  # which of segments 1..15 carry an abduction, and its joint
_ABD_OF = _ABD[1:][_ABD_SEGS]


def _angle_terms() -> np.ndarray:
    """(16, 4): the outer product r r^T (flattened) of a quaternion r = (w, x, y, z) times this gives the terms
    -2(xz - wy), -2(x^2 + y^2), -2(xy - wz), -2(x^2 + z^2) of R = Rz(abd) Ry(flex): R[2,0] = -sin flex,
    R[2,2] = cos flex, R[0,1] = -sin abd, R[1,1] = cos abd (with 1 added to the second and the fourth)."""
    w, x, y, z = range(4)
    c = np.zeros((4, 4, 4))
    c[0, x, z] = c[0, z, x] = -1.0
    c[0, w, y] = c[0, y, w] = 1.0
    c[1, x, x] = c[1, y, y] = -2.0
    c[2, x, y] = c[2, y, x] = -1.0
    c[2, w, z] = c[2, z, w] = 1.0
    c[3, x, x] = c[3, z, z] = -2.0
    return c.reshape(4, 16).T.copy()


_TERMS = _angle_terms()
_TERMS_ONE = np.array([0.0, 1.0, 0.0, 1.0])


def joint_angles_from_relative(rel_quats) -> np.ndarray:
    """The 20 joint angles (radians) from parent-relative quats (..., 16, 4), inverse of ``forward``.

    Each segment's rotation after removing REST is decomposed as Rz(abd) · Ry(flex); for hinge joints only
    the flexion is kept (a projection when the input is not a pure hinge rotation).
    """
    q = np.asarray(rel_quats, dtype=float)[..., 1:, :, None]
    r = _UNREST @ q  # REST removed: conj(REST) * q, segments 1..15, as columns
    f = (r * np.swapaxes(r, -1, -2)).reshape(r.shape[:-2] + (16,)) @ _TERMS + _TERMS_ONE
    out = np.zeros(q.shape[:-3] + (N_JOINTS,))
    out[..., _FLEX_OF] = np.arctan2(f[..., 0], f[..., 1])
    out[..., _ABD_OF] = np.arctan2(f[..., _ABD_SEGS, 2], f[..., _ABD_SEGS, 3])
    return out


def dorsal_mounts(size: HandSize = HandSize()) -> np.ndarray:
    """Where an IMU sits on each segment (16, 3), metres in the segment frame: mid-bone, on the back."""
    lengths = size.lengths()
    mounts = np.zeros((N_SEGMENTS, 3))
    mounts[:, 0] = 0.5 * lengths
    mounts[:, 2] = 0.5e-3 * size.finger_thickness_mm * size.scale
    mounts[0, 2] = 0.5e-3 * size.palm_thickness_mm * size.scale
    return mounts
