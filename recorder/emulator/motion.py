"""Ground-truth hand motion for the glove emulator: joint angles and palm pose sampled at a fixed rate.

Every trajectory is a deterministic function of time for a given seed, so consecutive blocks are pieces
of one continuous trajectory whatever their sizes. The DIP joints always follow the PIP by thesis eq. 3.3,
so the hand model's distal interpolation holds exactly in the ground truth.

Kinds:
- "gestures": hold a named gesture for 0.5-1.5 s, move to another with minimum-jerk timing in 0.4-1.0 s;
  each keyframe gets a few degrees of pose variability, the joints wander slowly (<= 1.5°, 0.1-0.5 Hz)
  and carry a small 8-12 Hz physiological tremor (<= 0.05°, fingertip accelerations of a few 0.1 m/s²).
- "random": every joint is a sum of low-frequency sinusoids (0.05-1.5 Hz) within its anatomical range.
In both, the palm turns slowly (a few tens of degrees, <= 0.8 Hz) and translates a few cm (<= 1 Hz) in
the world (z up), so the accelerometers see linear acceleration as well as gravity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.hand.kinematics import JOINTS, LIMITS, N_JOINTS, clip, interpolate_dip

KINDS = ("gestures", "random")


def _pose(**deg) -> np.ndarray:
    """A 20-vector in radians from {joint: degrees}, others 0, DIPs from PIPs (eq. 3.3)."""
    a = np.zeros(N_JOINTS)
    for name, value in deg.items():
        a[JOINTS.index(name)] = np.radians(value)
    return interpolate_dip(a)


def _fingers(**per_finger) -> dict:
    """{finger: (mcp_flex, mcp_abd, pip)} in degrees -> joint keyword arguments for _pose."""
    out = {}
    for f, (flex, abd, pip) in per_finger.items():
        out.update({f"{f}_mcp_flex": flex, f"{f}_mcp_abd": abd, f"{f}_pip": pip})
    return out


_CURLED = (85, 0, 105)
GESTURES = {
    "open": _pose(
        thumb_cmc_flex=-10,
        thumb_cmc_abd=10,
        **_fingers(index=(0, 8, 0), middle=(0, 0, 0), ring=(0, -6, 0), pinky=(0, -12, 0)),
    ),
    "fist": _pose(
        thumb_cmc_flex=40,
        thumb_cmc_abd=35,
        thumb_mcp=45,
        thumb_ip=40,
        **_fingers(index=(85, 0, 100), middle=(88, 0, 102), ring=(88, 0, 102), pinky=(85, 0, 100)),
    ),
    # thumb tip on the index tip (forward kinematics puts them about 1 mm apart)
    "pinch": _pose(
        thumb_cmc_flex=10,
        thumb_cmc_abd=20,
        thumb_mcp=25,
        thumb_ip=50,
        **_fingers(index=(40, 0, 50), middle=(20, 0, 30), ring=(25, 0, 35), pinky=(30, 0, 40)),
    ),
    "point": _pose(
        thumb_cmc_flex=35,
        thumb_cmc_abd=30,
        thumb_mcp=40,
        thumb_ip=30,
        **_fingers(index=(0, 0, 5), middle=_CURLED, ring=_CURLED, pinky=_CURLED),
    ),
    # thesis fig. 5.10: index and middle extended, ring and pinky fully curled, thumb to the side
    "two_fingers": _pose(
        thumb_cmc_flex=-10,
        thumb_cmc_abd=15,
        **_fingers(index=(0, 6, 0), middle=(0, -4, 0), ring=(90, 0, 110), pinky=(90, 0, 110)),
    ),
    # thesis fig. 5.16: index and pinky extended, middle and ring curled, thumb extended
    "spiderman": _pose(
        thumb_cmc_flex=-15,
        thumb_cmc_abd=10,
        thumb_mcp=-5,
        thumb_ip=-10,
        **_fingers(index=(0, 5, 0), middle=_CURLED, ring=_CURLED, pinky=(0, -10, 0)),
    ),
}

_MARGIN = np.radians(2.0)  # keyframes stay this far inside LIMITS: wander + tremor never need clipping


@dataclass
class MotionBlock:
    """n samples: t (n,) s since start; angles (n, 20) rad; palm_quat (n, 4) world; palm_pos (n, 3) m world."""

    t: np.ndarray
    angles: np.ndarray
    palm_quat: np.ndarray
    palm_pos: np.ndarray


class _Sines:
    """Sum of sinusoids per output channel: sum_m a[m, c] sin(2 pi f[m, c] t + phi[m, c])."""

    def __init__(self, rng, n_channels, n_terms, f_lo, f_hi, peak):
        self.f = rng.uniform(f_lo, f_hi, (n_terms, n_channels))
        self.phi = rng.uniform(0.0, 2.0 * np.pi, (n_terms, n_channels))
        w = rng.uniform(0.2, 1.0, (n_terms, n_channels))
        self.a = np.asarray(peak) * w / w.sum(axis=0)  # |sum| <= peak per channel

    def __call__(self, t) -> np.ndarray:
        phase = 2.0 * np.pi * t[:, None, None] * self.f + self.phi
        return np.sum(self.a * np.sin(phase), axis=1)


def _min_jerk(s) -> np.ndarray:
    """Minimum-jerk position profile 10 s^3 - 15 s^4 + 6 s^5 on s in [0, 1]."""
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


class Motion:
    """A seeded, continuous hand trajectory sampled at ``rate_hz``; see the module docstring for kinds."""

    def __init__(self, kind: str = "gestures", seed: int = 0, rate_hz: float = 200.0):
        if kind not in KINDS:
            raise ValueError(f"unknown motion kind {kind!r}; valid kinds: {', '.join(KINDS)}")
        self.kind = kind
        self.rate_hz = float(rate_hz)
        self._i = 0
        rng = np.random.default_rng([seed, 0x6D6F])
        self._palm_rot = _Sines(rng, 3, 3, 0.05, 0.8, np.radians([20.0, 25.0, 30.0]))
        self._palm_pos = _Sines(rng, 3, 3, 0.1, 1.0, [0.03, 0.03, 0.02])
        if kind == "random":
            lo, hi = LIMITS[:, 0] + _MARGIN, LIMITS[:, 1] - _MARGIN
            self._mid = 0.5 * (lo + hi)
            self._joints = _Sines(rng, N_JOINTS, 4, 0.05, 1.5, 0.9 * 0.5 * (hi - lo))
        else:
            self._wander = _Sines(rng, N_JOINTS, 2, 0.1, 0.5, np.radians(1.5))
            self._tremor = _Sines(rng, N_JOINTS, 2, 8.0, 12.0, np.radians(0.05))
            self._rng = rng
            self._names = tuple(GESTURES)
            self._current = int(rng.integers(len(self._names)))
            self._knot_t = [0.0]
            self._knot_pose = [self._keyframe(self._current)]

    def _keyframe(self, gesture: int) -> np.ndarray:
        pose = GESTURES[self._names[gesture]] + self._rng.normal(0.0, np.radians(4.0), N_JOINTS)
        return np.clip(pose, LIMITS[:, 0] + _MARGIN, LIMITS[:, 1] - _MARGIN)

    def _extend(self, t_end: float) -> None:
        """Append hold + transition knot pairs until the schedule covers t_end."""
        while self._knot_t[-1] <= t_end:
            hold = self._rng.uniform(0.5, 1.5)
            move = self._rng.uniform(0.4, 1.0)
            nxt = (self._current + 1 + int(self._rng.integers(len(self._names) - 1))) % len(self._names)
            self._current = nxt
            self._knot_t += [self._knot_t[-1] + hold, self._knot_t[-1] + hold + move]
            self._knot_pose += [self._knot_pose[-1], self._keyframe(nxt)]

    def _angles(self, t: np.ndarray) -> np.ndarray:
        if self.kind == "random":
            a = self._mid + self._joints(t)
        else:
            self._extend(float(t[-1]))
            knots = np.asarray(self._knot_t)
            poses = np.asarray(self._knot_pose)
            k = np.searchsorted(knots, t, side="right") - 1
            s = (t - knots[k]) / (knots[k + 1] - knots[k])
            a = poses[k] + (poses[k + 1] - poses[k]) * _min_jerk(s)[:, None]
            a = a + self._wander(t) + self._tremor(t)
        return interpolate_dip(clip(a))

    def at(self, t) -> MotionBlock:
        """The trajectory at times t (n,) seconds, ascending and >= 0."""
        t = np.asarray(t, dtype=float)
        palm_quat = quat.from_rotvec(self._palm_rot(t))
        return MotionBlock(t, self._angles(t), palm_quat, self._palm_pos(t))

    def next_block(self, n: int) -> MotionBlock:
        """The next n samples; t = sample index / rate_hz."""
        t = (self._i + np.arange(n)) / self.rate_hz
        self._i += n
        if n == 0:
            return MotionBlock(t, np.zeros((0, N_JOINTS)), np.zeros((0, 4)), np.zeros((0, 3)))
        return self.at(t)
