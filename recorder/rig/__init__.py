"""The rig: a recording session's parts, built once, in one place, from one config (STYLE.md, "For gloverec").

``SessionConfig`` (recorder/rig/config.py) holds the settings every session shares (the glove, the robot, the task,
retargeting, the wearer, the wrist); `gloverec record` and `gloverec view` extend it. ``Rig`` (recorder/rig/rig.py)
builds from it the task environment, the wearer's hand profile and the retargeter, the scripted demonstrator, then
the glove (worn by the performer when the emulated wearer performs the demonstrations) and the tracked wrist, and
zeroes the wrist as an episode starts. record, rerecord, view, the rollout (recorder/rig/rollout.py) and the
LeRobot teleoperator use it. This package imports nothing heavy: ``from recorder.rig.rig import Rig``.
"""
