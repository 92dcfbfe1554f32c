"""Retargeting: the fused human hand (20 joint angles + palm orientation) -> robot hand actions.

``Retargeter(robot, mode)`` reads ``configs/robots/<robot>.yaml`` (section ``retarget``), validated on load
(``RetargetConfigError``, one line). Modes: ``joint`` (linear joint map) and ``ik`` (fingertip positions by
mink inverse kinematics, warm-started). Every call reports the per-finger retargeting error.
"""

from recorder.retarget.config import (
    Coupling,
    IKConfig,
    RetargetConfig,
    RetargetConfigError,
    load_retarget_config,
    tendon_couplings,
)
from recorder.retarget.retargeter import MODES, Retargeter

__all__ = [
    "MODES",
    "Coupling",
    "IKConfig",
    "RetargetConfig",
    "RetargetConfigError",
    "Retargeter",
    "load_retarget_config",
    "tendon_couplings",
]
