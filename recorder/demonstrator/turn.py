"""HandTurn demonstrator: while the base descends, the thumb and middle finger open wider than the knob (the others
straight, out of the way); once the base has stopped and after a human reaction time they close on
the knob's rim and squeeze; then the palm turns about the knob's axis by the target angle (minimum jerk, a small
aiming error), holds, and the fingers open again to let go. The grip postures are the robot's thumb-middle pinch
(envs.tasks.hand_pinch.robot_pinch), as the operator sees the robot's fingertips. Varies timing, speed, aperture,
squeeze, aim and posture between demos."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from envs.tasks.hand_pinch import robot_pinch
from envs.tasks.hand_turn import GRIP_FINGER
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.pinch import pinch_pose
from recorder.hand.gestures import GESTURES


@dataclass(frozen=True)
class TurnDemoConfig:
    preshape_s: tuple = (0.35, 0.5)
    aperture_mm: tuple = (16, 24)  # the open grip: this much wider than the knob
    squeeze_mm: tuple = (5, 8)  # the closed grip: this much narrower (the knob stops the fingers)
    robot_squeeze_mm: dict = field(default_factory=lambda: {"shadow": (12, 15)})  # the hands whose servos need more
    reaction_s: tuple = (0.1, 0.3)  # after the base has stopped
    close_s: tuple = (0.4, 0.6)
    settle_s: tuple = (0.1, 0.25)  # gripped, before turning
    turn_deg_per_s: tuple = (70.0, 110.0)  # the palm's mean turning speed
    aim_deg: float = 2.0  # the turn's error, uniform in ±
    lead: tuple = (1.0, 1.08)  # the palm turns this much further than the knob must (the grip gives a little)
    hold_s: tuple = (0.6, 0.8)  # at the target, before letting go
    # watching the knob: after the turn, an error beyond ``watch_deg`` is turned away (a reaction time later, over
    # ``correct_s``), at most ``corrections`` times; the fingers let go once it has sat at the mark for ``hold_s``
    watch_deg: float = 3.0
    correct_s: tuple = (0.25, 0.4)
    corrections: int = 3
    release_s: tuple = (0.3, 0.45)
    pose_noise_deg: float = 1.5
    palm_deg: float = 1.0
    rate_hz: float = 200.0

    def squeeze_for(self, robot: str) -> tuple:
        return self.robot_squeeze_mm.get(robot, self.squeeze_mm)


class TurnDemonstrator:
    task = "turn"

    def __init__(self, config: TurnDemoConfig = TurnDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None, share: float = 1.0, tremor_deg: float = 0.05) -> DemoMotion:
        """``share``: how much of the target the wearer turns (a wearer's mistake: less than 1, unwatched)."""
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)
        robot, width = env.robot.config.name, env.grip_gap_mm()
        aperture = int(rng.integers(c.aperture_mm[0], c.aperture_mm[1] + 1))
        lo, hi = c.squeeze_for(robot)
        squeeze = int(rng.integers(lo, hi + 1))
        # both about the grip that spans the knob (the task's pivot): the fingertips open and close around its axis
        open_p = robot_pinch(robot, GRIP_FINGER, width + aperture, width)[0]
        closed_p = robot_pinch(robot, GRIP_FINGER, max(0, width - squeeze), width)[0]
        noise = np.clip(rng.normal(0, 1, 6), -2, 2) * c.pose_noise_deg
        start = GESTURES["open"]
        opened = pinch_pose(GRIP_FINGER, np.array(open_p) + noise, start)
        closed = pinch_pose(GRIP_FINGER, np.array(closed_p) + noise, start)
        turn = env.target * rng.uniform(*c.lead) * share + np.radians(rng.uniform(-c.aim_deg, c.aim_deg))
        t_pre = rng.uniform(0.05, 0.2)
        t_open = t_pre + rng.uniform(*c.preshape_s)
        t_close = env.schedule["grip"] + rng.uniform(*c.reaction_s)
        t_closed = t_close + rng.uniform(*c.close_s)
        t_turn = t_closed + rng.uniform(*c.settle_s)
        t_turned = t_turn + abs(np.degrees(turn)) / rng.uniform(*c.turn_deg_per_s) + 0.3
        t_let = t_turned + rng.uniform(*c.hold_s)
        t_free = t_let + rng.uniform(*c.release_s)
        # letting go wider than the approach: thick fingertips clear the rim of a knob turned under them
        free_p = robot_pinch(robot, GRIP_FINGER, width + aperture + 10, width)[0]
        freed = pinch_pose(GRIP_FINGER, np.array(free_p) + noise, start)
        end = max(t_free, env.config.episode_s) + 1.0
        times = [0.0, t_pre, t_open, t_close, t_closed, t_turn, t_turned, t_let, t_free, end]
        poses = [start, start, opened, opened, closed, closed, closed, closed, freed, freed]
        z = np.array([0.0, 0.0, 1.0])
        turns = [0 * z] * 6 + [turn * z] * 4
        limit = env.config.max_base_angle_deg - 5.0
        motion = TurnMotion(times, poses, rng, c, t_turned, t_let, palm_turns=turns, max_turn_deg=limit,
                            tremor_deg=tremor_deg)  # fmt: skip
        if share < 1.0:
            motion.busy_until = np.inf  # turned short and let go as planned: it does not look again
        return motion


