"""GloverecSimConfig: `--robot.type=gloverec_sim` and its fields on LeRobot's command line."""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot.robots.config import RobotConfig


@dataclass
class SimCameraConfig:
    """A MuJoCo camera of the task's scene (front, top or side), rendered offscreen. ``fps`` is LeRobot's required
    camera field: images come with every step, at the robot's ``fps``."""

    width: int = 128
    height: int = 128
    fps: int = 30


@RobotConfig.register_subclass("gloverec_sim")
@dataclass
class GloverecSimConfig(RobotConfig):
    """``robot``: a gloverec robot hand (configs/robots: glovehand, shadow, ...); ``task``: a registered task
    (pose, grasp, ...: envs/tasks/registry.py); ``cameras``: {name: {width, height}} of the scene's cameras, all the
    same size (e.g.
    ``--robot.cameras='{front: {width: 128, height: 128}}'``); ``fps``: the control rate the task steps at, equal
    to lerobot-record's ``--dataset.fps``; ``seed``: the first scene's seed, then +1 at each reset."""

    robot: str = "glovehand"
    task: str = "pose"
    cameras: dict[str, SimCameraConfig] = field(default_factory=dict)
    fps: int = 30
    seed: int = 0
