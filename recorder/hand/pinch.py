"""Thumb-finger pinches on the hand model, both ways: ``pinch_pose`` finds the joint angles with which a hand of
a given size touches its thumb tip to a finger tip (the emulated wearer's pinch step; ``retarget_motions``, the
human motions retargeting is measured on by bench/retarget.py and its tests); ``estimate_proportions`` finds the
finger lengths of a wearer from the angles the glove measured while they did that (`gloverec calibrate --pinch`).

A pinch is scale-free: a hand and the same hand enlarged pinch with the same angles. What a pinch does tell is
how long the thumb and each finger are against the palm (whose size the measured hand length sets): a longer
thumb meets the index with a straighter index. So the estimate is of each finger's length factor against the
Buchholz proportions of the measured hand, one least-squares problem over the pinches (scipy), pulled weakly
toward 1 (a finger the pinches do not constrain keeps its proportion).
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np
from scipy.optimize import least_squares

from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS, LIMITS, HandSize, forward, interpolate_dip
from recorder.hand.motion import Motion, min_jerk
from recorder.hand.skeleton import FINGER_SEGMENTS, FINGERS

THUMB = [JOINTS.index(j) for j in ("thumb_cmc_flex", "thumb_cmc_abd", "thumb_mcp", "thumb_ip")]
PRIOR = 0.02  # m of fingertip distance per unit of length factor away from 1: a weak pull
FACTORS = (0.7, 1.4)  # the length factors an estimate may take


def _finger_joints(finger: str) -> list[int]:
    return [JOINTS.index(f"{finger}_{j}") for j in ("mcp_flex", "mcp_abd", "pip")]


def tip_gap(angles, size: HandSize, finger: str) -> np.ndarray:
    """Distance (...) from the thumb tip to ``finger``'s tip (m) at joint angles (..., 20)."""
    tips = forward(np.asarray(angles, float), np.array([1.0, 0.0, 0.0, 0.0]), size)[2]
    return np.linalg.norm(tips[..., FINGERS.index(finger), :] - tips[..., 0, :], axis=-1)


@lru_cache(maxsize=64)
def pinch_pose(finger: str, size: HandSize = HandSize()) -> np.ndarray:
    """Joint angles (20,) with the thumb tip on ``finger``'s tip for a hand of ``size``: the thumb and that
    finger move from the pinch gesture's pose as little as they must, the other fingers keep it."""
    if finger not in FINGERS[1:]:
        raise ValueError(f"unknown finger {finger!r}; valid: {', '.join(FINGERS[1:])}")
    start = GESTURES["pinch"].copy()
    free = THUMB + _finger_joints(finger)
    x0 = start[free]

    def residuals(x):
        a = start.copy()
        a[free] = x
        a = interpolate_dip(a)
        tips = forward(a, np.array([1.0, 0.0, 0.0, 0.0]), size)[2]
        return np.concatenate((tips[FINGERS.index(finger)] - tips[0], 0.003 * (x - x0)))

    sol = least_squares(residuals, x0, bounds=(LIMITS[free, 0], LIMITS[free, 1]), xtol=1e-10, ftol=1e-10)
    out = start.copy()
    out[free] = sol.x
    out = interpolate_dip(out)
    out.flags.writeable = False
    return out


def sized(size: HandSize, factors) -> HandSize:
    """``size`` with each finger's bones (thumb first) times its factor."""
    lengths = size.lengths() * 1000.0
    segments = tuple(
        (f, tuple(float(v) for v in k * lengths[list(FINGER_SEGMENTS[f])])) for f, k in zip(FINGERS, factors)
    )
    return replace(size, segments_mm=segments)


def estimate_proportions(pinches: dict, size: HandSize = HandSize()) -> np.ndarray:
    """Length factors (5,) of the thumb and fingers against ``size``'s from pinches: {finger: joint angles
    (n, 20) measured while the thumb tip touched that finger's tip}."""
    fingers = [f for f in FINGERS[1:] if f in pinches and len(pinches[f])]
    if not fingers:
        raise ValueError("no pinches to estimate from")

    def residuals(k):
        s = sized(size, k)
        gaps = [tip_gap(pinches[f], s, f) for f in fingers]
        return np.concatenate(gaps + [PRIOR * (k - 1.0)])

    sol = least_squares(residuals, np.ones(len(FINGERS)), bounds=FACTORS, xtol=1e-8, ftol=1e-10)
    return sol.x


def pinch_motion(fingers, size: HandSize = HandSize(), rate_hz: float = 30.0) -> tuple[np.ndarray, list]:
    """For each of ``fingers`` in turn: open hand -> thumb tip on that finger's tip (``pinch_pose``) in 0.8 s,
    held 0.6 s, open again in 0.8 s. Joint angles (n, 20) and the finger each frame pinches."""
    start = GESTURES["open"]
    move, hold = int(0.8 * rate_hz), int(0.6 * rate_hz)
    s = min_jerk(np.linspace(0.0, 1.0, move))[:, None]
    frames, which = [], []
    for f in fingers:
        target = pinch_pose(f, size)
        seq = np.concatenate(
            (start + s * (target - start), np.repeat(target[None], hold, 0), target + s * (start - target))
        )
        frames.append(interpolate_dip(seq))
        which += [f] * len(seq)
    return np.concatenate(frames), which


def retarget_motions(fingers, size: HandSize = HandSize(), rate_hz: float = 30.0) -> dict:
    """The human motions retargeting is measured on, for a robot with ``fingers`` (no thumb) and a wearer of
    ``size``: the emulated wearer's ``gestures`` and ``random`` motion (10 s each, seed 0) and ``pinches``
    (pinch_motion). {name: (joint angles (n, 20), the finger each frame pinches, or None)}."""
    n = int(10 * rate_hz)
    return {
        "gestures": (Motion("gestures", seed=0, rate_hz=rate_hz).next_block(n).angles, None),
        "random": (Motion("random", seed=0, rate_hz=rate_hz).next_block(n).angles, None),
        "pinches": pinch_motion(fingers, size, rate_hz),
    }