class TurnMotion(DemoMotion):
    """The turn demonstration, watching the knob: once the palm's turn is over, the wearer looks at the pointer and
    turns away what is left (the grip gives, closing it may have nudged the knob), and lets go only after it has sat
    at the mark for a while."""

    watches = True

    def __init__(self, times, poses, rng, config: TurnDemoConfig, turned_s: float, let_go_s: float, palm_turns,
                 max_turn_deg: float, tremor_deg: float = 0.05):  # fmt: skip
        super().__init__(times, poses, rng, config.rate_hz, palm_deg=config.palm_deg, palm_turns=palm_turns,
                         tremor_deg=tremor_deg)  # fmt: skip
        self.config, self.rng = config, rng
        self.turned_s, self.let_go_s = turned_s, let_go_s
        self.busy_until = turned_s + rng.uniform(*config.reaction_s)  # the first look
        self.at_mark_since = None
        self.corrections = 0
        self.max_turn_deg = max_turn_deg

    def watch(self, env, into=None) -> None:
        into = self if into is None else into
        c, t = self.config, env.t
        if t < self.busy_until or t >= self.let_go_s:
            return
        err = env.error_deg()
        if abs(err) <= c.watch_deg:
            self.at_mark_since = t if self.at_mark_since is None else self.at_mark_since
        else:
            self.at_mark_since = None
            if self.corrections < c.corrections:  # turn it away, a reaction time after seeing it
                self._revise(into, t + self.rng.uniform(*c.reaction_s), self.rng.uniform(*c.correct_s),
                             np.radians(-err))  # fmt: skip
                self.corrections += 1
                return
        # about to let go: not before it has sat at the mark for hold_s
        settled = self.at_mark_since is not None and t - self.at_mark_since >= c.hold_s[0]
        if t >= self.let_go_s - 0.1 and not settled:
            self._revise(into, t + 0.05, 0.2, 0.0)

    def _revise(self, into, at_s: float, duration_s: float, turn: float) -> None:
        at_s = min(at_s, self.let_go_s - 1e-3)  # in the hold before letting go
        limit = np.radians(self.max_turn_deg)  # no further than the wearer's forearm turns
        now = float(self._keyframes([at_s], self.palm_turns)[0, 2])
        turn = float(np.clip(now + turn, -limit, limit) - now)
        at_s = into.revise(at_s, duration_s, (0.0, 0.0, turn))
        if at_s is None:
            return  # too late: what is performed is past that hold
        if into is not self:
            self.revise(at_s, duration_s, (0.0, 0.0, turn))  # this plan's own copy, when the performer made it
        self.let_go_s += duration_s
        self.busy_until = at_s + duration_s + self.rng.uniform(*self.config.reaction_s)
