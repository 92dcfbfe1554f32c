"""`gloverec view`: its flags; the view itself is recorder/view/live.py (loaded only when the command runs)."""

from __future__ import annotations

from recorder.argtypes import positive_float
from recorder.glove.config import SPECS
from recorder.view.process import view_arg
from recorder.wrist.config import SPECS as WRIST_SPECS


def add_parser(subparsers):
    v = subparsers.add_parser("view", help="a MuJoCo robot hand follows the glove live")
    v.add_argument("--glove", required=True, help=SPECS)
    v.add_argument("--robot", default="glovehand", help="a robot of configs/robots/ (default: glovehand)")
    v.add_argument("--task", default="pose", help="a registered task: pose, grasp, ... (default: pose)")
    v.add_argument("--mode", default="joint", choices=("joint", "ik", "pinch"), help="retargeting mode")
    v.add_argument(
        "--wearer",
        metavar="NAME",
        help="whose hand: the profile saved by `gloverec calibrate --wearer NAME` (default: a 190 mm hand)",
    )
    v.add_argument(
        "--view",
        type=view_arg,
        help="native (MuJoCo's viewer), web[:PORT] (a page on 127.0.0.1), rerun[:MODE], none "
        "(default: native with a display; none with --video)",
    )
    v.add_argument(
        "--wrist",
        default="scripted",
        metavar="SOURCE",
        help=f"where the wrist is: {WRIST_SPECS}; a tracker moves the hand's base, and a free-wrist task (relocate) "
        "needs one (default: scripted, the task's)",
    )
    v.add_argument(
        "--wrist-camera",
        metavar="FILE.json",
        help="the marker camera's calibration (default: the one `gloverec calibrate --camera` saved)",
    )
    v.add_argument("--marker-mm", type=positive_float, default=40.0, help="the marker's printed side, mm (default: 40)")
    v.add_argument("--video", metavar="FILE.mp4", help="also render to this video (with no --view: instead of one)")
    v.add_argument(
        "--duration", type=positive_float, help="seconds (default: until Ctrl-C; 10 s for a video from the emulator)"
    )
    v.add_argument("--camera", default="front", help="camera for the video (front, top, side)")
    v.set_defaults(func=run)
    return v


def run(args) -> int:
    from recorder.view import live  # mujoco, the glove and retargeting: only when the command runs

    return live.run(args)
