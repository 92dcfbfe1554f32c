"""Segment indexing of the thesis hand model (§3.1, table 4.1).

Sixteen segments: the palm, then for the thumb its metacarpal, proximal and distal phalanges, and for each
finger its proximal, intermediate and distal phalanges. Every segment's parent is the one before it in its
chain; the palm's parent is the world (the glove's reference frame).
"""

from __future__ import annotations

from recorder.protocol.layout import (  # noqa: F401  (the wire order is the model's: re-exported here)
    FINGERS,
    JOINT_MAP,
    MEASURED_MASK,
    MUX_MAP,
    N_IMUS,
    N_SEGMENTS,
    SEGMENTS,
)

# parent segment index, -1 for the palm (world)
PARENTS = (-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14)

# segment indices per finger, base to tip
FINGER_SEGMENTS = {name: (1 + 3 * i, 2 + 3 * i, 3 + 3 * i) for i, name in enumerate(FINGERS)}
INTERPOLATED = tuple(i for i in range(N_SEGMENTS) if i not in JOINT_MAP)
