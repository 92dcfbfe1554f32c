"""`gloverec calibrate`: its flags; the procedure is recorder/calibrate/procedure.py (loaded when it runs). With
``--wearer NAME`` it also saves that wearer's hand profile (recorder/hand/profile.py) beside the calibrations:
measured (``--hand-length``, ``--hand-breadth``), with the finger proportions the pinch step estimates
(``--pinch``); measurements alone need no glove. ``--camera CAMERA`` calibrates a camera instead
(recorder/wrist/calibration.py), and ``--wrist SOURCE`` finds where the tracked marker sits on the glove
(recorder/calibrate/mount.py)."""

from __future__ import annotations

import argparse
import json

from recorder import GloverecError
from recorder.argtypes import positive_float, positive_int
from recorder.calibrate.board import BOARD_FLAGS, add_board_arguments, board_from
from recorder.paths import CALIBRATION_ENV
from recorder.view.process import view_arg


def add_parser(sub) -> None:
    c = sub.add_parser(
        "calibrate", help="walk through the calibration steps and save the glove's calibration (and a hand profile)"
    )
    c.add_argument(
        "--glove",
        help="emulator (the emulated wearer runs the steps), serial:PORT, "
        "a device path, udp:PORT or mcap:FILE (a log of the steps); not needed to save measurements alone",
    )
    c.add_argument("--wearer", metavar="NAME", help="save this wearer's hand profile (record and view --wearer NAME)")
    c.add_argument(
        "--hand-length",
        type=positive_float,
        metavar="MM",
        help="the wearer's hand length, wrist crease to the tip of the middle finger (default: kept, else 190)",
    )
    c.add_argument(
        "--hand-breadth",
        type=positive_float,
        metavar="MM",
        help="the wearer's hand breadth across the knuckles, thumb excluded (default: kept, else in proportion)",
    )
    c.add_argument(
        "--pinch",
        action="store_true",
        help="add step 5, the thumb tip on each fingertip: estimates the wearer's finger proportions (--wearer)",
    )
    c.add_argument("--glove-id", type=_glove_id, help="hex id to save under (default: the glove's status frame)")
    c.add_argument("--dir", help=f"where calibrations live (default: ${CALIBRATION_ENV}, else datasets/calibration)")
    c.add_argument("--config", help="a fusion config YAML (default: the FusionConfig defaults)")
    c.add_argument(
        "--yes",
        action="store_true",
        help="do not wait for Enter: each step follows the last "
        "(the default when stdin is not a terminal, and for the emulator)",
    )
    c.add_argument(
        "--attempts",
        type=positive_int,
        default=3,
        help="recordings of step 1 before giving up when the hand moves (default 3)",
    )
    c.add_argument(
        "--realtime", action="store_true", help="pace the emulator in real time (default: as fast as it is read)"
    )
    c.add_argument(
        "--view",
        type=view_arg,
        help="a live view of each step on the human hand: native, web[:PORT], rerun[:MODE], "
        "none (default: native with a display and a terminal, else none)",
    )
    c.add_argument(
        "--camera",
        metavar="CAMERA",
        help="calibrate a camera instead, from views of a ChArUco board (recorder/wrist/calibration.py): a device "
        "index, a video file or a stream URL; saved as camera_<name>.json in --dir (docs/wrist.md)",
    )
    c.add_argument("--views", type=positive_int, default=30, help="board views to take from --camera (default 30)")
    add_board_arguments(c, marker=False)  # the board's markers: --marker-mm below
    c.add_argument(
        "--wrist",
        metavar="SOURCE",
        help="find where the tracked marker sits on the glove instead (recorder/calibrate/mount.py): the wrist "
        "source, marker:CAMERA, udp:PORT or mcap:FILE (marker:emulated[:RX,RY,RZ] with --glove emulator), paired "
        "with --glove's palm while the wearer tilts and turns the hand; saved as marker_mount.json in --dir, which "
        "gloverec record --wrist uses (docs/wrist.md)",
    )
    c.add_argument(
        "--duration", type=positive_float, default=15.0, help="seconds of tilting and turning, for --wrist (default 15)"
    )
    c.add_argument(
        "--wrist-camera",
        metavar="FILE.json",
        help="the marker camera's calibration, for --wrist marker:CAMERA (default: the one --camera CAMERA saved)",
    )
    c.add_argument("--marker-mm", type=positive_float, metavar="MM", help="the marker's side, mm: the tracked marker's "
                   "for --wrist (default 40), the board's markers' for --camera (default 22)")  # fmt: skip
    c.add_argument("--json", action="store_true", help="print a JSON summary instead of the table")
    c.set_defaults(func=cmd_calibrate)


