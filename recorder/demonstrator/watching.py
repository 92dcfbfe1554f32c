"""A wearer who watches the robot hand close on an object (HandGrasp, HandPinch), as a person at the operator view
does: they close until the robot's pads meet the object, close a finger further that stopped short of it (which
also re-centres a pinch whose object sits nearer one pad), and squeeze harder when they see the object sink in the
grip as it is lifted. Through the glove, what they correct is whatever the fused pose got wrong.

What the wearer sees is the simulator's state a person's visual delay later and with a person's precision:

- **visual feedback delay**, 150-250 ms, drawn per take: the time from what the eye sees to a corrective
  movement (Keele & Posner 1968, "Processing of visual feedback in rapid movements": 190-260 ms; Carlton 1981,
  "Processing visual feedback information for movement control": corrections from 135 ms on). It includes the
  reaction, so a correction starts as soon as the delayed sight calls for it;
- **judging a gap** to about a millimetre (``gap_sd_mm`` 1.0; a gap under ``touch_mm``, 1.5 mm, looks closed): the
  operator view frames the workspace at about a millimetre per pixel, and a person resolves a one-pixel gap at a
  screen's distance (visual acuity, 1 arc minute, is 0.2 mm at 60 cm: finer than a pixel);
- **a slip** is seen as the object sinking 3 mm in the grip (``slip_mm``), as a gap is;
- **a correction** is a small submovement (Meyer et al. 1988): 150-250 ms, at most ``corrections`` times a take.
  A digit seen stopped short of the object (or beside it: the thumb's fused abduction can be 10 degrees off, a
  heading the glove's accelerometers cannot see) is moved toward it: its joints turned by what takes the robot's
  fingertip along the seen gap, plus ``squeeze_mm`` into the object (a damped least-squares step through the
  robot's joint map, as a person steers the finger they see). A slip is met by a sixth more of the whole grip's
  closing. The next look comes a visual delay after the correction ends, so that the wearer sees what it did before
  correcting again.

The open-loop wearer, who closes as planned and never looks, stays selectable (``make_demonstrator(...,
watches=False)``, `gloverec record --open-loop`), so that a benchmark measures what watching is worth.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from envs.tasks import postures
from recorder import quat
from recorder.hand.kinematics import JOINTS, interpolate_dip

MOVING_S, MOVING_MM = 0.15, 0.5  # a digit whose gap shrank this much over this long is seen moving


@dataclass(frozen=True)
class SightConfig:
    delay_s: tuple = (0.15, 0.25)  # visual feedback delay, drawn per take
    gap_sd_mm: float = 1.0  # a gap's judgement error, standard deviation (each axis of where it is, too)
    touch_mm: float = 1.5  # a gap under this looks closed
    slip_mm: float = 3.0  # the object sunk this far in the grip since it was gripped looks like a slip
    squeeze_mm: float = 3.0  # a digit short of the object is moved this far past where it would touch it
    most_deg: float = 20.0  # one correction turns a joint at most this far
    step: float = 1 / 6  # a slip: the grip closed this share of its planned closing move further
    correct_s: tuple = (0.15, 0.25)  # one correction's duration
    corrections: int = 4  # at most this many corrections a take


class GripWatcher:
    """Watches a grip on ``env``'s object: ``digits`` (thumb first) must touch it, each steered onto it when it does
    not; a slip is met by closing the whole grip further along ``closing`` ((20,) rad: the plan's move from open to
    closed). Looks from ``from_s`` (the plan's close done) until ``until_s`` (a meant release: a person who lets go
    does not correct it). ``made``: the corrections, as lines (a take's record)."""

    def __init__(self, digits, closing, from_s: float, rng: np.random.Generator, sight: SightConfig = SightConfig(),
                 until_s: float = np.inf):  # fmt: skip
        self.digits, self.sight, self.rng = tuple(digits), sight, rng
        self.closing = np.asarray(closing, float)
        self.from_s, self.until_s = from_s, until_s
        self.delay = float(rng.uniform(*sight.delay_s))
        self.seen: deque = deque()  # (t, {digit: (gap mm, to the object (3,) m, palm frame)}, sink mm), oldest first
        self.past: deque = deque()  # ... and what the wearer saw over the last MOVING_S
        self.busy_until = from_s
        self.gripped_sink = None  # the object's depth in the grip once every digit touched it
        self.made: list[str] = []

    def look(self, env) -> tuple | None:
        """Note the scene now; what the wearer sees of it now (the note a visual delay old), or None yet."""
        sd = self.sight.gap_sd_mm
        gaps = env.distal_gaps(env.object_geom)
        palm, turn = env.palm_pose()
        seen = {}
        for d in self.digits:
            gap, to = gaps[d]
            to = quat.rotate(quat.conj(turn), to + self.rng.normal(0.0, sd * 1e-3, 3))
            seen[d] = (1000 * gap + self.rng.normal(0.0, sd), to)
        self.seen.append((env.t, seen, 1000 * (palm[2] - env.object_pose()[2])))
        sight = None
        while self.seen and self.seen[0][0] <= env.t - self.delay:
            sight = self.seen.popleft()
            self.past.append(sight)
        while self.past and self.past[0][0] < env.t - self.delay - MOVING_S:
            self.past.popleft()
        return sight

    def moving(self, digit: str) -> bool:
        """Whether ``digit`` is seen still closing on the object (its gap shrank over the last ``MOVING_S`` seen): a
        person waits for a finger to stop before judging it short (a robot's servo lags the command)."""
        return len(self.past) > 1 and self.past[0][1][digit][0] - self.past[-1][1][digit][0] > MOVING_MM

    def __call__(self, motion, env, into) -> None:
        sight = self.look(env)
        t = env.t
        if sight is None or t < self.busy_until or t >= self.until_s or len(self.made) >= self.sight.corrections:
            return
        seen_t, seen, sink = sight
        if seen_t < self.from_s:
            return
        c = self.sight
        # closing until every digit is seen on the object; then only holding it, watching for a slip
        short = [] if self.gripped_sink is not None else [d for d in self.digits if seen[d][0] > c.touch_mm]
        if any(self.moving(d) for d in short):
            return  # a digit still closing: judged once it stops
        if short:
            pose = motion.keyframe_angles([t])[0]
            delta = sum(steer(env.robot.config.name, pose, d, seen[d][1], c) for d in short)
            why = "moved " + ", ".join(short) + " onto the object"
        elif self.gripped_sink is None:
            self.gripped_sink = sink
            return
        elif max(g for g, _ in seen.values()) > c.touch_mm:
            self.until_s = t  # the object is out of the grip: nothing left to correct with the fingers alone
            return
        elif sink - self.gripped_sink > c.slip_mm:
            why, delta = "squeezed (it slipped)", c.step * self.closing
            self.gripped_sink = sink
        else:
            return
        took = float(self.rng.uniform(*c.correct_s))
        try:
            at = into.revise(t, took, pose_delta=delta)
        except ValueError:  # in a move of the plan (a free wrist's lift): the next look, once it holds
            return
        if at is None:
            return  # too late for whoever performs it: as planned
        if into is not motion:
            motion.revise(at, took, pose_delta=delta)  # the plan's own copy, when a performer made it
        self.busy_until = at + took + self.delay
        self.until_s += took
        self.made.append(f"{why} at {at:.2f} s")


DIGIT_JOINTS = {
    d: [k for k, n in enumerate(JOINTS) if n.startswith(f"{d}_") and not n.endswith("_dip")]
    for d in ("thumb", "index", "middle", "ring", "pinky")
}  # fmt: skip  (a DIP follows its PIP)


def steer(robot: str, pose, digit: str, to, c: SightConfig) -> np.ndarray:
    """The turn of ``digit``'s joints ((20,) rad, the others 0) that takes the robot's fingertip by ``to`` (3, m,
    palm frame) and ``c.squeeze_mm`` further along it, at the wearer's ``pose``: a damped least-squares step through
    the robot's joint map (the fingertip's Jacobian by finite differences), each joint at most ``c.most_deg``."""
    joints, tip = DIGIT_JOINTS[digit], postures.retargeter(robot).fingers.index(digit)
    h = np.radians(1.0)
    at = postures.robot_tips(robot, interpolate_dip(pose))[tip]
    jac = np.empty((3, len(joints)))
    for i, k in enumerate(joints):
        moved = pose.copy()
        moved[k] += h
        jac[:, i] = (postures.robot_tips(robot, interpolate_dip(moved))[tip] - at) / h
    to = np.asarray(to, float)
    want = to + c.squeeze_mm * 1e-3 * to / max(float(np.linalg.norm(to)), 1e-6)
    damping = 0.005**2  # m^2: a joint that hardly moves the tip is not turned far for it
    turn = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(3), want)
    out = np.zeros(len(JOINTS))
    out[joints] = np.clip(turn, -np.radians(c.most_deg), np.radians(c.most_deg))
    return out
