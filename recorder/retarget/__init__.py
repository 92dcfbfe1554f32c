"""Retargeting: the fused human hand (20 joint angles + palm orientation) -> robot hand actions.

``Retargeter(robot, mode)`` drives a robot of envs.robots with its yaml's ``retarget`` section (checked when the
robot loads, recorder.config errors: one line). Modes: ``joint`` (the robot's linear joint map) and ``ik``
(fingertip positions by mink inverse kinematics, warm-started). Every call reports the per-finger retargeting
error.
"""

from recorder.retarget.retargeter import MODES, Retargeter

__all__ = ["MODES", "Retargeter"]
