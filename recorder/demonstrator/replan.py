"""Demonstrators that act from the state they find: a free-wrist plan (HandRelocate, HandPick) that sees its object
lie elsewhere than it reaches for (pushed, knocked), or out of the hand while it should hold it (slipped, or knocked
by a policy before a takeover), plans again from where the hand and the object are, and goes on with that plan
from its next pause (``DemoMotion.splice``; for the emulated glove the performer's)."""

from __future__ import annotations

import numpy as np

from recorder.demonstrator.motion import DemoMotion


def in_hand(env) -> bool:
    """The object is held off the table: two hand bodies on it, and 1 cm above where it rests."""
    return bool(env.hand_contacts(env.object_geom) >= 2 and env.object_pose()[2] - env.object_start[2] > 0.01)


class ReplanningMotion(DemoMotion):
    """A plan that re-plans (see the module docstring): ``aim`` (x, y, reached_s, held_s, released_s): where its
    reach goes for the object, when the hand is over it, and from when until when the plan has it in the hand;
    ``planner``: the demonstrator, whose ``plan(env, seed, start=(pose, palm position))`` plans from the state
    found; at most ``replans`` times a take (0: a careless take, which does not go back for it)."""

    watches = True
    replans = 3
    moved_m = 0.015  # the object this far from where the plan reaches for it (and at rest): planned again

    def __init__(self, *args, aim=None, planner=None, seed: int = 0, **kw):
        super().__init__(*args, **kw)
        self.aim = None if aim is None else np.asarray(aim, float)
        self.planner, self.seed, self.replanned = planner, seed, 0
        self._last_seen = None

    def replanned_now(self, env, into) -> bool:
        """Called on every watch: whether it saw the object lost and planned again (the rest of the watch then
        waits for the next step)."""
        if not self._displaced(env):
            return False
        self._replan(env, into)
        return True

    def shifted(self, at: float, took: float) -> None:
        """A correction at ``at`` took ``took`` s: what the plan expects after it comes that much later."""
        if self.aim is not None:
            self.aim[2:] += np.where(self.aim[2:] > at, took, 0.0)

    def adopt(self, fresh: ReplanningMotion, at: float) -> None:
        """Take what ``fresh`` (spliced in at ``at``) expects as this plan's own (a subclass adds its checks)."""
        self.aim = fresh.aim + [0.0, 0.0, at, at, at]

    def _displaced(self, env) -> bool:
        pose = env.object_pose()[:3]
        still = self._last_seen is not None and np.linalg.norm(pose - self._last_seen) < 2e-4  # < 6 mm/s at 30 Hz
        self._last_seen = pose
        if self.planner is None or self.aim is None or self.replanned >= self.replans or not still:
            return False
        reached, held, released = self.aim[2:]
        if env.t < reached:
            return float(np.linalg.norm(pose[:2] - self.aim[:2])) > self.moved_m
        return held < env.t < released and not in_hand(env)

    def _replan(self, env, into) -> None:
        """Plan again from the hand and the object as they are, at the plan's next pause (a person finishes the
        move they are in, then re-aims)."""
        t = env.t + 0.02
        k = int(np.searchsorted(self.times, t, side="right"))
        while k < len(self.times) and not (
            self.times[k] > max(t, self.times[k - 1]) + 0.05
            and np.allclose(self.poses[k - 1], self.poses[k])
            and np.allclose(self.palm_positions[k - 1], self.palm_positions[k])
        ):
            k += 1  # (a pause: two equal keyframes, the fingers' pose and the palm's place alike, not over yet)
        if k >= len(self.times):
            return
        at = max(t, float(self.times[k - 1]) + 1e-3)
        start = (self.keyframe_angles([at])[0], self._keyframes([at], self.palm_positions)[0])
        self.replanned += 1
        fresh = self.planner.plan(env, seed=self.seed + 7919 * self.replanned, start=start)
        try:
            done = into.splice(at, fresh)
        except ValueError:  # (this plan performed directly: never, the pause was found above)
            done = None
        if done is None:
            self.replanned -= 1  # too late for that pause: the next look tries the next one
            return
        if into is not self:
            self.splice(done, fresh)
        self.adopt(fresh, done)
