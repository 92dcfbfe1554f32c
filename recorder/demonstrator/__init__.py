"""Scripted demonstrators: human-like hand motion that solves a task, as a Motion-like object.

``make_demonstrator(task)`` -> an object with ``plan(env, seed) -> DemoMotion`` for a reset env of that task: the
demonstrator the task registry (envs/tasks/registry.py) names.
A DemoMotion drives a Retargeter directly, or a SyntheticGlove / the glove emulator, so that demonstrations
carry the glove's sensor noise and latency through the whole stack. recorder/rig/rollout.py runs and scores them.
"""

from __future__ import annotations

import importlib
from dataclasses import replace

from envs.tasks.registry import get_task
from recorder.config import ConfigError
from recorder.demonstrator.grasp import GraspDemoConfig, GraspDemonstrator
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.pose import PoseDemoConfig, PoseDemonstrator

__all__ = [
    "DemoMotion",
    "GraspDemoConfig",
    "GraspDemonstrator",
    "PoseDemoConfig",
    "PoseDemonstrator",
    "demonstrator_class",
    "make_demonstrator",
]


def demonstrator_class(task: str) -> type:
    """The scripted demonstrator the task registry names for ``task`` (a class, or "module:Class" imported here);
    a task without one, or an unknown task: one-line ConfigError."""
    spec = get_task(task)
    found = spec.demonstrator
    if found is None:
        raise ConfigError(f"task {task!r} has no scripted demonstrator: record it with a glove")
    if isinstance(found, str):
        module, _, name = found.partition(":")
        found = getattr(importlib.import_module(module), name)
    return found


DEMONSTRATORS = ("scripted", "human")


def make_demonstrator(task: str, kind: str = "scripted", failure_rate: float | None = None, watches: bool = True):
    """The task's scripted demonstrator, or with ``kind="human"`` its human-like one (recorder/demonstrator/human.py;
    ``failure_rate``: the share of takes it gets wrong, default 15 %). ``watches=False``: the open-loop wearer, who
    never looks at the robot hand (where the demonstrator's config has a ``sight``: recorder/demonstrator/
    watching.py). An unknown kind, or a task without a human-like demonstrator: one-line ConfigError."""
    demo = _make(task, kind, failure_rate)
    if not watches and getattr(demo.config, "sight", None) is not None:
        demo.config = replace(demo.config, sight=None)
    return demo


def _make(task: str, kind: str, failure_rate: float | None):
    if kind == "scripted":
        return demonstrator_class(task)()
    if kind != "human":
        raise ConfigError(f"unknown demonstrator {kind!r}; valid: {', '.join(DEMONSTRATORS)}")
    from recorder.demonstrator.human import HUMAN, HumanConfig  # every task's scripted one: loaded when asked for

    if task not in HUMAN:
        raise ConfigError(f"task {task!r} has no human-like demonstrator yet (it has: {', '.join(HUMAN)})")
    if failure_rate is not None and not 0.0 <= failure_rate <= 1.0:
        raise ConfigError(f"failure rate {failure_rate:g}: expected a share from 0 to 1")
    return HUMAN[task](HumanConfig() if failure_rate is None else HumanConfig(failure_rate=failure_rate))
