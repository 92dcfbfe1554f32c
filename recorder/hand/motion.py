"""Hand motion sampled in time: joint angles and palm pose. ``SampledMotion`` is what every trajectory provides
(``at(t)`` at any times, ``next_block(n)`` the next n samples at ``rate_hz``): the emulated wearer's ``Motion``
here, the scripted demonstrations (recorder/demonstrator) and the calibration procedure (recorder/emulator).

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
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import LIMITS, N_JOINTS, clip, interpolate_dip

KINDS = ("gestures", "random")


_MARGIN = np.radians(2.0)  # keyframes stay this far inside LIMITS: wander + tremor never need clipping


@dataclass
class MotionBlock:
    """n samples: t (n,) s since start; angles (n, 20) rad; palm_quat (n, 4) world; palm_pos (n, 3) m world."""

    t: np.ndarray
    angles: np.ndarray
    palm_quat: np.ndarray
    palm_pos: np.ndarray

    @classmethod
    def empty(cls) -> MotionBlock:
        return cls(np.zeros(0), np.zeros((0, N_JOINTS)), np.zeros((0, 4)), np.zeros((0, 3)))


class Sines:
    """Sum of sinusoids per output channel: sum_m a[m, c] sin(2 pi f[m, c] t + phi[m, c])."""

    def __init__(self, rng, n_channels, n_terms, f_lo, f_hi, peak):
        self.f = rng.uniform(f_lo, f_hi, (n_terms, n_channels))
        self.phi = rng.uniform(0.0, 2.0 * np.pi, (n_terms, n_channels))
        w = rng.uniform(0.2, 1.0, (n_terms, n_channels))
        self.a = np.asarray(peak) * w / w.sum(axis=0)  # |sum| <= peak per channel

    def __call__(self, t) -> np.ndarray:
        phase = 2.0 * np.pi * t[:, None, None] * self.f + self.phi
        return np.sum(self.a * np.sin(phase), axis=1)


def min_jerk(s) -> np.ndarray:
    """Minimum-jerk position profile 10 s^3 - 15 s^4 + 6 s^5 on s in [0, 1] (0 before, 1 after)."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


class SampledMotion:
    """Base of the hand trajectories: subclasses define ``at(t)``; ``next_block(n)`` samples the next n at
    ``rate_hz`` (t = sample index / rate_hz), so consecutive blocks are one trajectory whatever their sizes."""

    def __init__(self, rate_hz: float = 200.0):
        self.rate_hz = float(rate_hz)
        self._i = 0

    def at(self, t) -> MotionBlock:
        """The trajectory at times t (n,) seconds, ascending and >= 0."""
        raise NotImplementedError

    def next_block(self, n: int) -> MotionBlock:
        """The next n samples."""
        t = (self._i + np.arange(n)) / self.rate_hz
        self._i += n
        return self.at(t) if n else MotionBlock.empty()


class Motion(SampledMotion):
    """A seeded, continuous hand trajectory sampled at ``rate_hz``; see the module docstring for kinds."""

    def __init__(self, kind: str = "gestures", seed: int = 0, rate_hz: float = 200.0):
        if kind not in KINDS:
            raise ValueError(f"unknown motion kind {kind!r}; valid kinds: {', '.join(KINDS)}")
        super().__init__(rate_hz)
        self.kind = kind
        rng = np.random.default_rng([seed, 0x6D6F])
        self._palm_rot = Sines(rng, 3, 3, 0.05, 0.8, np.radians([20.0, 25.0, 30.0]))
        self._palm_pos = Sines(rng, 3, 3, 0.1, 1.0, [0.03, 0.03, 0.02])
        if kind == "random":
            lo, hi = LIMITS[:, 0] + _MARGIN, LIMITS[:, 1] - _MARGIN
            self._mid = 0.5 * (lo + hi)
            self._joints = Sines(rng, N_JOINTS, 4, 0.05, 1.5, 0.9 * 0.5 * (hi - lo))
        else:
            self._wander = Sines(rng, N_JOINTS, 2, 0.1, 0.5, np.radians(1.5))
            self._tremor = Sines(rng, N_JOINTS, 2, 8.0, 12.0, np.radians(0.05))
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
            a = poses[k] + (poses[k + 1] - poses[k]) * min_jerk(s)[:, None]
            a = a + self._wander(t) + self._tremor(t)
        return interpolate_dip(clip(a))

    def at(self, t) -> MotionBlock:
        """The trajectory at times t (n,) seconds, ascending and >= 0."""
        t = np.asarray(t, dtype=float)
        palm_quat = quat.from_rotvec(self._palm_rot(t))
        return MotionBlock(t, self._angles(t), palm_quat, self._palm_pos(t))
