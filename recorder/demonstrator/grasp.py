"""HandGrasp demonstrator: open the hand wide while the base descends, then, once it has stopped and after a
human reaction time, close into a power grasp sized for the object (minimum jerk), and keep squeezing. With a free
wrist (the task's ``base_position``) the wearer also does the script's descent (while opening), lift and tilt
(recorder/demonstrator/reach.py).

The grasp posture aims a little past contact (the object stops the fingers), so the position servos press
on it; smaller objects get a tighter target. The operator sizes the grasp by what the robot's hand needs: an
object looks as large to them as it is against the robot's hand (its fingertip scale, ``retarget.tips``), so a
hand bigger than theirs gets a tighter grasp. Varies timing, speed and posture between demos."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.reach import grip
from recorder.demonstrator.watching import SightConfig
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS, interpolate_dip


def _pose(base: np.ndarray, **deg) -> np.ndarray:
    a = base.copy()
    for k, v in deg.items():
        a[JOINTS.index(k)] = np.radians(v)
    return interpolate_dip(a)


def _fingers(flex: float, pip: float, spread: float = 0.0) -> dict:
    out = {}
    for f, s in zip(("index", "middle", "ring", "pinky"), (1.0, 0.0, -1.0, -2.0)):
        out.update({f"{f}_mcp_flex": flex, f"{f}_pip": pip, f"{f}_mcp_abd": s * spread})
    return out


PREGRASP = _pose(
    np.zeros(len(JOINTS)), thumb_cmc_flex=5, thumb_cmc_abd=55, thumb_mcp=5, thumb_ip=5, **_fingers(10, 10, 6)
)


def power_grasp(size_m: float) -> np.ndarray:
    """Power grasp target for an object about ``size_m`` across: the smaller, the tighter."""
    k = float(np.clip((0.075 - size_m) / 0.03, 0.0, 1.0))  # 0: large (7.5 cm), 1: small (4.5 cm)
    return _pose(
        np.zeros(len(JOINTS)),
        thumb_cmc_flex=20,
        thumb_cmc_abd=60,
        thumb_mcp=35,
        thumb_ip=35,
        **_fingers(70 + 10 * k, 90 + 10 * k, 0),
    )


@dataclass(frozen=True)
class GraspDemoConfig:
    pre_s: tuple = (0.05, 0.3)  # the open hand held at first
    preshape_s: tuple = (0.5, 0.9)  # opening wide, during the descent
    reaction_s: tuple = (0.1, 0.3)  # after the base has stopped
    close_s: tuple = (0.45, 0.8)
    pose_noise_deg: float = 3.0
    wrist_reaction_s: tuple = (0.15, 0.3)  # a free wrist: each of the script's base moves started this late
    aim_mm: float = 3.0  # a free wrist: the reach's error, standard deviation, each horizontal axis
    rate_hz: float = 200.0
    sight: SightConfig | None = SightConfig()  # the wearer watches the fingers close (None: open loop)


class GraspDemonstrator:
    task = "grasp"

    def __init__(self, config: GraspDemoConfig = GraspDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)
        size = 2.0 * float(np.mean(env.object_half[:2])) / env.robot.config.retarget.tips.scale
        noise = np.clip(rng.normal(0, 1, len(JOINTS)), -2, 2) * np.radians(c.pose_noise_deg)
        return grip(env, rng, c, GESTURES["open"], PREGRASP, power_grasp(size) + noise, env.robot.fingers)
