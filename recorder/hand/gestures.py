"""Named hand gestures as joint angles (radians, recorder.hand.kinematics.JOINTS): what the emulated wearer
moves between, what HandPose asks for, and what the scripted demonstrator shows."""

from __future__ import annotations

import numpy as np

from recorder.hand.kinematics import JOINTS, N_JOINTS, interpolate_dip


def _pose(**deg) -> np.ndarray:
    """A 20-vector in radians from {joint: degrees}, others 0, DIPs from PIPs (eq. 3.3)."""
    a = np.zeros(N_JOINTS)
    for name, value in deg.items():
        a[JOINTS.index(name)] = np.radians(value)
    return interpolate_dip(a)


def _fingers(**per_finger) -> dict:
    """{finger: (mcp_flex, mcp_abd, pip)} in degrees -> joint keyword arguments for _pose."""
    out = {}
    for f, (flex, abd, pip) in per_finger.items():
        out.update({f"{f}_mcp_flex": flex, f"{f}_mcp_abd": abd, f"{f}_pip": pip})
    return out


_CURLED = (85, 0, 105)
GESTURES = {
    "open": _pose(
        thumb_cmc_flex=-10,
        thumb_cmc_abd=10,
        **_fingers(index=(0, 8, 0), middle=(0, 0, 0), ring=(0, -6, 0), pinky=(0, -12, 0)),
    ),
    "fist": _pose(
        thumb_cmc_flex=40,
        thumb_cmc_abd=35,
        thumb_mcp=45,
        thumb_ip=40,
        **_fingers(index=(85, 0, 100), middle=(88, 0, 102), ring=(88, 0, 102), pinky=(85, 0, 100)),
    ),
    # thumb tip on the index tip (forward kinematics puts them about 1 mm apart)
    "pinch": _pose(
        thumb_cmc_flex=10,
        thumb_cmc_abd=20,
        thumb_mcp=25,
        thumb_ip=50,
        **_fingers(index=(40, 0, 50), middle=(20, 0, 30), ring=(25, 0, 35), pinky=(30, 0, 40)),
    ),
    "point": _pose(
        thumb_cmc_flex=35,
        thumb_cmc_abd=30,
        thumb_mcp=40,
        thumb_ip=30,
        **_fingers(index=(0, 0, 5), middle=_CURLED, ring=_CURLED, pinky=_CURLED),
    ),
    # thesis fig. 5.10: index and middle extended, ring and pinky fully curled, thumb to the side
    "two_fingers": _pose(
        thumb_cmc_flex=-10,
        thumb_cmc_abd=15,
        **_fingers(index=(0, 6, 0), middle=(0, -4, 0), ring=(90, 0, 110), pinky=(90, 0, 110)),
    ),
    # thesis fig. 5.16: index and pinky extended, middle and ring curled, thumb extended
    "spiderman": _pose(
        thumb_cmc_flex=-15,
        thumb_cmc_abd=10,
        thumb_mcp=-5,
        thumb_ip=-10,
        **_fingers(index=(0, 5, 0), middle=_CURLED, ring=_CURLED, pinky=(0, -10, 0)),
    ),
}
