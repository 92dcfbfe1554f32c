"""The human-like demonstrator (`--demonstrator human`): a person's takes rather than a script's, for the tasks a
person does with the fingers alone (HandPose, HandGrasp, HandPinch). It plans like the task's scripted demonstrator,
then moves the plan toward how people move, with figures from the motor-control literature:

- **reaction time** before each move a person starts on seeing something (the goal gesture shown, the hand come to
  rest over the object): visual simple reaction time, 250 ms mean, 40 ms spread, cut to 180-400 ms (Luce 1986,
  "Response Times", ch. 2; Welford 1980: 200-300 ms for visual stimuli);
- **speed variability**: each move's duration scaled by a log-normal factor, coefficient of variation 15 % (the
  trial-to-trial variability of movement time in aimed movements; Schmidt et al. 1979 report 10-20 %);
- **overshoot and correction**: a fast aimed move often overshoots and is corrected by a second, smaller
  submovement (Meyer et al. 1988, optimized submovement model): in half the large moves the hand goes 5-15 % of the
  move past its target and comes back in 150-250 ms;
- **hesitation**: in a fifth of the large moves the hand stops partway (40-60 %) for 100-250 ms, then goes on;
- **physiological tremor**: 8-12 Hz at the fingers, a few tenths of a degree (Elble & Koller 1990, "Tremor"):
  0.3 deg per joint here (the scripted demonstrator: 0.05);
- **two strategies** for the same task: the fingers and thumb together, or the thumb first (grasp, pinch) / last
  (pose);
- **failed takes** at ``failure_rate`` (default 15 %), of the kinds people make: HandGrasp "too loose" (a grip 45 %
  of the way closed, which the lift pulls out) or "lets go" (the hand opens during the lift); HandPinch "too loose"
  or "wrong finger" (the other finger the task draws from opposes the thumb); HandPose "stops
  short" (60 % of the way to the gesture) or "wrong gesture" (the instruction misread: the gesture least like the
  one asked for; also where stopping short of a gesture near the open hand would still show it).

Each plan says what it intended (``motion.intent``: strategy, failure or None, and the edits made), so a benchmark
and the recorder's episode records can tell a meant failure from an unlucky one. Seeded: the same seed gives the
same take.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from recorder.demonstrator.grasp import GraspDemonstrator
from recorder.demonstrator.keys import KeysDemoConfig, KeysDemonstrator
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.pick import PickDemoConfig, PickDemonstrator
from recorder.demonstrator.pinch import PinchDemonstrator
from recorder.demonstrator.pose import PoseDemoConfig, PoseDemonstrator
from recorder.demonstrator.relocate import RelocateDemoConfig, RelocateDemonstrator
from recorder.demonstrator.turn import TurnDemoConfig, TurnDemonstrator
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS

THUMB = np.array([name.startswith("thumb") for name in JOINTS])
LARGE_RAD = np.radians(15.0)  # a move this large (its largest joint) can overshoot or hesitate


@dataclass(frozen=True)
class HumanConfig:
    failure_rate: float = 0.15
    reaction_s: tuple = (0.25, 0.04, 0.18, 0.40)  # mean, sd, shortest, longest
    speed_cv: float = 0.15
    overshoot_p: float = 0.5
    overshoot: tuple = (0.05, 0.15)  # of the move's amplitude
    correction_s: tuple = (0.15, 0.25)
    hesitate_p: float = 0.2
    hesitate_at: tuple = (0.4, 0.6)
    hesitate_s: tuple = (0.1, 0.25)
    tremor_deg: float = 0.3
    loose: float = 0.45  # "too loose": this much of the way from open to the grasp
    aim_mm: float = 5.0  # a free wrist: a reach's endpoint error, standard deviation, each horizontal axis
    place_mm: float = 8.0  # ... and a carry's (relocate), before the wearer looks and nudges it
    short_carry: float = 0.4  # relocate "misplaces": the carry goes this share of the way, unwatched
    short: float = 0.6  # "stops short": this much of the way to the gesture


def reaction(rng: np.random.Generator, c: HumanConfig) -> float:
    mean, sd, lo, hi = c.reaction_s
    return float(np.clip(rng.normal(mean, sd), lo, hi))


def duration(rng: np.random.Generator, c: HumanConfig, span: tuple) -> float:
    """A move's duration: the middle of the scripted range, scaled log-normally (``speed_cv``)."""
    return float(np.mean(span) * rng.lognormal(0.0, c.speed_cv))


def failure(rng: np.random.Generator, c: HumanConfig, kinds: tuple) -> str | None:
    return str(rng.choice(kinds)) if rng.random() < c.failure_rate else None


