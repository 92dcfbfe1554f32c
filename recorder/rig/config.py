"""SessionConfig: the settings every session shares (the glove, the robot, the task, retargeting, the wearer, the
wrist), once. `gloverec record` (RecordConfig, recorder/record/config.py) and `gloverec view` (ViewConfig,
recorder/view/config.py) extend it, so their flags, generated from the fields (recorder/config.py), carry the same
names and help; the rig (recorder/rig/rig.py) builds a session from it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

from pydantic import AfterValidator

from recorder.config import STRICT, ConfigError, Positive, setting
from recorder.glove.config import SPECS, GloveConfig
from recorder.wrist.config import SCRIPTED, WristConfig


def checked_wrist(text: str) -> str:
    """A wrist source, checked: ConfigError (a ValueError) names what is valid."""
    WristConfig.parse(text)
    return text


@dataclass
class SessionConfig:
    __pydantic_config__ = STRICT

    glove: GloveConfig = setting(
        default_factory=GloveConfig,
        help=SPECS,
        metavar="GLOVE",
        flags={"rate_hz": "--glove-rate", "mode": ("--glove-output", "--glove-mode")},
    )
    robot: str = setting("glovehand", "a robot of configs/robots/ (glovehand, shadow, leap)")
    task: str = setting("pose", "a registered task: pose, grasp, ... (an unknown name lists them; docs/envs.md)")
    retarget: Literal["joint", "ik", "pinch"] = setting(
        "joint",
        "retargeting mode: joint map, fingertip IK, or pinch-preserving (fingertips, pinches, no overlap)",
        aliases=("--mode",),
    )
    wearer: str | None = setting(
        None,
        "whose hand: the hand profile saved by `gloverec calibrate --wearer NAME` (default: a 190 mm hand)",
        metavar="NAME",
    )
    wrist: Annotated[str, AfterValidator(checked_wrist)] = setting(
        "scripted",
        "where the wrist is: scripted (the task's script; a free-wrist task's demonstrator), udp:PORT (a tracker's "
        "pose stream), marker:CAMERA (a marker on the glove seen by a camera: index, video file or URL; "
        "marker:emulated renders the emulated wearer's), mcap:FILE (a session log's), or a plugin's KIND:ADDRESS; "
        "a tracker moves the hand's base (the base position is in the action), and a free-wrist task (relocate) "
        "needs one",
        metavar="SOURCE",
        check=WristConfig.parse,
    )
    wrist_camera: str | None = setting(
        None, "the marker camera's calibration (default: the one `gloverec calibrate --camera` saved)", metavar="FILE"
    )
    wrist_mount: str | None = setting(
        None,
        "where the tracked marker sits on the glove (default: the marker_mount.json `gloverec calibrate --wrist` "
        "saved, else flat on the back of the hand; a session log's own for mcap:FILE)",
        metavar="FILE",
    )
    marker_mm: Annotated[float, Positive] = setting(40.0, "the marker's printed side, mm", metavar="MM")

    def check_wrist_files(self) -> None:
        """The wrist's files, before anything opens: a camera calibration only for a source that films with a
        calibrated camera (marker:CAMERA), checked; a mounting file checked. One line for what is wrong."""
        if self.wrist_camera is not None:
            if self.wrist_config.kind != "marker":
                raise ConfigError(f"--wrist-camera is a marker camera's calibration (marker:CAMERA); {self.wrist} "
                                  "uses none (marker:emulated films with the simulator's own camera)")  # fmt: skip
            from recorder.wrist.marker import CameraModel  # numpy only

            CameraModel.load(self.wrist_camera)
        if self.wrist_mount is not None:
            from recorder.wrist.mounting import MarkerMount

            MarkerMount.load(self.wrist_mount)

    @property
    def glove_config(self) -> GloveConfig:
        """The glove the session opens (RecordConfig seeds its emulated wearer with the session's seed)."""
        return GloveConfig.parse(self.glove)

    @property
    def wrist_config(self) -> WristConfig:
        return WristConfig.parse(self.wrist)

    @property
    def tracked(self) -> bool:
        """A tracker moves the hand's base (not the task's script)."""
        return self.wrist_config.kind != SCRIPTED

    def tracked_options(self) -> dict:
        """The task settings a tracked wrist needs: the wearer places the base."""
        return {"base_position": True} if self.tracked else {}
