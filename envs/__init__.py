"""gloverec MuJoCo robot-hand environments (Gymnasium).

Importing ``envs`` registers every task of the task registry (envs/tasks/registry.py) with Gymnasium, e.g.
``gloverec/HandPose-v0`` and ``gloverec/HandGrasp-v0``; choose the robot with
``gym.make("gloverec/HandPose-v0", robot="shadow")``, or ``envs.make("pose", "shadow")``. Robots: ``envs.robots``
(an MJCF under envs/assets plus configs/robots/<name>.yaml each); tasks: ``envs.tasks`` (a module each, with its
config dataclass; plugins add more: docs/envs.md, "Adding a task").
"""

from __future__ import annotations

import gymnasium as gym

from envs.robots import load_robot, robot_names
from envs.tasks import get_task, task_names
from recorder.config import ConfigError

__all__ = ["check_names", "get_task", "load_robot", "make", "robot_names", "task_names"]


def check_names(robot: str | None = None, task: str | None = None) -> None:
    """The ``--robot`` and ``--task`` of a command: an unknown one is a one-line ConfigError listing the valid
    ones (commands check before loading lerobot and torch, which takes seconds)."""
    if robot is not None and robot not in robot_names() and not robot.endswith((".yaml", ".yml")):
        raise ConfigError(f"--robot {robot}: unknown robot; valid: {', '.join(robot_names())}")
    if task is not None and task not in task_names():
        raise ConfigError(f"--task {task}: unknown task; valid: {', '.join(task_names())}")


def make(task: str, robot: str = "glovehand", **kwargs) -> gym.Env:
    """``gym.make`` by task name (``pose``, ``grasp``, ...); unknown names: one-line ConfigError."""
    return gym.make(get_task(task).env_id, robot=robot, **kwargs)
