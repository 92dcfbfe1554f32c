"""SessionMotion: one continuous hand motion for a whole recording session with the emulated glove.

The glove emulator synthesises IMU readings by differentiating the hand's motion, so the motion must never
jump. Demonstrations are appended to the session's keyframes while it streams: the hand moves from wherever it
is, with minimum jerk, to the demonstration's first pose, and then performs it. The wander, tremor and palm
drift run on session time, continuous across demonstrations.
"""

from __future__ import annotations

import threading

import numpy as np

from recorder.demonstrator.motion import DemoMotion
from recorder.hand.gestures import GESTURES


class SessionMotion(DemoMotion):
    def __init__(self, seed: int = 0, rate_hz: float = 200.0):
        super().__init__([0.0], [GESTURES["open"]], np.random.default_rng([seed, 0x5E55]), rate_hz)
        self._lock = threading.Lock()

    def append(self, demo: DemoMotion, start_s: float, transition_s: float = 0.8) -> None:
        """Perform ``demo`` from session time ``start_s``, reaching its first pose by then (the move starts
        ``transition_s`` earlier, or at once if that has passed). Samples before ``start_s - transition_s``
        are unchanged, so blocks the emulator already generated stay valid."""
        t_from = max(start_s - transition_s, 0.0)
        with self._lock:
            here = self.keyframe_angles([t_from])[0]
            turn = self._keyframes([t_from], self.palm_turns)[0]
            pos = self._keyframes([t_from], self.palm_positions)[0]
            keep = self.times < t_from
            self.times = np.concatenate((self.times[keep], [t_from], start_s + demo.times))
            self.poses = np.concatenate((self.poses[keep], [here], demo.poses))
            self.palm_turns = np.concatenate((self.palm_turns[keep], [turn], demo.palm_turns))
            self.palm_positions = np.concatenate((self.palm_positions[keep], [pos], demo.palm_positions))

    def revise(self, at_s: float, duration_s: float, palm_delta=(0.0, 0.0, 0.0), move=(0.0, 0.0, 0.0),
               pose_delta=None) -> float:  # fmt: skip
        with self._lock:
            return super().revise(at_s, duration_s, palm_delta, move, pose_delta)

    def splice(self, at_s: float, plan: DemoMotion) -> float:
        with self._lock:
            return super().splice(at_s, plan)

    def next_block(self, n: int):
        with self._lock:
            return super().next_block(n)