def take(seed, h: HumanConfig, kinds: tuple, strategies: tuple):
    """A take's first draws, in this order: (its generator, a generator for the scripted plan's own draws, the
    meant failure or None, the strategy, the reaction time)."""
    rng = np.random.default_rng(seed)
    sub = np.random.default_rng(rng.integers(2**32))
    fails = failure(rng, h, kinds)
    strategy = str(rng.choice(strategies))
    return rng, sub, fails, strategy, reaction(rng, h)


class MeantFailures:
    """What a human-like demonstrator says of a take before planning it: ``meant_failure(seed)``, the mistake the take
    of ``seed`` is meant to make (one of ``kinds``) or None, drawn as ``plan`` draws it (``take``'s first draws), so
    a caller can count a plan set's meant failures without planning the takes."""

    kinds: tuple = ()
    human: HumanConfig

    def meant_failure(self, seed: int) -> str | None:
        return take(seed, self.human, self.kinds, ("",))[2]


def humanize(m: DemoMotion, rng: np.random.Generator, c: HumanConfig, until: float = np.inf) -> list[str]:
    """Overshoot-and-correct and hesitate in the large moves of ``m`` that end before ``until`` and are followed by
    a hold long enough to take the extra time; the edits made."""
    edits = []
    k = 0
    while k + 2 < len(m.times):
        a, b, hold = m.poses[k], m.poses[k + 1], m.times[k + 2] - m.times[k + 1]
        large = np.max(np.abs(b - a)) > LARGE_RAD and m.times[k + 1] < until
        follows_hold = np.allclose(m.poses[k + 1], m.poses[k + 2])
        u = rng.random() if large and follows_hold else 1.0  # one draw: overshoot, hesitate, or neither
        if u < c.overshoot_p:
            back = rng.uniform(*c.correction_s)
            if hold > back + 0.05:
                t = m.times[k + 1]
                m.insert(t + back, b)  # the correction: back onto the target ...
                m.insert(t, b + rng.uniform(*c.overshoot) * (b - a), replace=True)  # ... from past it
                edits.append(f"overshoot at {t:.2f} s")
                k += 1
        elif u < c.overshoot_p + c.hesitate_p:
            pause, s = rng.uniform(*c.hesitate_s), rng.uniform(*c.hesitate_at)
            t0, t1 = m.times[k], m.times[k + 1]
            if hold > pause + 0.05:
                mid = a + s * (b - a)  # partway (in joint space; the minimum-jerk halves keep it smooth) ...
                m.times[k + 1] = t1 + pause  # ... the move then ends ``pause`` later, eating into the hold
                m.insert(t0 + s * (t1 - t0), mid)
                m.insert(t0 + s * (t1 - t0) + pause, mid)
                edits.append(f"hesitation at {t0 + s * (t1 - t0):.2f} s")
                k += 2
        k += 1
    return edits


def staged(m: DemoMotion, t0: float, t1: float, thumb_first: bool) -> None:
    """The move that ends at keyframe ``t1`` (from ``t0``) done in two: the thumb first (or last), then the rest."""
    k = int(np.searchsorted(m.times, t1))
    a, b = m.poses[k - 1], m.poses[k]
    mid = np.where(THUMB == thumb_first, b, a)
    m.insert(t0 + 0.5 * (t1 - t0), mid)


def pause_at(m: DemoMotion, t: float, pause: float) -> None:
    """The motion stops where it is at ``t`` (hand and palm) for ``pause`` s, then goes on; later keyframes later."""
    m.insert(t, m.keyframe_angles([t])[0])
    k = int(np.searchsorted(m.times, t)) + 1
    m.times = np.concatenate((m.times[:k], [t + pause], m.times[k:] + pause))
    for name in ("poses", "palm_positions", "palm_turns"):
        values = getattr(m, name)
        setattr(m, name, np.concatenate((values[:k], values[k - 1 : k], values[k:])))


