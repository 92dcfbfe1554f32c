"""Segment indexing of the thesis hand model (§3.1, table 4.1).

Sixteen segments: the palm, then for the thumb its metacarpal, proximal and distal phalanges, and for each
finger its proximal, intermediate and distal phalanges. Every segment's parent is the one before it in its
chain; the palm's parent is the world (the glove's reference frame).
"""

from __future__ import annotations

FINGERS = ("thumb", "index", "middle", "ring", "pinky")

SEGMENTS = (
    "palm",
    "thumb_metacarpal",
    "thumb_proximal",
    "thumb_distal",
    "index_proximal",
    "index_intermediate",
    "index_distal",
    "middle_proximal",
    "middle_intermediate",
    "middle_distal",
    "ring_proximal",
    "ring_intermediate",
    "ring_distal",
    "pinky_proximal",
    "pinky_intermediate",
    "pinky_distal",
)
N_SEGMENTS = len(SEGMENTS)

# parent segment index, -1 for the palm (world)
PARENTS = (-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14)

# segment indices per finger, base to tip
FINGER_SEGMENTS = {name: (1 + 3 * i, 2 + 3 * i, 3 + 3 * i) for i, name in enumerate(FINGERS)}

# Table 4.1 of the thesis: the 12 IMUs, their multiplexer channel and the segment each one is strapped to.
# The four distal phalanges of the fingers (6, 9, 12, 15) carry no IMU; they are interpolated (eq. 3.3).
MUX_MAP = (0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5)
JOINT_MAP = (0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14)
N_IMUS = len(JOINT_MAP)
INTERPOLATED = tuple(i for i in range(N_SEGMENTS) if i not in JOINT_MAP)
MEASURED_MASK = sum(1 << s for s in JOINT_MAP)
