"""Robot hands by name. A robot is an MJCF under ``envs/assets/`` plus ``configs/robots/<name>.yaml``;
dropping in those two files makes it available here and in every task (``robot=<name>``)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

from envs.robots.robot import CONFIGS, FINGER_NAMES, Robot, RobotConfig

__all__ = ["FINGER_NAMES", "Robot", "RobotConfig", "load_robot", "robot_config", "robot_names"]


def robot_names() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in CONFIGS.glob("*.yaml")))


def robot_config(name: str) -> RobotConfig:
    """The config of robot ``name`` (or of a .yaml path)."""
    path = Path(name) if name.endswith((".yaml", ".yml")) else CONFIGS / f"{name}.yaml"
    if not path.is_file():
        raise ValueError(f"unknown robot {name!r}; valid robots: {', '.join(robot_names())}")
    return RobotConfig.from_yaml(path)


@cache
def load_robot(name: str) -> Robot:
    """The robot ``name`` (cached: a Robot is immutable once loaded)."""
    return Robot(robot_config(name))