class HumanGripDemonstrator(MeantFailures):
    """A grip task (HandGrasp, HandPinch) as a person does it: the scripted plan (``scripted``, its reaction and
    durations drawn as people's), then a strategy, the overshoots and hesitations, and the meant failure. Fingers only
    (no free wrist)."""

    scripted: type = GraspDemonstrator
    kinds: tuple = ("too loose", "lets go")

    def __init__(self, human: HumanConfig = HumanConfig(), config=None):
        self.human = human
        self.config = config if config is not None else self.scripted().config

    def _scripted_plan(self, env, config, seed: int, fails: str | None) -> DemoMotion:
        return self.scripted(config).plan(env, seed=seed)

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        env, h, c = env.unwrapped, self.human, self.config
        rng, sub, fails, strategy, r = take(seed, h, self.kinds, ("together", "thumb first"))
        config = replace(c, preshape_s=(duration(rng, h, c.preshape_s),) * 2, reaction_s=(r, r),
                         close_s=(duration(rng, h, c.close_s),) * 2)  # fmt: skip
        if env.config.base_position:  # a free wrist: the script's moves each a person's reaction late, aimed as
            rw = reaction(rng, h)  # a person aims (drawn after the fingers' draws: a fixed wrist's takes unchanged)
            config = replace(config, wrist_reaction_s=(rw, rw), aim_mm=h.aim_mm)
        planned = self._scripted_plan(env, config, int(sub.integers(2**31)), fails)
        m = DemoMotion(planned.times, planned.poses, rng, c.rate_hz, tremor_deg=h.tremor_deg,
                       palm_deg=getattr(c, "palm_deg", 3.0), palm_pos=planned.palm_positions,
                       palm_turns=planned.palm_turns)  # fmt: skip
        # watching the hand as the scripted wearer does, but for a careless take: a grip left too loose is not
        # looked at (closing it would undo the mistake), and one let go is watched only until it is
        m.watcher = None if fails == "too loose" else planned.watcher
        t_close, t_closed = m.times[3], m.times[4]
        opened, closed = m.poses[2], m.poses[4]
        if fails == "too loose":
            m.poses[4:] = opened + h.loose * (closed - opened)
        if strategy == "thumb first":
            staged(m, t_close, t_closed, thumb_first=True)
        edits = humanize(m, rng, h, until=env.schedule["lift"])
        if fails == "lets go":
            t = env.schedule["lift"] + rng.uniform(0.3, 0.6)
            m.insert(t, m.keyframe_angles([t])[0])
            m.insert(t + rng.uniform(0.3, 0.5), GESTURES["open"])
            if m.watcher is not None:
                m.watcher.until_s = t
        m.intent = {"demonstrator": "human", "strategy": strategy, "failure": fails, "edits": edits}
        if m.watcher is not None:
            m.intent["corrections"] = m.watcher.made  # filled in as the take is performed
        return m


class HumanGraspDemonstrator(HumanGripDemonstrator):
    task = "grasp"


class HumanPinchDemonstrator(HumanGripDemonstrator):
    """HandPinch: the mistakes are a pinch too loose, or with the wrong finger (the other one the task draws from;
    too loose where the robot's thumb reaches only one)."""

    task = "pinch"
    scripted = PinchDemonstrator
    kinds = ("too loose", "wrong finger")

    def _scripted_plan(self, env, config, seed: int, fails: str | None) -> DemoMotion:
        others = [f for f in env.fingers if f != env.finger]
        if fails == "wrong finger" and others:
            return self.scripted(config).plan(env, seed=seed, finger=others[0])
        return self.scripted(config).plan(env, seed=seed)


class HumanPoseDemonstrator(PoseDemonstrator, MeantFailures):
    """HandPose as a person shows a gesture: see module docstring."""

    kinds = ("stops short", "wrong gesture")

    def __init__(self, human: HumanConfig = HumanConfig(), config: PoseDemoConfig = PoseDemoConfig()):
        super().__init__(config)
        self.human = human

    def meant_failure(self, seed: int) -> str | None:
        """As MeantFailures says; "stops short" becomes "wrong gesture" in the plan where the goal is this close to
        the open hand that stopping short would still show it."""
        return failure(np.random.default_rng(seed), self.human, self.kinds)

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        env, h, c = env.unwrapped, self.human, self.config
        rng = np.random.default_rng(seed)
        fails = failure(rng, h, self.kinds)
        strategy = str(rng.choice(("together", "thumb last")))
        noise = np.clip(rng.normal(0, 1, len(env.goal_angles)), -2, 2) * np.radians(c.pose_noise_deg)
        start, goal = GESTURES["open"], env.goal_angles + noise
        missed = (1.0 - h.short) * np.max(np.abs(goal - start))
        if fails == "stops short" and missed < 2 * np.radians(env.config.tolerance_deg):
            fails = "wrong gesture"  # a gesture this close to the open hand: stopping short would still show it
        if fails == "stops short":
            goal = start + h.short * (goal - start)
        elif fails == "wrong gesture":  # the instruction misread: the gesture least like the one asked for
            goal = max(GESTURES.values(), key=lambda g: float(np.max(np.abs(g - env.goal_angles)))) + noise
        t0 = reaction(rng, h)
        t1 = t0 + duration(rng, h, c.move_s)
        end = max(t1, env.config.episode_s) + 1.0
        m = DemoMotion([0.0, t0, t1, end], [start, start, goal, goal], rng, c.rate_hz, tremor_deg=h.tremor_deg)
        if strategy == "thumb last":
            staged(m, t0, t1, thumb_first=False)
        edits = humanize(m, rng, h)
        m.intent = {"demonstrator": "human", "strategy": strategy, "failure": fails, "edits": edits}
        return m


