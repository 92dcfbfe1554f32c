"""HandPinch demonstrator: the thumb and the named finger open a little wider than the object while the base
descends (the other fingers straight, out of the way), then, once the base has stopped and after a human reaction
time, close on it (minimum jerk) and keep pressing: the posture aims a few millimetres past contact, as a person
squeezes a small object. The postures are the robot's pinch (envs.tasks.hand_pinch.robot_pinch): the operator
watches the robot's fingertips, not their own. Varies timing, aperture, squeeze and posture between demos."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.tasks.hand_pinch import pinch_angles, robot_pinch
from recorder.demonstrator.motion import DemoMotion
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS


@dataclass(frozen=True)
class PinchDemoConfig:
    preshape_s: tuple = (0.35, 0.5)  # to the open pinch, while the base hovers
    aperture_mm: tuple = (18, 28)  # the open pinch: this much wider than the object
    squeeze_mm: tuple = (4, 6)  # the closed pinch: this much narrower (the object stops the fingers)
    reaction_s: tuple = (0.1, 0.3)  # after the base has stopped
    close_s: tuple = (0.4, 0.7)
    pose_noise_deg: float = 1.5
    palm_deg: float = 1.0  # the palm's wander: a person holds it steady over a small object (3 degrees moves the
    # fingertips 5 mm, half a marble)
    rate_hz: float = 200.0


class PinchDemonstrator:
    task = "pinch"

    def __init__(self, config: PinchDemoConfig = PinchDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)
        robot, finger, width = env.robot.config.name, env.finger, env.pinch_gap_mm()
        open_p = robot_pinch(robot, finger, width + int(rng.integers(c.aperture_mm[0], c.aperture_mm[1] + 1)))[0]
        closed_p = robot_pinch(robot, finger, max(0, width - int(rng.integers(c.squeeze_mm[0], c.squeeze_mm[1] + 1))))[
            0
        ]
        noise = np.clip(rng.normal(0, 1, 6), -2, 2) * c.pose_noise_deg
        start = GESTURES["open"]
        opened = self._with_others_straight(start, pinch_angles(finger, np.array(open_p) + noise), finger)
        closed = self._with_others_straight(start, pinch_angles(finger, np.array(closed_p) + noise), finger)
        sched = env.schedule
        t_pre = rng.uniform(0.05, 0.2)
        t_open = t_pre + rng.uniform(*c.preshape_s)
        t_close = sched["close"] + rng.uniform(*c.reaction_s)
        t_closed = t_close + rng.uniform(*c.close_s)
        end = max(t_closed, env.config.episode_s) + 1.0
        times = [0.0, t_pre, t_open, t_close, t_closed, end]
        poses = [start, start, opened, opened, closed, closed]
        return DemoMotion(times, poses, rng, c.rate_hz, palm_deg=c.palm_deg)

    @staticmethod
    def _with_others_straight(start: np.ndarray, pinch: np.ndarray, finger: str) -> np.ndarray:
        """The pinch's thumb and finger, the open hand's other fingers."""
        out = start.copy()
        for k, name in enumerate(JOINTS):
            if name.startswith(("thumb_", f"{finger}_")):
                out[k] = pinch[k]
        return out
