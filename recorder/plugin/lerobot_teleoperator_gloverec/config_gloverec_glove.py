"""GloverecGloveConfig: `--teleop.type=gloverec_glove` and its fields on LeRobot's command line."""

from __future__ import annotations

from dataclasses import dataclass

from lerobot.teleoperators.config import TeleoperatorConfig


@TeleoperatorConfig.register_subclass("gloverec_glove")
@dataclass
class GloverecGloveConfig(TeleoperatorConfig):
    """``port``: the glove as gloverec takes it (a serial device or serial:PORT, udp:PORT, udp:HOST:PORT,
    mcap:FILE, or emulator). ``robot``: what it drives: a gloverec robot hand (configs/robots: glovehand, shadow,
    ... for gloverec_sim) or a motor map of a real hand (configs/retarget: hope_jr_hand). ``retarget``: joint or
    ik (robot hands). ``glove_id``: the calibration to fuse raw frames with, in hex (default: the glove's own id,
    from its status frames); ``calibration_dir``: where gloverec keeps calibrations (default
    $GLOVEREC_CALIBRATION_DIR, else datasets/calibration). ``emulator_mode``, ``emulator_motion``: the emulated
    glove's output (pose, raw, compact, json) and its wearer (gestures, random). ``first_pose_s``: how long
    ``connect`` waits for the glove's first hand pose. ``wearer``: whose hand, the hand profile saved by
    `gloverec calibrate --wearer NAME` in ``calibration_dir`` (default: the 190 mm reference hand), as `gloverec
    record --wearer` takes it: retargeting onto a robot hand scales the wearer's fingertips by it."""

    port: str = "emulator"
    robot: str = "glovehand"
    retarget: str = "joint"
    wearer: str | None = None
    glove_id: str | None = None
    emulator_mode: str = "pose"
    emulator_motion: str = "gestures"
    first_pose_s: float = 5.0
