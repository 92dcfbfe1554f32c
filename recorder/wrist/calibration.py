"""A camera's intrinsics from views of a ChArUco board: OpenCV's ChArUco detector and ``calibrateCamera``. The
board (recorder/wrist/board.py: its layout, sizes and dictionary) is printed by `gloverec board`; its views come
from the camera itself (a device index, a video file or a stream URL); the result is a CameraModel saved per
camera beside the glove calibrations."""

from __future__ import annotations

import re
import time
from pathlib import Path

import cv2
import numpy as np

from recorder import GloverecError
from recorder.wrist.board import BoardSpec
from recorder.wrist.board_hint import what_the_views_show
from recorder.wrist.marker import CameraModel

__all__ = ["BoardSpec", "calibrate", "camera_file", "frames_of"]

MIN_VIEWS = 5  # views that show enough of the board
MIN_CORNERS = 8  # chessboard corners a view must show to count


def calibrate(frames, board: BoardSpec = BoardSpec()) -> tuple[CameraModel, float, int]:
    """(the camera's model, the reprojection RMS in px, the views used) from ``frames`` (RGB or grey images of
    one size); GloverecError in one line when too few of them show the board, saying what they show instead (the
    markers of another layout or dictionary: recorder/wrist/board_hint.py)."""
    b = board.board()
    detector = cv2.aruco.CharucoDetector(b)
    greys = [frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY) for frame in frames]
    objects, images, size = [], [], None
    for grey in greys:
        size = grey.shape[::-1]
        corners, ids, _, _ = detector.detectBoard(grey)
        if ids is None or len(ids) < MIN_CORNERS:
            continue
        obj, img = b.matchImagePoints(corners, ids)
        objects.append(obj)
        images.append(img)
    if len(objects) < MIN_VIEWS:
        hint = what_the_views_show(greys, board) or (
            f"move it through the camera's view, near and far, tilted (a {board.layout()} board of {board.dictionary} "
            "markers; another: --board, --dictionary)"
        )
        raise GloverecError(f"only {len(objects)} views showed the board ({MIN_VIEWS} needed): {hint}")
    rms, k, dist, _, _ = cv2.calibrateCamera(objects, images, size, None, None)
    model = CameraModel(size[0], size[1], float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]),
                        tuple(float(v) for v in dist.ravel()[:5]))  # fmt: skip
    return model, float(rms), len(objects)


def frames_of(camera: str, views: int, every_s: float = 0.5):
    """Up to ``views`` frames of ``camera`` (a device index: one every ``every_s``; a file: spread over it)."""
    source = int(camera) if camera.isdigit() else camera
    capture = cv2.VideoCapture(source)
    if not capture.isOpened():
        raise GloverecError(f"cannot open the camera or video {camera!r} (a device index, file or URL)")
    try:
        count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) if not isinstance(source, int) else 0
        wanted = set(np.linspace(0, count - 1, min(views, count)).round().astype(int)) if count > 0 else None
        out, k, last = [], 0, -1e9
        while len(out) < views:
            ok, frame = capture.read()
            if not ok:
                break
            if wanted is not None:
                if k in wanted:
                    out.append(frame[..., ::-1])
            elif time.monotonic() - last >= every_s:
                out.append(frame[..., ::-1])
                last = time.monotonic()
            k += 1
    finally:
        capture.release()
    if not out:
        raise GloverecError(f"no frames from {camera!r}: is it a video?")
    return out


def camera_file(directory: str | Path, camera: str) -> Path:
    """Where a camera's calibration is saved: ``camera_<name>.json`` in the calibrations' folder."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", Path(camera).name if not camera.isdigit() else camera).strip("_")
    return Path(directory) / f"camera_{name or 'default'}.json"
