"""HandRelocate demonstrator: a person's reach with a free wrist. Look at the object, reach down over it, close into
the grasp sized for it (as the grasp demonstrator does), lift, carry it by the vector from where it lies to the
circle's centre, lower it to the table, open, and take the hand away.

The wrist moves on minimum-jerk paths between keyframes (the palm positions of the DemoMotion, in the robot's
world), each after a human reaction time, with the aim a few millimetres off and the durations varied between
demonstrations; the palm stays about palm down (with a real hand's few degrees of wander)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder.demonstrator.grasp import PREGRASP, power_grasp
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.reach import aim_error
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS


@dataclass(frozen=True)
class RelocateDemoConfig:
    reaction_s: tuple = (0.15, 0.3)  # before each move: seeing that the last one is done
    reach_s: tuple = (0.8, 1.1)  # down over the object
    close_s: tuple = (0.45, 0.7)
    squeeze_s: float = 0.3
    lift_s: tuple = (0.6, 0.9)
    carry_s: tuple = (1.0, 1.4)
    lower_s: tuple = (0.6, 0.9)
    open_s: tuple = (0.3, 0.5)
    lift_m: float = 0.08  # how high the object is carried
    aim_mm: float = 3.0  # the reach's error, standard deviation, each horizontal axis
    place_mm: float = 5.0  # the carry's error, the same
    pose_noise_deg: float = 3.0
    rate_hz: float = 200.0


class RelocateMotion(DemoMotion):
    """The plan, and the person watching it: in the pause after the lift they see where the object sits in the
    hand and aim the carry for it, and in the pause before letting go they nudge it into the circle."""

    watches = True

    def __init__(self, *args, checks=(), carry=(0.0, 0.0), nudge_mm: float = 6.0, **kw):
        super().__init__(*args, **kw)
        self.checks = list(checks)  # (from_s, to_s, kind): the pauses where the person looks
        self.carry = np.asarray(carry, float)  # the planned carry (x, y) still ahead at the first check
        self.nudge_m = nudge_mm * 1e-3

    def watch(self, env, into=None) -> None:
        into = self if into is None else into
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
        move = (*error, 0.0)
        at = into.revise(at, took, move=move)
        if at is None:
            return  # too late for whoever performs it (the emulated glove has sent that part): as planned
        if into is not self:
            self.revise(at, took, move=move)  # this plan's own copy, when the performer made it
        self.checks = [(a + took, b + took, k) for a, b, k in self.checks]


class RelocateDemonstrator:
    task = "relocate"

    def __init__(self, config: RelocateDemoConfig = RelocateDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)

        def took(span) -> float:
            return float(rng.uniform(*span))

        size = 2.0 * float(np.mean(env.object_half[:2])) / env.robot.config.retarget.tips.scale
        noise = np.clip(rng.normal(0, 1, len(JOINTS)), -2, 2) * np.radians(c.pose_noise_deg)
        grasp = power_grasp(size) + noise
        start, _ = env._base_target(0.0)
        gp = np.array(env.robot.config.grasp_point)
        at_object = np.array([*(env.object_start[:2] + aim_error(rng, c.aim_mm)), 2 * env.object_half[2] + 0.003]) - gp
        lifted = at_object + [0, 0, c.lift_m]
        shift = env.target - env.object_start[:2] + rng.normal(0, c.place_mm * 1e-3, 2)
        over_target = lifted + [*shift, 0]
        placed = at_object + [*shift, 0.004]
        away = placed + [0, 0, 0.06]
        opened = GESTURES["open"]
        keys = [(0.0, opened, start)]

        checks = []

        def then(span, pose, pos, react=True, look=None) -> None:
            t = keys[-1][0] + (took(c.reaction_s) if react else 0.0)
            keys.append((t, keys[-1][1], keys[-1][2]))  # held while reacting (and looking)
            if look:
                checks.append((keys[-2][0], t, look))
            keys.append((t + (took(span) if isinstance(span, tuple) else span), pose, pos))

        then(c.reach_s, PREGRASP, at_object)
        then(c.close_s, grasp, at_object)
        then(c.squeeze_s, grasp, at_object, react=False)
        then(c.lift_s, grasp, lifted, react=False)
        then(c.carry_s, grasp, over_target, look="carry")
        then(c.lower_s, grasp, placed)
        then(c.open_s, PREGRASP, placed, look="place")
        then(c.lift_s, opened, away)
        end = max(keys[-1][0], env.config.episode_s) + 1.0
        keys.append((end, opened, away))
        times, poses, positions = zip(*keys)
        return RelocateMotion(times, poses, rng, c.rate_hz, palm_pos=np.array(positions), checks=checks,
                              carry=shift)  # fmt: skip
