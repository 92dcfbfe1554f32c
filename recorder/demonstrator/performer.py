"""Performer: the emulated wearer performing demonstrations. It wears the emulated glove (``--glove emulator``,
recorder/emulator/source.py) and moves it with one continuous SessionMotion: each demonstration is appended as the
recording loop asks for it (``demonstrate``, the glove's button pressed as it starts), a demonstrator that watches
corrects what is still ahead (``revise``), and where the wearer's palm is as performed is known (``performed``:
what an emulated camera films). Faster than real time, it keeps the emulator a short lead ahead of the loop, so
that no motion is synthesised before the loop has scheduled it.
"""

from __future__ import annotations

import threading

from recorder import GloverecError
from recorder.demonstrator.session import SessionMotion
from recorder.emulator.emulator import FAST_BLOCK_S
from recorder.glove.config import EMULATOR, GloveConfig
from recorder.glove.glove import make_glove
from recorder.hand.kinematics import interpolate_dip

TRANSITION_S = 0.8  # the emulated hand's move back to a demonstration's start pose
LEAD_S = 0.5  # faster than real time, the emulator runs at most this far ahead of the loop's needs
WATCHING_LEAD_S = 0.05  # ... or this far, in blocks this long, while a demonstrator that watches performs (its
# corrections come a reaction time, 0.1-0.3 s, after what it saw: further ahead, the emulator would have
# synthesised past them)


def performs(config: GloveConfig) -> bool:
    """Whether a performer wears the glove ``config`` names: the emulator, its motion demonstrations or unset."""
    return config.kind == EMULATOR and (config.motion or "demonstrations") == "demonstrations"


class _TakenMotion:
    """The session motion as the emulator takes it, block by block, under a lock that ``demonstrate`` holds too:
    a demonstration then starts after the last block taken, never inside a block being synthesised (which would
    make the hand jump: harmless for poses, a saturated gyro for raw frames)."""

    def __init__(self, motion: SessionMotion):
        self.motion = motion
        self.rate_hz = motion.rate_hz
        self.lock = threading.Lock()
        self.taken = 0  # samples the emulator took

    @property
    def taken_s(self) -> float:
        """Session time of the first sample not taken yet."""
        return self.taken / self.rate_hz

    def next_block(self, n: int):
        with self.lock:
            self.taken += n
            return self.motion.next_block(n)

    def at(self, t):
        return self.motion.at(t)


class Performer:
    """See the module docstring. ``config``: the emulated glove (``performs(config)``); ``fast`` and
    ``glove_options``: as Glove's. ``glove``: the Glove it wears, not open yet (the recording loop opens, reads and
    closes it)."""

    def __init__(self, config: GloveConfig, *, fast: bool = False, **glove_options):
        if not performs(config):
            raise GloverecError("only the emulated glove with motion=demonstrations performs demonstrations")
        self.session = SessionMotion(seed=config.seed, rate_hz=config.rate_hz)  # the demonstrations performed
        self._motion = _TakenMotion(self.session)
        self._demo_start = 0.0  # session time of the demonstration being performed
        self._lead_s = LEAD_S  # how far ahead a fast emulator may synthesise
        # the wearer rests in the session's first pose (where fusion starts), not the flat hand
        rest = interpolate_dip(self.session.keyframe_angles([0.0]))[0]
        self.glove = make_glove(config, fast=fast, motion="demonstrations", wearer=self._motion, rest_angles=rest,
                                **glove_options)  # fmt: skip
        self.emulator = self.glove.source.emulator  # recorder/emulator/source.py EmulatedLink
        if fast:  # demonstrations are scheduled as the loop goes: the emulator waits for them
            self.emulator.lead_s = LEAD_S
            self.glove.before_wait = self._allow

    def demonstrate(self, demo, lead_s: float = 0.0) -> None:
        """Have the emulated hand perform ``demo`` next; its glove presses the button as the demo starts."""
        hold = self.glove.fusion.hold_until_s  # host fusion starts on a resting hand
        with self._motion.lock:
            start = max(self._motion.taken_s, hold) + TRANSITION_S + lead_s
            self.session.append(demo, start, TRANSITION_S)
        self._demo_start = start
        self._lead_s = WATCHING_LEAD_S if demo.watches else LEAD_S
        self.emulator.fast_block_s = WATCHING_LEAD_S if demo.watches else FAST_BLOCK_S
        self.emulator.schedule_button(start)

    def revise(self, at_s: float, duration_s: float, palm_delta=(0.0, 0.0, 0.0), move=(0.0, 0.0, 0.0),
               pose_delta=None) -> float | None:  # fmt: skip
        """The demonstration being performed corrects itself (DemoMotion.revise, ``at_s`` in its own time): in the
        session's time, and never before what the emulator has synthesised already. Returns when it starts, in
        the demonstration's time (``at_s`` or later), so that the plan's copy makes the same correction; None when
        that is too late: the hold it belonged to is over (the correction is dropped, the demonstration goes on as
        planned)."""
        return self._change(at_s, lambda at: self.session.revise(at, duration_s, palm_delta, move, pose_delta))

    def splice(self, at_s: float, plan) -> float | None:
        """The demonstration being performed goes on as ``plan`` from ``at_s`` (DemoMotion.splice: a plan made from
        the state it found), in the session's time and never before what the emulator has synthesised already;
        returns when, in the demonstration's time, or None when that is no longer in the hold it was meant for."""
        return self._change(at_s, lambda at: self.session.splice(at, plan))

    def _change(self, at_s: float, change) -> float | None:
        """``change(at)`` of the session's motion at the demonstration's ``at_s`` in session time, never before
        what the emulator has synthesised already; when it happened in the demonstration's time, or None where
        that is no longer in a hold (DemoMotion's ValueError)."""
        with self._motion.lock:
            at = max(self._demo_start + at_s, self._motion.taken_s + 1.0 / self._motion.rate_hz)
            try:
                return change(at) - self._demo_start
            except ValueError:
                return None

    def performed(self, t: float):
        """The emulated wearer's palm at glove time ``t`` as the emulator performs it (the session's motion, the
        palm's drift included: what its IMUs measure), as (position (3,), quat (4,)) in the world; faster than
        real time only (``fast``: glove time is the emulator's device clock)."""
        if not self.glove.fast:
            raise GloverecError("only the emulated glove, faster than real time, knows where its wearer's palm is")
        b = self.session.at([self._session_time(t)])
        return b.palm_pos[0], b.palm_quat[0]

    def _allow(self, t: float) -> None:
        """Before the loop waits for glove time ``t``: the emulator may synthesise up to it and the lead beyond (from
        the hand's rest, after which host fusion shows its first pose)."""
        fusion = self.glove.fusion
        hold = fusion.hold_until_s if not fusion.started else 0.0
        self.emulator.allow(max(self._session_time(t), hold) + self._lead_s)

    def _session_time(self, t: float) -> float:
        """The emulator's session time of glove time ``t`` (fast: its device clock, unwrapped from t0)."""
        t0 = self.emulator.t0_us
        return t - t0 * 1e-6 if t0 is not None else 0.0