class HumanKeysDemonstrator(MeantFailures):
    """HandKeys as a person plays the sequence: each press a reaction time after its key lights (drawn per take),
    presses and releases at a person's varying speed, tremor, overshoot and hesitation; quick taps or deliberate
    presses; the mistakes: a press "too light" to register (the wearer goes on to the next key, unlit) or the "wrong
    finger" (its neighbour presses its own key)."""

    task = "keys"
    kinds = ("too light", "wrong finger")

    def __init__(self, human: HumanConfig = HumanConfig(), config: KeysDemoConfig = KeysDemoConfig()):
        self.human, self.config = human, config

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        env, h, c = env.unwrapped, self.human, self.config
        rng, sub, fails, strategy, r = take(seed, h, self.kinds, ("quick taps", "deliberate presses"))
        hold = c.hold_s if strategy == "quick taps" else tuple(2.5 * x for x in c.hold_s)
        config = replace(c, reaction_s=(r, r + 0.05), press_s=(duration(rng, h, c.press_s),) * 2, hold_s=hold,
                         release_s=(duration(rng, h, c.release_s),) * 2)  # fmt: skip
        mistake = (fails, int(rng.integers(len(env.sequence)))) if fails else None
        m = KeysDemonstrator(config).plan(env, seed=int(sub.integers(2**31)), mistake=mistake)
        m = DemoMotion(m.times, m.poses, rng, c.rate_hz, tremor_deg=h.tremor_deg, palm_deg=c.palm_deg)
        edits = humanize(m, rng, h)
        m.intent = {"demonstrator": "human", "strategy": strategy, "failure": fails, "edits": edits}
        if mistake:
            m.intent["press"] = mistake[1]
        return m


class HumanTurnDemonstrator(MeantFailures):
    """HandTurn as a person turns a knob: reaction and closing at a person's speed, a turning speed of their own,
    tremor, overshoot and hesitation in the grip; one sweep of the palm or two with a pause between (a person
    re-sets the wrist on a large turn); watching the pointer and correcting as the scripted wearer does. The
    mistakes: a grip "too loose" (no squeeze: the knob slips under the fingers) or "stops short" (60 % of the turn,
    let go without looking again)."""

    task = "turn"
    kinds = ("too loose", "stops short")

    def __init__(self, human: HumanConfig = HumanConfig(), config: TurnDemoConfig = TurnDemoConfig()):
        self.human, self.config = human, config

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        env, h, c = env.unwrapped, self.human, self.config
        rng, sub, fails, strategy, r = take(seed, h, self.kinds, ("one sweep", "two sweeps"))
        speed = float(np.mean(c.turn_deg_per_s) * rng.lognormal(0.0, h.speed_cv))
        config = replace(c, reaction_s=(r, r + 0.05), close_s=(duration(rng, h, c.close_s),) * 2,
                         turn_deg_per_s=(speed, speed))  # fmt: skip
        if fails == "too loose":
            config = replace(config, squeeze_mm=(-10, -6), robot_squeeze_mm={})  # closes short of the rim
        m = TurnDemonstrator(config).plan(env, seed=int(sub.integers(2**31)), tremor_deg=h.tremor_deg,
                                          share=h.short if fails == "stops short" else 1.0)  # fmt: skip
        t_turn = float(m.times[5])
        edits = humanize(m, rng, h, until=t_turn)
        if strategy == "two sweeps":  # the palm stops halfway through the turn for a moment, then turns on
            t_mid = float(np.mean(m.times[m.times >= t_turn][:2]))
            pause = rng.uniform(*h.hesitate_s)
            pause_at(m, t_mid, pause)
            m.turned_s += pause
            m.let_go_s += pause
            m.busy_until += pause
            edits.append(f"two sweeps, paused {pause:.2f} s")
        m.intent = {"demonstrator": "human", "strategy": strategy, "failure": fails, "edits": edits}
        return m


