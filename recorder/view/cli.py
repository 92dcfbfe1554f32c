"""`gloverec view`: its flags, generated from ViewConfig (recorder/view/config.py); the view itself is
recorder/view/live.py (loaded only when the command runs)."""

from __future__ import annotations

import argparse
import sys

from recorder import config
from recorder.view.config import ViewConfig


def add_parser(subparsers):
    v = subparsers.add_parser("view", help="a MuJoCo robot hand follows the glove live")
    config.add_arguments(v, ViewConfig, required=("glove",))
    # never used: the video films through the view's free camera; taken, with a note, for a release
    v.add_argument("--camera", help=argparse.SUPPRESS)
    v.set_defaults(func=run)
    return v


def run(args) -> int:
    if args.camera is not None:
        print(f"gloverec view: note: --camera {args.camera} does nothing (the video films through the view's camera); "
              "--camera goes in a later release", file=sys.stderr)  # fmt: skip
    cfg = config.load(ViewConfig, overrides=config.overrides(args, ViewConfig))
    from recorder.view import live  # mujoco, the glove and retargeting: only when the command runs

    return live.run(cfg)
