"""Tasks by name, from the task registry (envs/tasks/registry.py): ``pose`` (HandPose), ``grasp`` (HandGrasp),
``pinch`` (HandPinch), ``keys`` (HandKeys), ``turn`` (HandTurn), ``relocate`` (HandRelocate, a free wrist) and
``pick`` (HandPick, a free wrist, two objects) built in, more from plugins;
``make_task(name, robot)`` builds one."""

from __future__ import annotations

from envs.tasks.base import CAMERAS, HandEnv, TaskConfig
from envs.tasks.hand_grasp import HandGraspConfig, HandGraspEnv
from envs.tasks.hand_keys import HandKeysConfig, HandKeysEnv
from envs.tasks.hand_pick import HandPickConfig, HandPickEnv
from envs.tasks.hand_pinch import HandPinchConfig, HandPinchEnv
from envs.tasks.hand_pose import HandPoseConfig, HandPoseEnv
from envs.tasks.hand_relocate import HandRelocateConfig, HandRelocateEnv
from envs.tasks.hand_turn import HandTurnConfig, HandTurnEnv
from envs.tasks.registry import TaskSpec, get_task, register_task, task_names

__all__ = [
    "CAMERAS",
    "HandEnv",
    "HandGraspConfig",
    "HandGraspEnv",
    "HandKeysConfig",
    "HandKeysEnv",
    "HandPickConfig",
    "HandPickEnv",
    "HandPinchConfig",
    "HandPinchEnv",
    "HandPoseConfig",
    "HandPoseEnv",
    "HandRelocateConfig",
    "HandRelocateEnv",
    "HandTurnConfig",
    "HandTurnEnv",
    "TaskConfig",
    "TaskSpec",
    "get_task",
    "make_task",
    "register_task",
    "task_names",
]


def make_task(name: str, robot: str = "glovehand", **kwargs) -> HandEnv:
    """The task ``name`` with ``robot`` (unwrapped); an unknown name: one-line ConfigError listing the valid ones."""
    return get_task(name).env(robot=robot, **kwargs)