def reaching_take(m, fails: str | None, strategy: str) -> DemoMotion:
    """A free-wrist reach-and-grasp plan (relocate, pick) made a person's take: a careless take (a meant failure)
    does not re-plan (the object let slip is not gone back for, the wrong one's mistake not seen); "thumb first"
    closes the thumb before the fingers (their second move is the closing: the first shapes the approach)."""
    if fails:
        m.replans = 0
    edits = []
    if strategy == "thumb first":
        k = int(np.flatnonzero(np.any(m.poses[1:] != m.poses[:-1], axis=1))[1]) + 1
        staged(m, float(m.times[k - 1]), float(m.times[k]), thumb_first=True)
        edits.append(f"thumb first at {m.times[k - 1]:.2f} s")
    m.intent = {"demonstrator": "human", "strategy": strategy, "failure": fails, "edits": edits}
    return m


class HumanRelocateDemonstrator(MeantFailures):
    """HandRelocate as a person does it with a free wrist: each move a reaction time after the last (drawn per take),
    the reach, closing, lift, carry and lowering each at a person's varying speed, aimed and placed with a person's
    spread (``aim_mm``, ``place_mm``: endpoint spread grows with the speed and length of the move, Schmidt et al.
    1979; 5 and 8 mm here for 10-20 cm reaches in about a second), a person's tremor; watching where the object sits
    in the hand and nudging it into the circle, and re-planning from where things are when the object is not where
    they reach (as the scripted wearer). Two strategies: the fingers together or the thumb first. The mistakes: a
    grip "too loose" (the object slips out in the carry) or "misplaces" (the carry stops short of the circle, and
    the wearer lets go without looking)."""

    task = "relocate"
    kinds = ("too loose", "misplaces")

    def __init__(self, human: HumanConfig = HumanConfig(), config: RelocateDemoConfig = RelocateDemoConfig()):
        self.human, self.config = human, config

    def plan(self, env, seed: int | None = None, start=None) -> DemoMotion:
        env, h, c = env.unwrapped, self.human, self.config
        rng, sub, fails, strategy, r = take(seed, h, self.kinds, ("together", "thumb first"))
        spans = {name: (duration(rng, h, getattr(c, name)),) * 2
                 for name in ("reach_s", "descend_s", "close_s", "lift_s", "carry_s", "lower_s", "open_s")}  # fmt: skip
        config = replace(c, reaction_s=(r - 0.05, r + 0.05), aim_mm=h.aim_mm, place_mm=h.place_mm,
                         tremor_deg=h.tremor_deg, **spans)  # fmt: skip
        if fails == "too loose":
            config = replace(config, grip=h.loose)
        elif fails == "misplaces":
            config = replace(config, carry=h.short_carry)
        # its re-plans (the object not where it reaches) come from the same person: this take's draws and mistake
        m = RelocateDemonstrator(config).plan(env, seed=int(sub.integers(2**31)), start=start)
        return reaching_take(m, fails, strategy)


PICK_LOOSE = 0.3  # HandPick's "too loose": a power grasp 45 % closed still lifted a light box (1 of 20 takes)


class HumanPickDemonstrator(MeantFailures):
    """HandPick as a person reaches for the named object: finding it (a reaction time), the travel, reach, closing
    and lift each at a person's varying speed, aimed with a person's spread (``aim_mm``), a person's tremor; the
    fingers together or the thumb first. The mistakes: a grip "too loose" (the object slips out in the lift) or
    the "wrong one" (the instruction misread: the other object picked up)."""

    task = "pick"
    kinds = ("too loose", "wrong one")

    def __init__(self, human: HumanConfig = HumanConfig(), config: PickDemoConfig = PickDemoConfig()):
        self.human, self.config = human, config

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        env, h, c = env.unwrapped, self.human, self.config
        rng, sub, fails, strategy, r = take(seed, h, self.kinds, ("together", "thumb first"))
        spans = {name: (duration(rng, h, getattr(c, name)),) * 2
                 for name in ("over_s", "reach_s", "descend_s", "close_s", "lift_s")}  # fmt: skip
        config = replace(c, reaction_s=(r - 0.05, r + 0.05), aim_mm=h.aim_mm, tremor_deg=h.tremor_deg,
                         grip=PICK_LOOSE if fails == "too loose" else 1.0, **spans)  # fmt: skip
        m = PickDemonstrator(config).plan(env, seed=int(sub.integers(2**31)),
                                          colour=env.other() if fails == "wrong one" else None)  # fmt: skip
        return reaching_take(m, fails, strategy)


HUMAN = {"grasp": HumanGraspDemonstrator, "pinch": HumanPinchDemonstrator, "pose": HumanPoseDemonstrator,
         "keys": HumanKeysDemonstrator, "turn": HumanTurnDemonstrator,
         "relocate": HumanRelocateDemonstrator, "pick": HumanPickDemonstrator}  # fmt: skip
