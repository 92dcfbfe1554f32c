"""What the wire protocol's arrays mean, index by index (docs/protocol.md): the 16 hand segments of a pose frame,
the 12 IMUs of a raw frame and the segment each one is strapped to, and the 20 joint angles of a pose_compact
frame. The hand model (recorder/hand) is built on the same order."""

from __future__ import annotations

FINGERS = ("thumb", "index", "middle", "ring", "pinky")

# Sixteen segments: the palm, then for the thumb its metacarpal, proximal and distal phalanges, and for each
# finger its proximal, intermediate and distal phalanges (thesis §3.1, table 4.1).
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

# Table 4.1 of the thesis: the 12 IMUs, their multiplexer channel and the segment each one is strapped to.
# The four distal phalanges of the fingers (6, 9, 12, 15) carry no IMU; they are interpolated (eq. 3.3).
MUX_MAP = (0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5)
JOINT_MAP = (0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14)
N_IMUS = len(JOINT_MAP)
MEASURED_MASK = sum(1 << s for s in JOINT_MAP)

# The joint angles, in radians: the thumb's CMC (flexion, abduction), MCP and IP, then per finger its MCP
# (flexion, abduction), PIP and DIP.
JOINTS = (
    "thumb_cmc_flex",
    "thumb_cmc_abd",
    "thumb_mcp",
    "thumb_ip",
    *(f"{f}_{j}" for f in FINGERS[1:] for j in ("mcp_flex", "mcp_abd", "pip", "dip")),
)
N_JOINTS = len(JOINTS)
