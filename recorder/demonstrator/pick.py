"""HandPick demonstrator: a person's reach for the object the instruction names. From the home pose, look at the
table, reach over the target with the hand open, come down onto it shaping the grasp, close into the grasp sized
for it, lift it and hold it up.

The reach down, the descent onto the object and the grasp are the relocate demonstrator's (recorder/demonstrator/
relocate.py: its timing config, its approach geometry through ``over_object``, a ball's palm on its top; the
grasp postures from grasp.py), imported rather than copied, so both tasks are demonstrated alike. What it adds:
a look before the reach (the target must be found first); the travel from home with the hand open, above the
taller object (the approach posture's thumb hangs 10 cm below the palm and swept objects off the table on its
side); and after the lift the person watches the object in the hand: if it hangs lower than meant (it slid in
the grip), they lift by the difference, once."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder.demonstrator.grasp import PREGRASP, power_grasp
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.relocate import RelocateDemoConfig, over_object
from recorder.demonstrator.replan import ReplanningMotion, in_hand
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS


@dataclass(frozen=True)
class PickDemoConfig(RelocateDemoConfig):
    look_s: tuple = (0.3, 0.5)  # before the reach: finding the named object on the table
    over_s: tuple = (0.6, 0.85)  # from home to ``hover_m`` over the target, the hand open (flat): clear of the
    hover_m: float = 0.08  # taller object's top (the approach posture's thumb hangs 10 cm below the palm: it would
    # sweep the objects on the way), then relocate's reach down, shaping the approach posture
    lift_m: float = 0.10  # the task's lift_m: the object held well above half of it
    sag_mm: float = 15.0  # after the lift, an object this much lower than planned is lifted again by that much


class PickMotion(ReplanningMotion):
    """The plan, and the person watching the lift: once, in the pause after it, they see how high the object hangs
    and, if it slid down in the grip, lift the hand by what it lost. When they see the object lie elsewhere than
    they reached for, or out of the hand, they plan again (ReplanningMotion)."""

    def __init__(self, *args, check=None, sag_m: float = 0.015, **kw):
        super().__init__(*args, **kw)
        self.check = check  # (from_s, to_s, planned height of the object's centre above its start)
        self.sag_m = sag_m

    def adopt(self, fresh: PickMotion, at: float) -> None:
        super().adopt(fresh, at)
        self.check = None if fresh.check is None else (fresh.check[0] + at, fresh.check[1] + at, fresh.check[2])

    def watch(self, env, into=None) -> None:
        into = self if into is None else into
        if self.replanned_now(env, into) or self.check is None or env.t < self.check[0]:
            return
        start, end, planned = self.check
        self.check = None
        at, took = env.t + 0.02, 0.3
        if at >= end:
            return
        sag = planned - env.lifted(env.target)
        if sag < self.sag_m or env.hand_contacts(env.object_geom) < 2:  # not slid: lost (nothing to lift)
            return
        at = into.revise(at, took, move=(0.0, 0.0, sag))
        if at is not None and into is not self:
            self.revise(at, took, move=(0.0, 0.0, sag))
        if at is not None:
            self.shifted(at, took)


class PickDemonstrator:
    task = "pick"

    def __init__(self, config: PickDemoConfig = PickDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None, colour: str | None = None, start=None) -> DemoMotion:
        """``colour``: reach for that object rather than the one the instruction names (a wearer's mistake).
        ``start``, (pose (20,) rad, palm position (3,) m): where the wearer's hand is now, from the environment as
        it is now (env.t is the plan's time 0): the object reached for where it lies, or held up if it is in the
        hand."""
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)

        def took(span) -> float:
            return float(rng.uniform(*span)) if isinstance(span, tuple) else float(span)

        target = env.objects[colour or env.target]
        size = 2.0 * float(np.mean(target.half[:2])) / env.robot.config.retarget.tips.scale
        noise = np.clip(rng.normal(0, 1, len(JOINTS)), -2, 2) * np.radians(c.pose_noise_deg)
        grasp = power_grasp(size) + noise
        grasp = PREGRASP + c.grip * (grasp - PREGRASP)
        home, _ = env._base_target(0.0)
        lies = env.object_pose(colour)[:3] if start is not None else target.start
        at_object = over_object(env.robot, lies, target.half, target.shape, rng, c)
        lifted = at_object + [0, 0, c.lift_m]
        tallest = max(2 * o.half[2] for o in env.objects.values())
        over = at_object + [0, 0, c.hover_m + tallest - 2 * target.half[2]]
        pose, pos = (GESTURES["open"], home) if start is None else (np.asarray(start[0]), np.asarray(start[1]))
        keys = [(0.0, pose, pos)]

        def then(span, pose, pos, react=True) -> None:
            t = keys[-1][0] + (took(c.reaction_s if react is True else react) if react else 0.0)
            keys.append((t, keys[-1][1], keys[-1][2]))  # held while reacting
            keys.append((t + took(span), pose, pos))

        held = start is not None and in_hand(env)
        if held:  # in the hand already: lift it (again) to where it should be held
            grasp, reached = pose, 0.0
            lifted = np.array([*pos[:2], max(pos[2], lifted[2])])
            then(c.lift_s, grasp, lifted)
        else:
            if start is None:
                then(c.look_s, GESTURES["open"], home, react=False)
            elif pos[2] < over[2] - 1e-3:  # up first, the hand open, clear of both objects, then over it
                then(c.lift_s, GESTURES["open"], [*pos[:2], over[2]])
            then(c.over_s, GESTURES["open"], over)
            then(c.reach_s, PREGRASP, at_object + [0, 0, c.approach_m], react=c.glance_s)  # over it: a glance
            reached = keys[-1][0]  # from here on the hand is at the object: it may nudge it itself
            then(c.descend_s, PREGRASP, at_object, react=c.glance_s)  # a glance that it is over it
            then(c.close_s, grasp, at_object)
            then(c.squeeze_s, grasp, at_object, react=False)
            then(c.lift_s, grasp, lifted, react=False)
        lift_done = keys[-1][0]
        end = max(lift_done, env.config.episode_s - env.t) + 1.0
        keys.append((end, grasp, lifted))
        times, poses, positions = zip(*keys)
        return PickMotion(times, poses, rng, c.rate_hz, palm_pos=np.array(positions), tremor_deg=c.tremor_deg,
                          check=(lift_done, lift_done + 0.5, c.lift_m), sag_m=c.sag_mm * 1e-3,
                          aim=(*lies[:2], reached, lift_done, np.inf), planner=self,
                          seed=0 if seed is None else int(seed))  # fmt: skip
