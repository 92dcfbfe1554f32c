"""HandRelocate demonstrator: a person's reach with a free wrist. Look at the object, reach over it and come down
onto it, close into the grasp sized for it (as the grasp demonstrator does), lift, carry it by the vector from where
it lies to the circle's centre, lower it to the table, loosen the grip, open, and take the hand away.

Done as a person does it with a ball: the palm comes down onto the ball's top before the fingers close around it
(with the palm a few millimetres above it, the closing fingers roll a ball back toward the wrist, out under the heel
of the hand, where the fingertips hold it against the thumb's base until it slips out); the ball is put down on the
table at the height it was picked up from; and the grip is loosened before the hand opens (fingers squeezing a ball
from all sides while some open first shoot it out, and it rolls out of the circle).

The wrist moves on minimum-jerk paths between keyframes (the palm positions of the DemoMotion, in the robot's
world), each after a human reaction time, with the aim a few millimetres off and the durations varied between
demonstrations; the palm stays about palm down (with a real hand's few degrees of wander)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder.demonstrator.grasp import PREGRASP, power_grasp
from recorder.demonstrator.reach import aim_error
from recorder.demonstrator.replan import ReplanningMotion, in_hand
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS


@dataclass(frozen=True)
class RelocateDemoConfig:
    reaction_s: tuple = (0.15, 0.3)  # before each move: seeing that the last one is done
    reach_s: tuple = (0.6, 0.8)  # over the object, ``approach_m`` above where it grasps
    approach_m: float = 0.02
    glance_s: tuple = (0.08, 0.15)  # over the object, a glance that the hand is above it before coming down
    descend_s: tuple = (0.25, 0.35)  # the last of the reach, straight down onto the object, slowly
    close_s: tuple = (0.45, 0.7)
    squeeze_s: float = 0.3
    lift_s: tuple = (0.5, 0.75)
    carry_s: tuple = (1.0, 1.4)
    lower_s: tuple = (0.5, 0.75)
    loosen_s: tuple = (0.2, 0.3)  # the grip relaxed before opening: ``loosen`` of the way to the open hand, ...
    loosen: float = 0.5
    loosen_spread_deg: float = 10.0  # ... and the fingers spread, off the object's sides
    open_s: tuple = (0.3, 0.5)
    lift_m: float = 0.06  # how high the object is carried
    land_m: float = -0.002  # where the lowering leaves the object's bottom: on the table (pressing it lightly)
    palm_on_ball_m: float = 0.01  # a ball: the palm aims this far past its top (the ball stops it: it rests on it)
    aim_mm: float = 3.0  # the reach's error, standard deviation, each horizontal axis
    place_mm: float = 5.0  # the carry's error, the same
    pose_noise_deg: float = 3.0
    tremor_deg: float = 0.05
    grip: float = 1.0  # how far the fingers close, from the pregrasp to the grasp (a human-like "too loose": less)
    carry: float = 1.0  # how much of the way to the circle the carry goes (less: a carry stopped short, unwatched)
    rate_hz: float = 200.0


class RelocateMotion(ReplanningMotion):
    """The plan, and the person watching it: in the pause after the lift they see where the object sits in the
    hand and aim the carry for it, and in the pause before letting go they nudge it into the circle. When they see
    the object lie elsewhere than they reached for, or out of the hand, they plan again (ReplanningMotion)."""

    def __init__(self, *args, checks=(), carry=(0.0, 0.0), lower=None, land_m=0.0, nudge_mm: float = 6.0, **kw):
        super().__init__(*args, **kw)
        self.checks = list(checks)  # (from_s, to_s, kind): the pauses where the person looks
        self.carry = np.asarray(carry, float)  # the planned carry (x, y) still ahead at the first check
        self.lower = lower  # how far the plan lowers the object after the carry (m; None: not looked at)
        self.land_m = land_m  # where the lowering should leave the object's bottom, above where it started
        self.nudge_m = nudge_mm * 1e-3

    def watch(self, env, into=None) -> None:
        into = self if into is None else into
        if self.replanned_now(env, into):
            return
        if not self.checks or env.t < self.checks[0][0]:
            return
        start, end, kind = self.checks.pop(0)
        at, took = env.t + 0.02, 0.3
        if at >= end:
            return  # past that pause already, or too late in it to start a correction: go on as planned
        lands = env.object_pose()[:2] + (self.carry if kind == "carry" else 0.0)
        error = env.target - lands
        if kind == "place" and np.linalg.norm(error) < self.nudge_m:
            return
        dz = 0.0  # after the lift they also see how low the object hangs in the hand, and lower it onto the table
        if kind == "carry" and self.lower is not None:
            dz = float(env.object_start[2] + self.land_m - (env.object_pose()[2] - self.lower))
        move = (*error, dz)
        at = into.revise(at, took, move=move)
        if at is None:
            return  # too late for whoever performs it (the emulated glove has sent that part): as planned
        if into is not self:
            self.revise(at, took, move=move)  # this plan's own copy, when the performer made it
        self.checks = [(a + took, b + took, k) for a, b, k in self.checks]
        self.shifted(at, took)

    def adopt(self, fresh: RelocateMotion, at: float) -> None:
        super().adopt(fresh, at)
        self.checks = [(a + at, b + at, kind) for a, b, kind in fresh.checks]
        self.carry, self.lower, self.land_m = fresh.carry, fresh.lower, fresh.land_m


class RelocateDemonstrator:
    task = "relocate"

    def __init__(self, config: RelocateDemoConfig = RelocateDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None, start=None) -> RelocateMotion:
        """The demonstration from the reset; with ``start``, (pose (20,) rad, palm position (3,) m): where the
        wearer's hand is now, from the environment as it is now (env.t is the plan's time 0): the object reached for
        where it lies, or carried on if it is in the hand (a re-grip after it was knocked, a policy's state taken
        over)."""
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)

        def took(span) -> float:
            return float(rng.uniform(*span))

        size = 2.0 * float(np.mean(env.object_half[:2])) / env.robot.config.retarget.tips.scale
        noise = np.clip(rng.normal(0, 1, len(JOINTS)), -2, 2) * np.radians(c.pose_noise_deg)
        grasp = power_grasp(size) + noise
        grasp = PREGRASP + c.grip * (grasp - PREGRASP)
        lies = env.object_pose()[:2]
        at_object = over_object(env.robot, lies, env.object_half, env.object_shape, rng, c)
        lifted = at_object + [0, 0, c.lift_m]
        shift = (env.target - lies + rng.normal(0, c.place_mm * 1e-3, 2)) * c.carry
        opened = GESTURES["open"]
        pose, pos = (opened, env._base_target(0.0)[0]) if start is None else (np.asarray(start[0]), start[1])
        carried = start is not None and in_hand(env)
        if carried:  # carried on from where the hand holds it
            lifted = np.array([pos[0], pos[1], max(pos[2], lifted[2])])
        over_target = lifted + [*shift, 0]
        placed = np.array([*over_target[:2], at_object[2] + 0.004])
        away = placed + [0, 0, 0.06]
        keys = [(0.0, pose, np.asarray(pos, float))]

        checks = []

        def then(span, pose, pos, react=True, look=None) -> None:
            t = keys[-1][0] + (took(c.reaction_s if react is True else react) if react else 0.0)
            keys.append((t, keys[-1][1], keys[-1][2]))  # held while reacting (and looking)
            if look:
                checks.append((keys[-2][0], t, look))
            keys.append((t + (took(span) if isinstance(span, tuple) else span), pose, pos))

        if not carried:
            clear = at_object[2] + c.approach_m
            if start is not None and pos[2] < clear - 1e-3:  # up first, clear of the object, then over it
                then(c.lift_s, PREGRASP, [*pos[:2], clear + 0.01])
            then(c.reach_s, PREGRASP, at_object + [0, 0, c.approach_m])
            reached = keys[-1][0]  # from here on the hand is at the object: it may nudge it itself
            then(c.descend_s, PREGRASP, at_object, react=c.glance_s)  # a look that it is over the object
            then(c.close_s, grasp, at_object)
            then(c.squeeze_s, grasp, at_object, react=False)
            then(c.lift_s, grasp, lifted, react=False)
        else:
            grasp, reached = pose, 0.0
        held = keys[-1][0]  # from here the object should be in the hand, ...
        then(c.carry_s, grasp, over_target, look="carry")
        put = keys[-1][0]  # ... until it is lowered
        then(c.lower_s, grasp, placed)
        loose = grasp + c.loosen * (PREGRASP - grasp)
        for finger, side in zip(("index", "middle", "ring", "pinky"), (1, 0, -1, -2)):
            loose[JOINTS.index(f"{finger}_mcp_abd")] += side * np.radians(c.loosen_spread_deg)
        then(c.loosen_s, loose, placed, look="place" if c.carry == 1.0 else None)
        then(c.open_s, PREGRASP, placed, react=False)
        then(c.lift_s, opened, away)
        end = max(keys[-1][0], env.config.episode_s - env.t) + 1.0
        keys.append((end, opened, away))
        times, poses, positions = zip(*keys)
        return RelocateMotion(
            times,
            poses,
            rng,
            c.rate_hz,
            palm_pos=np.array(positions),
            tremor_deg=c.tremor_deg,
            checks=checks if c.carry == 1.0 else [],
            carry=shift,
            lower=float(lifted[2] - placed[2]),
            land_m=c.land_m,
            aim=(*lies, reached, held, put),
            planner=self,
            seed=0 if seed is None else int(seed),
        )


def over_object(robot, start, half, shape: str, rng: np.random.Generator, c: RelocateDemoConfig) -> np.ndarray:
    """Where the palm frame goes to grasp an object (centre ``start``, half extents ``half``, ``shape``) that rests on
    the table, as ``RelocateDemonstrator.plan`` aims: the robot's grasp point just above its top, ``c.aim_mm`` off,
    and on a ball's top rather than above it (it cannot roll from under the palm). Relocate's and pick's."""
    at = np.array([*(np.asarray(start)[:2] + aim_error(rng, c.aim_mm)), 2 * half[2] + 0.003])
    at -= np.array(robot.config.grasp_point)
    if shape == "sphere":
        at[2] -= 0.003 + c.palm_on_ball_m
    return at
