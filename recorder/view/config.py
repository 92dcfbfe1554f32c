"""ViewConfig: what `gloverec view` shows. Its flags are generated from these fields (recorder/config.py), named
as `gloverec record` names the same settings (RecordConfig: --glove, --robot, --task, --retarget, --wearer, --view,
--wrist, --wrist-camera, --marker-mm, --glove-rate, --glove-output)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

from pydantic import AfterValidator

from recorder.config import STRICT, Positive, setting
from recorder.glove.config import SPECS, GloveConfig
from recorder.view.process import ViewSpec
from recorder.wrist.config import SPECS as WRIST_SPECS, WristConfig


def checked_view(text: str) -> str:
    """A view spec, checked (RecordConfig's too): ConfigError (a ValueError) names what is valid."""
    ViewSpec.parse(text)
    return text


def checked_wrist(text: str) -> str:
    """A wrist source, checked (RecordConfig's too): ConfigError names what is valid."""
    WristConfig.parse(text)
    return text


@dataclass
class ViewConfig:
    __pydantic_config__ = STRICT

    glove: GloveConfig = setting(
        default_factory=GloveConfig,
        help=SPECS,
        metavar="GLOVE",
        flags={"rate_hz": "--glove-rate", "mode": "--glove-output"},
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
    view: Annotated[str, AfterValidator(checked_view)] | None = setting(
        None,
        "native (MuJoCo's viewer), web[:PORT] (a page on 127.0.0.1), rerun[:MODE], none (default: native with a "
        "display; none with --video)",
        metavar="VIEW",
        check=ViewSpec.parse,
    )
    wrist: Annotated[str, AfterValidator(checked_wrist)] = setting(
        "scripted",
        f"where the wrist is: {WRIST_SPECS}; a tracker moves the hand's base, and a free-wrist task (relocate) needs "
        "one (scripted: the task's)",
        metavar="SOURCE",
        check=WristConfig.parse,
    )
    wrist_camera: str | None = setting(
        None, "the marker camera's calibration (default: the one `gloverec calibrate --camera` saved)", metavar="FILE"
    )
    marker_mm: Annotated[float, Positive] = setting(40.0, "the marker's printed side, mm", metavar="MM")
    video: str | None = setting(None, "also render to this video (with no --view: instead of one)", metavar="FILE.mp4")
    duration: Annotated[float, Positive] | None = setting(
        None, "seconds (default: until Ctrl-C; 10 s for a video from the emulator)", metavar="S"
    )
