"""Robot hands by name. A robot is an MJCF under ``envs/assets/`` plus ``configs/robots/<name>.yaml``;
dropping in those two files makes it available here and in every task (``robot=<name>``)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

from envs.robots.config import FINGER_NAMES, RobotConfig, load_robot_config
from envs.robots.joint_map import JointMap, tendon_couplings
from envs.robots.robot import Robot
from recorder.config import ConfigError
from recorder.paths import configs_dir

__all__ = [
    "FINGER_NAMES",
    "JointMap",
    "Robot",
    "RobotConfig",
    "load_robot",
    "robot_config",
    "robot_names",
    "tendon_couplings",
]


def robot_names() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in (configs_dir() / "robots").glob("*.yaml")))


def robot_config(name: str) -> RobotConfig:
    """The config of robot ``name`` (or of a .yaml path)."""
    path = Path(name) if name.endswith((".yaml", ".yml")) else configs_dir() / "robots" / f"{name}.yaml"
    if not path.is_file():
        raise ConfigError(f"unknown robot {name!r}; valid robots: {', '.join(robot_names())}")
    return load_robot_config(path)


@cache
def load_robot(name: str) -> Robot:
    """The robot ``name`` (cached: a Robot is immutable once loaded)."""
    return Robot(robot_config(name))
