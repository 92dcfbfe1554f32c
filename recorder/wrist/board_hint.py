"""What views showed when too few of them showed the board (recorder/wrist/calibration.py): the markers'
dictionary and the board's layout, so that the one-line error can say which flags describe the board held up.

The markers come from OpenCV's ArUco detector, for the configured dictionary and, when it finds none, for each
other dictionary that DICTIONARIES knows. The layout is the one thing written here, since OpenCV has no call that
names a ChArUco board from its markers: every layout numbers its markers from 0, row by row, so the ids alone do
not tell a 7×5 board from a 5×7 one, but where the markers sit does. For each candidate layout (the configured
one, its transpose, the common ones; each with and without the legacy pattern) the board's marker centres for the
ids seen are fitted to where they were seen with a homography (cv2.findHomography): the layout of the board held
up fits to a fraction of a pixel, another one by about a square."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

from recorder.wrist.board import BoardSpec
from recorder.wrist.marker import DICTIONARIES

COMMON = ((5, 7), (7, 5), (6, 8), (8, 6), (5, 5), (6, 6), (7, 7), (8, 8), (9, 6), (6, 9), (8, 11), (11, 8),
          (9, 12), (12, 9), (10, 7), (7, 10))  # fmt: skip
MIN_MARKERS = 6  # markers a view must show to be fitted: a homography has 8 unknowns, so 4 points fit any layout
BETTER = 0.5  # another layout is named when it fits at most half as far off as the configured one


def what_the_views_show(greys: list[np.ndarray], board: BoardSpec) -> str | None:
    """A phrase for the error ("found 4X4_50 markers in 38 views, laid out as a 5×7 board: pass --board 5x7"), or
    None when no view shows markers of a known dictionary, or what they show is the configured board."""
    for name in dict.fromkeys([board.dictionary, *DICTIONARIES]):
        views = [v for v in _markers(greys, name) if len(v[0])]
        if views:
            break
    else:
        return None
    seen = f"found {name} markers in {len(views)} view{'s' if len(views) != 1 else ''}"
    fitted = [v for v in views if len(v[0]) >= MIN_MARKERS]
    configured = dataclasses.replace(board, dictionary=name)
    if not fitted:
        if name == board.dictionary:
            return f"{seen}, never {MIN_MARKERS} at once: hold the whole board in view"
        return f"{seen}, never {MIN_MARKERS} at once: pass --dictionary {name} and hold the whole board in view"
    errors = {spec: _error(spec, fitted) for spec in _candidates(configured, max(int(v[0].max()) for v in fitted))}
    best_error = min(errors.values())
    best = next(s for s, e in errors.items() if e <= best_error * 1.01 + 1e-9)  # ties: the configured one first
    if not errors.get(configured, np.inf) * BETTER > best_error:
        best = configured
    flags = [f"--dictionary {name}"] if name != board.dictionary else []
    if best.squares != board.squares:
        flags.append(f"--board {best.squares[0]}x{best.squares[1]}")
    if best.legacy != board.legacy:
        flags.append("--legacy" if best.legacy else "--no-legacy")
    if not flags:
        return None
    legacy = " in the legacy pattern" if best.legacy else ""
    article = "an" if best.layout().startswith(("8", "11", "18")) else "a"
    return f"{seen}, laid out as {article} {best.layout()} board{legacy}: pass {' '.join(flags)}"


def _markers(greys, name: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per view, the ids (n,) and centres (n, 2) of the markers of dictionary ``name``."""
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(DICTIONARIES[name]))
    out = []
    for grey in greys:
        corners, ids, _ = detector.detectMarkers(grey)
        if ids is None:
            out.append((np.zeros(0, int), np.zeros((0, 2))))
            continue
        out.append((ids.ravel().astype(int), np.array([c.reshape(4, 2).mean(0) for c in corners])))
    return out


def _candidates(configured: BoardSpec, top_id: int) -> list[BoardSpec]:
    """The layouts to try, the configured one first, each that has a marker numbered ``top_id``."""
    across, down = configured.squares
    layouts = dict.fromkeys([(across, down), (down, across), *COMMON])
    out = []
    for squares in layouts:
        for legacy in (configured.legacy, not configured.legacy):
            try:
                spec = dataclasses.replace(configured, squares=squares, legacy=legacy)
            except ValueError:  # more markers than the dictionary holds
                continue
            if spec.markers() > top_id:
                out.append(spec)
    return out


def _error(spec: BoardSpec, views) -> float:
    """The RMS distance (px) between where the markers were seen and where the homography fitted to the board's
    marker centres puts them, over the views."""
    board = spec.board()
    centres = np.array(board.getObjPoints(), np.float64).mean(axis=1)[:, :2]
    where = {int(i): k for k, i in enumerate(board.getIds().ravel())}
    squares = []
    for ids, seen in views:
        obj = centres[[where[i] for i in ids]]
        h, _ = cv2.findHomography(obj, seen, 0)
        if h is None:
            return np.inf
        fitted = cv2.perspectiveTransform(obj.reshape(-1, 1, 2), h).reshape(-1, 2)
        squares.append(((fitted - seen) ** 2).sum(axis=1))
    return float(np.sqrt(np.concatenate(squares).mean()))
