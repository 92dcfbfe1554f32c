"""GloverecGloveConfig: `--teleop.type=gloverec_glove` and its fields on LeRobot's command line."""

from __future__ import annotations

import sys
from dataclasses import dataclass

from lerobot.teleoperators.config import TeleoperatorConfig


@TeleoperatorConfig.register_subclass("gloverec_glove")
@dataclass
class GloverecGloveConfig(TeleoperatorConfig):
    """``port``: the glove as gloverec takes it (a serial device or serial:PORT, udp:PORT, udp:HOST:PORT,
    mcap:FILE, or emulator): `gloverec`'s --glove, named ``port`` as every LeRobot teleoperator names its device
    (docs/decisions.md, "One idea, one flag name"). ``robot``: what it drives: a gloverec robot hand
    (configs/robots: glovehand, shadow, ... for gloverec_sim) or a motor map of a real hand (configs/retarget:
    hope_jr_hand). ``retarget``: joint or ik (robot hands). ``glove_id``: the calibration to fuse raw frames with,
    in hex (default: the glove's own id, from its status frames); ``calibration_dir``: where gloverec keeps
    calibrations (default $GLOVEREC_CALIBRATION_DIR, else datasets/calibration). ``emulator_output``,
    ``emulator_motion``: the emulated glove's output (pose, raw, compact, json: `gloverec emulate --output`) and its
    wearer (gestures, random); ``emulator_mode`` is ``emulator_output``'s old name, still taken for a release.
    ``first_pose_s``: how long ``connect`` waits for the glove's first hand pose. ``wearer``: whose hand, the hand
    profile saved by `gloverec calibrate --wearer NAME` in ``calibration_dir`` (default: the 190 mm reference
    hand), as `gloverec record --wearer` takes it: retargeting onto a robot hand scales the wearer's fingertips by
    it."""

    port: str = "emulator"
    robot: str = "glovehand"
    retarget: str = "joint"
    wearer: str | None = None
    glove_id: str | None = None
    emulator_output: str = "pose"
    emulator_motion: str = "gestures"
    first_pose_s: float = 5.0
    emulator_mode: str | None = None  # emulator_output's old name

    def __post_init__(self):
        if self.emulator_mode is not None:
            print("gloverec_glove: note: emulator_mode is now emulator_output; emulator_mode goes in a later "
                  "release", file=sys.stderr)  # fmt: skip
            self.emulator_output, self.emulator_mode = self.emulator_mode, None
