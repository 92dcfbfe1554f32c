"""DemoMotion: a scripted, human-like hand trajectory (a recorder.hand.motion.SampledMotion).

Keyframed joint angles joined by minimum-jerk moves, plus the small slow wander and physiological tremor of
a real hand, and a palm that drifts a few degrees; sampled at ``rate_hz`` by ``next_block(n)`` (or at any
times by ``at(t)``), so it can drive a SyntheticGlove, the emulator, or a Retargeter directly.
"""

from __future__ import annotations

import numpy as np

from recorder import quat
from recorder.hand.kinematics import LIMITS, N_JOINTS, clip, interpolate_dip
from recorder.hand.motion import MotionBlock, SampledMotion, Sines, min_jerk


class DemoMotion(SampledMotion):
    watcher = None  # called by ``watch``: a wearer who watches the robot hand (recorder/demonstrator/watching.py)

    @property
    def watches(self) -> bool:
        """Whether ``watch`` may revise the plan: its performer stays close behind."""
        return self.watcher is not None

    def __init__(
        self,
        times,
        poses,
        rng: np.random.Generator,
        rate_hz: float = 200.0,
        wander_deg: float = 0.75,
        tremor_deg: float = 0.05,
        palm_deg: float = 3.0,
        palm_pos=(0.0, 0.0, 0.0),
        palm_turns=None,
    ):
        """times (k,) ascending s; poses (k, 20) rad: the hand is at poses[i] at times[i], holds before the
        first and after the last, and moves with minimum jerk in between (equal poses: a hold). palm_turns (k, 3)
        rad: the palm's rotation vector (palm axes) at each keyframe, on the same minimum-jerk path (default 0).
        palm_pos: the palm's position (m, world), (3,) for all the demonstration or (k, 3), one per keyframe on
        that path: the wrist a free-wrist task's demonstrator moves (the wearer's reach)."""
        super().__init__(rate_hz)
        self.times = np.asarray(times, float)
        self.poses = clip(np.asarray(poses, float))
        if self.times.ndim != 1 or len(self.times) != len(self.poses) or np.any(np.diff(self.times) < 0):
            raise ValueError("keyframe times must be ascending, one per pose")
        pos = np.asarray(palm_pos, float)
        self.palm_positions = np.tile(pos, (len(self.times), 1)) if pos.ndim == 1 else pos
        if self.palm_positions.shape != (len(self.times), 3):
            raise ValueError("palm positions must be one per keyframe")
        self.palm_turns = np.zeros((len(self.times), 3)) if palm_turns is None else np.asarray(palm_turns, float)
        if self.palm_turns.shape != (len(self.times), 3):
            raise ValueError("palm turns must be one rotation vector per keyframe")
        self._wander = Sines(rng, N_JOINTS, 2, 0.1, 0.5, np.radians(wander_deg))
        self._tremor = Sines(rng, N_JOINTS, 2, 8.0, 12.0, np.radians(tremor_deg))
        self._palm = Sines(rng, 3, 2, 0.05, 0.4, np.radians(palm_deg))

    intent: dict | None = None  # what a planner meant by this take (recorder/demonstrator/human.py)

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def _keyframes(self, t, values) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, float))
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 1)
        k1 = np.minimum(k + 1, len(self.times) - 1)
        span = self.times[k1] - self.times[k]
        s = np.where(span > 0, (t - self.times[k]) / np.where(span > 0, span, 1.0), 1.0)
        return values[k] + (values[k1] - values[k]) * min_jerk(np.clip(s, 0.0, 1.0))[:, None]

    def keyframe_angles(self, t) -> np.ndarray:
        """The keyframe path alone (no wander or tremor), (n, 20) rad."""
        return self._keyframes(t, self.poses)

    def revise(self, at_s: float, duration_s: float, palm_delta=(0.0, 0.0, 0.0), move=(0.0, 0.0, 0.0),
               pose_delta=None) -> float:  # fmt: skip
        """A correction while demonstrating: from ``at_s`` on, spend ``duration_s`` turning the palm by
        ``palm_delta`` (a rotation vector, palm axes; zeros: a pause), moving it by ``move`` (m, world) and the
        joints by ``pose_delta`` ((20,) rad, or None), then go on with the rest of the plan that much later (and
        turned and moved by that much; flexed by that much while the pose is held, the plan's next posture as
        planned). ``at_s`` must fall in a hold (between two equal keyframes): the
        path before it is unchanged, so samples already taken stay valid. Returns when the correction starts
        (``at_s``; a performer may start it later, or return None when it is too late)."""
        at_s = float(at_s)
        k = self._hold(at_s)
        delta = np.asarray(palm_delta, float)
        flex = np.zeros(N_JOINTS) if pose_delta is None else np.asarray(pose_delta, float)
        pose, turn = self.keyframe_angles([at_s])[0], self._keyframes([at_s], self.palm_turns)[0]
        at, move = self._keyframes([at_s], self.palm_positions)[0], np.asarray(move, float)  # before the times move
        self.times = np.concatenate((self.times[:k], [at_s, at_s + duration_s], self.times[k:] + duration_s))
        held = np.cumprod([np.allclose(p, pose) for p in self.poses[k:]]).astype(bool)  # the hold goes on flexed;
        later = self.poses[k:] + np.where(held[:, None], flex, 0.0)  # a move after it goes where it was planned to
        self.poses = clip(np.concatenate((self.poses[:k], [pose, pose + flex], later)))
        self.palm_positions = np.concatenate((self.palm_positions[:k], [at, at + move], self.palm_positions[k:] + move))
        self.palm_turns = np.concatenate((self.palm_turns[:k], [turn, turn + delta], self.palm_turns[k:] + delta))
        return at_s

    def _hold(self, at_s: float) -> int:
        """The index of the first keyframe after ``at_s``, which must fall in a hold (between two equal keyframes,
        or after the last): a change from there leaves the path before it as it was. A move: ValueError."""
        k = int(np.searchsorted(self.times, at_s, side="right"))
        if 0 < k < len(self.times) and not (
            np.allclose(self.poses[k - 1], self.poses[k])
            and np.allclose(self.palm_turns[k - 1], self.palm_turns[k])
            and np.allclose(self.palm_positions[k - 1], self.palm_positions[k])
        ):
            raise ValueError(f"a correction at {at_s:.2f} s falls inside a move, not a hold")
        return k

    def splice(self, at_s: float, plan: DemoMotion) -> float:
        """From ``at_s`` (in a hold) on, perform ``plan`` instead of the rest of this one: a plan made from the state
        the demonstration found there (its time 0 is ``at_s``, its first keyframe the hand as it holds then).
        Returns ``at_s``."""
        at_s = float(at_s)
        k = self._hold(at_s)
        self.times = np.concatenate((self.times[:k], at_s + plan.times))
        for name in ("poses", "palm_positions", "palm_turns"):
            setattr(self, name, np.concatenate((getattr(self, name)[:k], getattr(plan, name))))
        return at_s

    def insert(self, t: float, pose, replace: bool = False) -> None:
        """A keyframe ``pose`` (20 rad) at ``t`` (the palm where its path is then); with ``replace``, the keyframe at
        exactly ``t`` takes ``pose`` instead. The planners' edits (recorder/demonstrator/human.py)."""
        k, pose = int(np.searchsorted(self.times, t)), clip(np.asarray(pose, float))
        if replace:
            if k >= len(self.times) or not np.isclose(self.times[k], t):
                raise ValueError(f"no keyframe at {t:.3f} s to replace")
            self.poses[k] = pose
            return
        at, turn = self._keyframes([t], self.palm_positions)[0], self._keyframes([t], self.palm_turns)[0]
        self.times = np.insert(self.times, k, t)
        self.poses = np.insert(self.poses, k, pose, axis=0)
        self.palm_positions = np.insert(self.palm_positions, k, at, axis=0)
        self.palm_turns = np.insert(self.palm_turns, k, turn, axis=0)

    def watch(self, env, into=None) -> None:
        """Called by whoever performs the demonstration after each step of ``env``: a demonstrator that watches
        what it does corrects its plan here (``into.revise``; ``into``: where the plan is performed, by default
        this motion), through its ``watcher`` if it has one."""
        if self.watcher is not None:
            self.watcher(self, env, self if into is None else into)

    def angles(self, t) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, float))
        a = self.keyframe_angles(t) + self._wander(t) + self._tremor(t)
        return interpolate_dip(np.clip(a, LIMITS[:, 0], LIMITS[:, 1]))

    def at(self, t) -> MotionBlock:
        t = np.atleast_1d(np.asarray(t, float))
        palm_quat = quat.mul(quat.from_rotvec(self._keyframes(t, self.palm_turns)), quat.from_rotvec(self._palm(t)))
        return MotionBlock(t, self.angles(t), palm_quat, self._keyframes(t, self.palm_positions))
