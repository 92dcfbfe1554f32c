"""The ChArUco board's flags, shared by `gloverec calibrate --camera` and `gloverec board` (the printable board):
``--board 5x7``, ``--square-mm``, ``--marker-mm``, ``--dictionary``, ``--legacy`` or a YAML file (``--board-file``,
keys: recorder/wrist/board.py's BoardSpec fields; the flags override it). OpenCV loads when a command runs."""

from __future__ import annotations

import argparse
import json

from recorder.argtypes import positive_float, positive_int

BOARD_FLAGS = ("board", "square_mm", "dictionary", "legacy", "board_file")  # all but --marker-mm (calibrate's)


def _layout(text: str) -> tuple[int, int]:
    from recorder.wrist.board import layout

    try:
        return layout(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_board_arguments(parser, marker: bool = True) -> None:
    """The board's flags on ``parser`` (``marker``: with its own --marker-mm; calibrate shares its own)."""
    parser.add_argument("--board", type=_layout, metavar="CxR", help="the board's squares across x down, e.g. 5x7 "
                        "(OpenCV's tutorial board; default 7x5)")  # fmt: skip
    parser.add_argument("--square-mm", type=positive_float, metavar="MM", help="the squares' side, mm (default 30)")
    if marker:
        parser.add_argument("--marker-mm", type=positive_float, metavar="MM",
                            help="the markers' side, mm (default 22)")  # fmt: skip
    parser.add_argument("--dictionary", metavar="NAME", help="the markers' ArUco dictionary: 4X4_50 (default), "
                        "5X5_100 or 6X6_250")  # fmt: skip
    parser.add_argument("--legacy", action=argparse.BooleanOptionalAction, default=None,
                        help="OpenCV's legacy pattern (boards made before OpenCV 4.6 or by other tools, with an even "
                        "number of rows)")  # fmt: skip
    parser.add_argument("--board-file", metavar="FILE.yaml", help="the board as YAML, keys squares ([5, 7]), "
                        "square_m, marker_m, dictionary, legacy (the flags override it)")  # fmt: skip


def board_from(args):
    """The BoardSpec the flags describe (one-line ConfigError for a bad value or file)."""
    from recorder.wrist.board import board_spec

    mm = {k: getattr(args, k) for k in ("square_mm", "marker_mm")}
    return board_spec(
        args.board_file,
        squares=args.board,
        square_m=mm["square_mm"] / 1e3 if mm["square_mm"] is not None else None,
        marker_m=mm["marker_mm"] / 1e3 if mm["marker_mm"] is not None else None,
        dictionary=args.dictionary,
        legacy=args.legacy,
    )


def add_parser(sub) -> None:
    b = sub.add_parser("board", help="write the printable ChArUco board for `gloverec calibrate --camera` (a PDF at "
                       "its true size, or a PNG at --dpi)")  # fmt: skip
    b.add_argument("--out", required=True, metavar="FILE.pdf|FILE.png", help="the file to write")
    add_board_arguments(b)
    b.add_argument("--dpi", type=positive_int, default=300, help="the PNG's dots per inch (default 300)")
    b.add_argument("--margin-mm", type=positive_float, default=10.0,
                   help="the white margin around the board, with the caption below it (default 10)")  # fmt: skip
    b.add_argument("--json", action="store_true", help="print a JSON summary instead of the line")
    b.set_defaults(func=cmd_board)


def cmd_board(args) -> int:
    from recorder.wrist.board import save_printable

    board = board_from(args)
    width, height = save_printable(board, args.out, args.dpi, args.margin_mm)
    unit = "px" if args.out.lower().endswith(".png") else "pt"
    w_mm, h_mm = (round(v * 1e3, 3) for v in board.size_m())
    out = {"path": args.out, "board": "{}x{}".format(*board.squares), "board_mm": [w_mm, h_mm],
           "square_mm": board.square_m * 1e3, "marker_mm": board.marker_m * 1e3, "dictionary": board.dictionary,
           "legacy": board.legacy, "page": [round(width, 2), round(height, 2)], "unit": unit}  # fmt: skip
    dpi = f" at {args.dpi} dpi" if unit == "px" else ""
    text = (f"{board.caption().split(': ')[0]}: {w_mm:g} x {h_mm:g} mm, written to {args.out} ({width:.0f} x "
            f"{height:.0f} {unit}{dpi}); print at 100 %")  # fmt: skip
    print(json.dumps(out) if args.json else text)
    return 0
