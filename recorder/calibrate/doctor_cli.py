"""`gloverec doctor`: its flags; the check-up is recorder/calibrate/doctor.py (loaded when it runs)."""

from __future__ import annotations

import json

from recorder.paths import CALIBRATION_ENV
from recorder.view.process import view_arg


def add_parser(sub) -> None:
    d = sub.add_parser("doctor", help="check a new glove: dead, stuck, flaky, swapped or turned IMUs, a slow bus")
    d.add_argument("--glove", required=True, help="emulator, serial:PORT, a device path, udp:PORT or mcap:FILE")
    d.add_argument("--fix", action="store_true", help="save the channel map that undoes swapped cables and IMUs "
                   "glued turned, beside the calibration (the host applies it to every raw frame)")  # fmt: skip
    d.add_argument("--dir", help=f"where calibrations live (default: ${CALIBRATION_ENV}, else datasets/calibration)")
    d.add_argument("--yes", action="store_true", help="do not wait for Enter: each move follows the last (the "
                   "default when stdin is not a terminal, and for the emulator)")  # fmt: skip
    d.add_argument("--realtime", action="store_true", help="pace --glove emulator in real time")
    d.add_argument("--json", action="store_true", help="print a JSON report instead of the screen")
    d.add_argument("--view", type=view_arg, default="none", help="a live view of each move on the human hand: "
                   "native, web[:PORT], rerun[:MODE], none (default: none; the terminal says each move)")  # fmt: skip
    d.set_defaults(func=cmd_doctor)


def cmd_doctor(args) -> int:
    from recorder.calibrate.doctor import Doctor, report, summary  # fusion, the glove: when it runs

    verdict = Doctor(args.glove, folder=args.dir, interactive=False if args.yes else None,
                     realtime=args.realtime, view=args.view).run(fix=args.fix)  # fmt: skip
    print(
        json.dumps(summary(verdict)) if args.json else report(verdict, f"`gloverec doctor --glove {args.glove} --fix`")
    )
    return 0 if verdict.checkup.ok or verdict.saved is not None else 1
