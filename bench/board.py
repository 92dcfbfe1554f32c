"""The calibration board the user owns (recorder/wrist/board.py, `gloverec calibrate --camera --board`): a rendered
webcam (its intrinsics known) films the default 7 × 5 board and OpenCV's tutorial 5 × 7 board (both 30 mm squares,
22 mm markers, 4X4_50), 30 views each, and each video is calibrated as `gloverec calibrate --camera VIDEO` does it:
the 7 × 5 with the defaults, the 5 × 7 with ``--board 5x7`` and without it (the one-line hint). Records fx's and
fy's error against the truth, the reprojection RMS, the views used and the hint's text.
Writes bench/results/board.json.

    MUJOCO_GL=egl .venv/bin/python bench/board.py [--views 30]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results  # noqa: E402

from recorder import GloverecError  # noqa: E402
from recorder.wrist.board import BoardSpec, film_board  # noqa: E402
from recorder.wrist.calibration import calibrate, frames_of  # noqa: E402


def run(video: Path, truth, board: BoardSpec, views: int) -> dict:
    start = time.perf_counter()
    try:
        model, rms, used = calibrate(frames_of(str(video), views), board)
    except GloverecError as exc:
        return {"error": str(exc), "seconds": round(time.perf_counter() - start, 2)}
    return {
        "fx_error_pct": round(float(100 * (model.fx / truth.fx - 1)), 3),
        "fy_error_pct": round(float(100 * (model.fy / truth.fy - 1)), 3),
        "centre_error_px": round(float(((model.cx - truth.cx) ** 2 + (model.cy - truth.cy) ** 2) ** 0.5), 2),
        "rms_px": round(rms, 3),
        "views_used": used,
        "seconds": round(time.perf_counter() - start, 2),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--views", type=int, default=30)
    args = p.parse_args()
    out = {"views": args.views}
    with tempfile.TemporaryDirectory() as folder:
        for name, squares in (("7x5", (7, 5)), ("5x7", (5, 7))):
            video = Path(folder) / f"board{name}.mkv"
            truth = film_board(video, BoardSpec(squares=squares), views=args.views, seed=2)
            out["truth_fx_px"] = round(truth.fx, 2)
            if name == "7x5":
                out["7x5 (default)"] = run(video, truth, BoardSpec(), args.views)
            else:
                out["5x7 --board 5x7"] = run(video, truth, BoardSpec(squares=squares), args.views)
                out["5x7 without --board"] = run(video, truth, BoardSpec(), args.views)
    for key, row in out.items():
        print(f"{key}: {row}")
    write_results("board", out)


if __name__ == "__main__":
    main()
