"""`gloverec calibrate`: its flags; the procedure is recorder/calibrate/procedure.py (loaded when it runs)."""

from __future__ import annotations

import argparse
import json

from recorder.argtypes import positive_int
from recorder.paths import CALIBRATION_ENV
from recorder.view.process import view_arg


def add_parser(sub) -> None:
    c = sub.add_parser("calibrate", help="walk through the calibration steps and save the glove's calibration")
    c.add_argument(
        "--glove",
        required=True,
        help="emulator (the emulated wearer runs the steps), serial:PORT, "
        "a device path, udp:PORT or mcap:FILE (a log of the steps)",
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
    ).run()
    print(json.dumps(summary(result)) if args.json else report(result))
    return 0
