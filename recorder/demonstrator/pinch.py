"""HandPinch demonstrator: the thumb and the named finger open a little wider than the object while the base
descends (the other fingers straight, out of the way), then, once the base has stopped and after a human reaction
time, close on it (minimum jerk) and keep pressing: the posture aims a few millimetres past contact, as a person
squeezes a small object. The postures are the robot's pinch as the task searches it (``env.robot_pinch``: its pads
clear of the table): the operator watches the robot's fingertips, not their own. Varies timing, aperture, squeeze
and posture between demos. With a free wrist (the task's ``base_position``) the wearer also does the script's
descent and lift (recorder/demonstrator/reach.py)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from envs.tasks.hand_pinch import pinch_angles
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.reach import grip
from recorder.demonstrator.watching import SightConfig
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS


@dataclass(frozen=True)
class PinchDemoConfig:
    pre_s: tuple = (0.05, 0.2)  # the open hand held at first
    preshape_s: tuple = (0.35, 0.5)  # to the open pinch, while the base hovers
    aperture_mm: tuple = (18, 28)  # the open pinch: this much wider than the object
    squeeze_mm: tuple = (10, 12)  # the closed pinch: this much narrower (the object stops the fingers; a lighter
    # squeeze, 4-6 mm, lost 7 of 50 takes through the glove to the object slipping or squirting out: 39/50 against 46)
    # the hands whose fingertip servos need a harder squeeze to hold (the operator sees the object slip and presses)
    robot_squeeze_mm: dict = field(default_factory=lambda: {"shadow": (12, 14)})
    reaction_s: tuple = (0.1, 0.3)  # after the base has stopped
    close_s: tuple = (0.4, 0.7)
    pose_noise_deg: float = 1.5
    palm_deg: float = 1.0  # the palm's wander: a person holds it steady over a small object (3 degrees moves the
    # fingertips 5 mm, half a marble)
    wrist_reaction_s: tuple = (0.15, 0.3)  # a free wrist: each of the script's base moves started this late
    aim_mm: float = 2.0  # a free wrist: the reach's error, standard deviation, each horizontal axis
    rate_hz: float = 200.0
    sight: SightConfig | None = SightConfig()  # the wearer watches the pads close (None: open loop)

    def squeeze_for(self, robot: str) -> tuple:
        return self.robot_squeeze_mm.get(robot, self.squeeze_mm)


class PinchDemonstrator:
    task = "pinch"

    def __init__(self, config: PinchDemoConfig = PinchDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None, finger: str | None = None) -> DemoMotion:
        """``finger``: pinch with that finger rather than the one the task names (a wearer's mistake)."""
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)
        finger, width = finger or env.finger, env.pinch_gap_mm()
        open_p = env.robot_pinch(width + int(rng.integers(c.aperture_mm[0], c.aperture_mm[1] + 1)), finger)[0]
        lo, hi = c.squeeze_for(env.robot.config.name)
        closed_p = env.robot_pinch(max(0, width - int(rng.integers(lo, hi + 1))), finger)[0]
        noise = np.clip(rng.normal(0, 1, 6), -2, 2) * c.pose_noise_deg
        start = GESTURES["open"]
        opened = pinch_pose(finger, np.array(open_p) + noise, start)
        closed = pinch_pose(finger, np.array(closed_p) + noise, start)
        return grip(env, rng, c, start, opened, closed, ("thumb", finger), palm_deg=c.palm_deg)


def pinch_pose(finger: str, p, start: np.ndarray) -> np.ndarray:
    """The thumb-``finger`` pinch with parameters ``p`` (6, deg), the other fingers as in ``start``."""
    pinch = pinch_angles(finger, p)
    out = start.copy()
    for k, name in enumerate(JOINTS):
        if name.startswith(("thumb_", f"{finger}_")):
            out[k] = pinch[k]
    return out
