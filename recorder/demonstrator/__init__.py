"""Scripted demonstrators: human-like hand motion that solves a task, as a Motion-like object.

``make_demonstrator(task)`` -> an object with ``plan(env, seed) -> DemoMotion`` for a reset env of that task.
A DemoMotion drives a Retargeter directly, or a SyntheticGlove / the glove emulator, so that demonstrations
carry the glove's sensor noise and latency through the whole stack. ``rollout`` runs and scores them.
"""

from __future__ import annotations

from recorder.demonstrator.grasp import GraspDemoConfig, GraspDemonstrator
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.pose import PoseDemoConfig, PoseDemonstrator

DEMONSTRATORS = {"pose": PoseDemonstrator, "grasp": GraspDemonstrator}

__all__ = [
    "DEMONSTRATORS",
    "DemoMotion",
    "GraspDemoConfig",
    "GraspDemonstrator",
    "PoseDemoConfig",
    "PoseDemonstrator",
    "make_demonstrator",
]


def make_demonstrator(task: str):
    if task not in DEMONSTRATORS:
        raise ValueError(f"no demonstrator for task {task!r}; valid tasks: {', '.join(DEMONSTRATORS)}")
    return DEMONSTRATORS[task]()
