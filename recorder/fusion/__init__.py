"""Sensor fusion: the glove's 12 IMUs -> segment orientations -> joint angles (docs/fusion.md).

Filters (one file each, a settings dataclass + a class with reset / observe / update over all IMUs at once):
complementary (the thesis' filter, shared with the firmware), mahony (Santaera et al. Alg. 1), relative (Alg. 2),
madgwick; ``make_filter(name, **settings)``. ``filter_block`` filters a whole recording in one call. Their maths
is one implementation, the numba kernels of kernels.py, for the live and the block path alike.
``HostFusion`` turns raw glove frames into 16 parent-relative quaternions, 20 joint angles and quality.
"""

from recorder.fusion.block import filter_block
from recorder.fusion.config import FusionConfig
from recorder.fusion.host import Fused, FusedFrame, HostFusion
from recorder.fusion.registry import FILTERS, make_filter, settings_for

__all__ = [
    "FILTERS",
    "Fused",
    "FusedFrame",
    "FusionConfig",
    "HostFusion",
    "filter_block",
    "make_filter",
    "settings_for",
]
