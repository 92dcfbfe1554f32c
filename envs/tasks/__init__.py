"""Tasks by name: ``pose`` (HandPose) and ``grasp`` (HandGrasp); configs in configs/tasks/<name>.yaml."""

from __future__ import annotations

from envs.tasks.base import CAMERAS, HandEnv, TaskConfig
from envs.tasks.hand_grasp import HandGraspConfig, HandGraspEnv
from envs.tasks.hand_pose import HandPoseConfig, HandPoseEnv
from recorder.config import ConfigError

TASKS = {"pose": HandPoseEnv, "grasp": HandGraspEnv}

__all__ = [
    "CAMERAS",
    "TASKS",
    "HandEnv",
    "HandGraspConfig",
    "HandGraspEnv",
    "HandPoseConfig",
    "HandPoseEnv",
    "TaskConfig",
    "make_task",
]


def make_task(name: str, robot: str = "glovehand", **kwargs) -> HandEnv:
    """The task ``name`` with ``robot``; unknown names: one-line ValueError listing the valid ones."""
    if name not in TASKS:
        raise ConfigError(f"unknown task {name!r}; valid tasks: {', '.join(TASKS)}")
    return TASKS[name](robot=robot, **kwargs)
