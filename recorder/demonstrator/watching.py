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
  A digit short of the object is closed by as much more as it needs, judged from what the plan's closing did to
  its gap (a person who saw the thumb come 20 mm and stop 5 mm short closes it a quarter as far again), plus
  ``squeeze_mm``; a slip is met by a sixth more of the whole grip's closing. The next look comes a visual delay
  after the correction ends, so that the wearer sees what it did before correcting again.

The open-loop wearer, who closes as planned and never looks, stays selectable (``make_demonstrator(...,
watches=False)``, `gloverec record --open-loop`), so that a benchmark measures what watching is worth.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from recorder.hand.kinematics import JOINTS

MOVING_S, MOVING_MM = 0.15, 0.5  # a digit whose gap shrank this much over this long is seen moving


@dataclass(frozen=True)
class SightConfig:
    delay_s: tuple = (0.15, 0.25)  # visual feedback delay, drawn per take
    gap_sd_mm: float = 1.0  # a gap's judgement error, standard deviation
    touch_mm: float = 1.5  # a gap under this looks closed
    slip_mm: float = 3.0  # the object sunk this far in the grip since it was gripped looks like a slip
    squeeze_mm: float = 2.0  # a digit short of the object is closed this far past where it would touch it
    step: float = 1 / 6  # a slip: the grip closed this share of its planned closing move further
    most: float = 0.6  # one correction closes a digit at most this share of its planned closing move further
    correct_s: tuple = (0.15, 0.25)  # one correction's duration
    corrections: int = 4  # at most this many corrections a take


class GripWatcher:
    """Watches a grip on ``env``'s object: ``digits`` (thumb first) must touch it, each closed further along
    ``closing`` ((20,) rad: the plan's move from open to closed, its joints of that digit) when it does not. Looks
    from ``from_s`` (the plan's close done) until ``until_s`` (a meant release: a person who lets go does not
    correct it). ``made``: the corrections, as lines (a take's record)."""

    def __init__(self, digits, closing, close_s: float, from_s: float, rng: np.random.Generator,
                 sight: SightConfig = SightConfig(), until_s: float = np.inf):  # fmt: skip
        """``close_s``: when the plan starts closing (the gaps then: how far the closing moves each digit)."""
        self.digits, self.sight, self.rng = tuple(digits), sight, rng
        self.closing = {d: np.where([j.startswith(f"{d}_") for j in JOINTS], closing, 0.0) for d in self.digits}
        self.closed = dict.fromkeys(self.digits, 1.0)  # how much of ``closing`` each digit is asked for so far
        self.open_gaps = None  # the gaps seen as the plan started closing (mm)
        self.close_s, self.from_s, self.until_s = close_s, from_s, until_s
        self.delay = float(rng.uniform(*sight.delay_s))
        self.seen: deque = deque()  # (t, gaps mm, sink mm): what reached the eye, oldest first
        self.past: deque = deque()  # ... and what the wearer saw over the last MOVING_S
        self.busy_until = from_s
        self.gripped_sink = None  # the object's depth in the grip once every digit touched it
        self.made: list[str] = []

    def look(self, env) -> tuple | None:
        """Note the scene now; what the wearer sees of it now (the note a visual delay old), or None yet."""
        gaps = env.distal_gaps(env.object_geom)
        noise = self.rng.normal(0.0, self.sight.gap_sd_mm, len(self.digits))
        sink = 1000 * (env.palm_pose()[0][2] - env.object_pose()[2])
        self.seen.append((env.t, {d: 1000 * gaps[d] + n for d, n in zip(self.digits, noise)}, sink))
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
        return len(self.past) > 1 and self.past[0][1][digit] - self.past[-1][1][digit] > MOVING_MM

    def __call__(self, motion, env, into) -> None:
        sight = self.look(env)
        t = env.t
        if sight is None or t < self.busy_until or t >= self.until_s or len(self.made) >= self.sight.corrections:
            return
        seen_t, gaps, sink = sight
        if self.open_gaps is None and seen_t >= self.close_s:
            self.open_gaps = gaps
        if seen_t < self.from_s:
            return
        c = self.sight
        # closing until every digit is seen on the object; then only holding it, watching for a slip
        short = {} if self.gripped_sink is not None else {d: self._more(d, gaps[d]) for d in self.digits
                                                          if gaps[d] > c.touch_mm}  # fmt: skip
        if any(self.moving(d) for d in short):
            return  # a digit still closing: judged once it stops
        if short:
            why = "closed " + ", ".join(short) + " further"
        elif self.gripped_sink is None:
            self.gripped_sink = sink
            return
        elif max(gaps.values()) > c.touch_mm:
            self.until_s = t  # the object is out of the grip: nothing left to correct with the fingers alone
            return
        elif sink - self.gripped_sink > c.slip_mm:
            why, short = "squeezed (it slipped)", dict.fromkeys(self.digits, c.step)
            self.gripped_sink = sink
        else:
            return
        delta = sum(share * self.closing[d] for d, share in short.items())
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
        for d, share in short.items():
            self.closed[d] += share
        self.made.append(f"{why} at {at:.2f} s")

    def _more(self, digit: str, gap_mm: float) -> float:
        """How much more of its planned closing ``digit``, ``gap_mm`` short of the object, is closed: what the
        closing so far did to its gap, scaled to the gap left and the squeeze."""
        c = self.sight
        moved = (self.open_gaps[digit] - gap_mm) / self.closed[digit] if self.open_gaps is not None else 0.0
        if moved <= 1.0:  # it hardly moved (or was not seen open): a sixth more, and look again
            return c.step
        return float(np.clip((gap_mm + c.squeeze_mm) / moved, c.step / 2, c.most))