def _glove_id(text: str) -> int:
    try:
        value = int(text, 16)
    except ValueError:
        value = -1
    if not 0 < value < 1 << 32:
        raise argparse.ArgumentTypeError(f"expected a glove id in hex (1 to ffffffff), got {text!r}")
    return value


def cmd_calibrate(args) -> int:
    if args.wrist is not None:
        return _calibrate_mount(args)
    if args.camera is not None:
        return _calibrate_camera(args)
    given = [f"--{k.replace('_', '-')}" for k in BOARD_FLAGS if getattr(args, k) is not None]
    if given:
        verb = "describes" if len(given) == 1 else "describe"
        raise GloverecError(f"{' and '.join(given)} {verb} the board of --camera CAMERA: add --camera")
    from recorder.hand.profile import (  # the procedure's modules: not at start-up
        measured_profile,
        save_profile,
        segments_from,
    )

    measured = args.hand_length is not None or args.hand_breadth is not None
    if args.glove is None and not (args.wearer and measured):
        raise GloverecError(
            "calibrate needs --glove (the glove's calibration), or --wearer NAME with --hand-length MM "
            "(and --hand-breadth MM) to save a hand profile alone"
        )
    if (args.pinch or measured) and not args.wearer:
        raise GloverecError("--pinch, --hand-length and --hand-breadth describe a wearer's hand: add --wearer NAME")
    if args.pinch and args.glove is None:
        raise GloverecError("--pinch is a step of the glove's calibration: add --glove")
    profile = measured_profile(args.wearer, args.hand_length, args.hand_breadth, args.dir) if args.wearer else None
    out = {}
    if args.glove is not None:
        from recorder.calibrate.procedure import Calibrator, report, summary  # fusion, the glove: when it runs

        result = Calibrator(
            args.glove,
            glove_id=args.glove_id,
            folder=args.dir,
            config=args.config,
            interactive=False if args.yes else None,
            attempts=args.attempts,
            realtime=args.realtime,
            view=args.view,
            pinch=args.pinch,
            **({"hand_size": profile.size()} if profile is not None else {}),
        ).run()
        if result.proportions is not None:
            profile = segments_from(profile, result.proportions)
        out = summary(result)
        text = report(result)
    if profile is not None:
        path = save_profile(profile, args.dir)
        out["hand_profile"] = {**profile.as_dict(), "path": str(path)}
        line = (
            f"hand profile of {profile.wearer} saved to {path}: {profile.hand_length_mm:g} x "
            f"{profile.breadth_mm:.0f} mm ({profile.source})"
        )
        text = f"{text}\n{line}" if args.glove is not None else line
    print(json.dumps(out) if args.json else text)
    return 0


def _calibrate_camera(args) -> int:
    from recorder.paths import calibration_dir  # the camera calibration (OpenCV): not at start-up
    from recorder.wrist.calibration import calibrate, camera_file, frames_of

    if args.glove is not None or args.wearer is not None:
        raise GloverecError("--camera calibrates a camera alone: drop --glove and --wearer")
    board = board_from(args)  # a bad flag or file: one line before the camera opens
    model, rms, used = calibrate(frames_of(args.camera, args.views), board)
    path = camera_file(calibration_dir(args.dir), args.camera)
    path.parent.mkdir(parents=True, exist_ok=True)
    model.save(path)
    layout = "{}x{}".format(*board.squares)
    out = {"camera": args.camera, "path": str(path), "views": used, "rms_px": round(rms, 3), "board": layout,
           **model.__dict__}  # fmt: skip
    text = (
        f"camera {args.camera}: {model.width}x{model.height}, fx {model.fx:.1f} fy {model.fy:.1f} px, centre "
        f"({model.cx:.1f}, {model.cy:.1f}), reprojection {rms:.2f} px over {used} views; saved to {path}"
    )
    print(json.dumps(out) if args.json else text)
    return 0


def _calibrate_mount(args) -> int:
    from recorder.calibrate.mount import calibrate_mount, report  # the glove, OpenCV: when it runs

    if args.glove is None:
        raise GloverecError("--wrist pairs the tracker's marker with the glove's palm: add --glove GLOVE")
    if args.camera is not None or args.wearer is not None or args.pinch:
        raise GloverecError("--wrist finds the marker's mounting alone: drop --camera, --wearer and --pinch")
    marker_mm = 40.0 if args.marker_mm is None else args.marker_mm
    result = calibrate_mount(args.glove, args.wrist, args.duration, args.wrist_camera, marker_mm, args.dir,
                             args.realtime)  # fmt: skip
    print(json.dumps(result) if args.json else report(result))
    return 0
