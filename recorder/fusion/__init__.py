"""Sensor fusion: the glove's 12 IMUs -> segment orientations -> joint angles (docs/fusion.md).

Filters (one module each: a settings dataclass, a class with reset / observe / update over all IMUs at once, its
numba step kernel, registered by name in recorder/fusion/registry.py): inertial (the glove's filter), complementary
(the thesis' filter, shared with the firmware), mahony (Santaera et al. Alg. 1), relative (Alg. 2), madgwick; more
from plugins (docs/fusion.md, "Adding a filter"). ``make_filter(name, **settings)``; ``filter_names()``.
``filter_block`` filters a whole recording in one call. Each filter's maths is one implementation, its step
kernel, for the live and the block path alike. ``HostFusion`` turns raw glove frames into 16 parent-relative
quaternions, 20 joint angles and quality.
"""

# the built-in filters, registered as they load (the registry's order: the default first)
from recorder.fusion import inertial, complementary, mahony, relative, madgwick  # noqa: F401, I001
from recorder.fusion.block import filter_block
from recorder.fusion.config import FusionConfig
from recorder.fusion.host import Fused, FusedFrame, HostFusion
from recorder.fusion.registry import filter_names, get_filter, make_filter, register_filter, settings_for

__all__ = [
    "Fused",
    "FusedFrame",
    "FusionConfig",
    "HostFusion",
    "filter_block",
    "filter_names",
    "get_filter",
    "make_filter",
    "register_filter",
    "settings_for",
]
