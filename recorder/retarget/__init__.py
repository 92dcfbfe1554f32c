"""Retargeting: the fused human hand (20 joint angles + palm orientation) -> robot hand actions.

``Retargeter(robot, mode)`` drives a robot of envs.robots with its yaml's ``retarget`` section (checked when the
robot loads, recorder.config errors: one line). Modes: ``joint`` (the robot's linear joint map), ``ik``
(fingertip positions by mink inverse kinematics, warm-started) and ``pinch`` (fingertips, thumb-finger vectors,
pinches that close, fingers that never overlap: pinch.py). ``hand_size``: the wearer's hand (their profile).
Every call reports the per-finger retargeting error.
"""

from recorder.retarget.retargeter import MODES, Retargeter

__all__ = ["MODES", "Retargeter"]
