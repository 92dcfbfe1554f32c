"""gloverec MuJoCo robot-hand environments (Gymnasium).

Importing ``envs`` registers ``gloverec/HandPose-v0`` and ``gloverec/HandGrasp-v0``; choose the robot with
``gym.make("gloverec/HandPose-v0", robot="shadow")``. Robots: ``envs.robots`` (an MJCF under envs/assets plus
configs/robots/<name>.yaml each); tasks: ``envs.tasks`` (configs/tasks/<name>.yaml for the defaults).
"""

from __future__ import annotations

import gymnasium as gym

from envs.robots import load_robot, robot_names
from recorder.config import ConfigError

__all__ = ["ENV_IDS", "check_names", "load_robot", "make", "robot_names", "task_names"]

ENV_IDS = {"pose": "gloverec/HandPose-v0", "grasp": "gloverec/HandGrasp-v0"}


def task_names() -> tuple[str, ...]:
    return tuple(ENV_IDS)


def check_names(robot: str | None = None, task: str | None = None) -> None:
    """The ``--robot`` and ``--task`` of a command: an unknown one is a one-line ConfigError listing the valid
    ones (commands check before loading lerobot and torch, which takes seconds)."""
    if robot is not None and robot not in robot_names() and not robot.endswith((".yaml", ".yml")):
        raise ConfigError(f"--robot {robot}: unknown robot; valid: {', '.join(robot_names())}")
    if task is not None and task not in ENV_IDS:
        raise ConfigError(f"--task {task}: unknown task; valid: {', '.join(ENV_IDS)}")


def make(task: str, robot: str = "glovehand", **kwargs) -> gym.Env:
    """``gym.make`` by task name (``pose``, ``grasp``); unknown names: one-line ValueError."""
    if task not in ENV_IDS:
        raise ConfigError(f"unknown task {task!r}; valid tasks: {', '.join(ENV_IDS)}")
    return gym.make(ENV_IDS[task], robot=robot, **kwargs)


def _register() -> None:
    for env_id, entry in (
        (ENV_IDS["pose"], "envs.tasks.hand_pose:HandPoseEnv"),
        (ENV_IDS["grasp"], "envs.tasks.hand_grasp:HandGraspEnv"),
    ):
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=entry,
                kwargs={"robot": "glovehand"},
                disable_env_checker=True,
                order_enforce=False,
            )


_register()
