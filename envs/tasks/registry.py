"""The task registry: a task is one module that defines its environment, a ``HandEnv`` subclass with its config
dataclass (``config_class``), and registers it with ``@register_task``. Every command finds tasks here:
`gloverec record --task`, `view`, `eval`, the LeRobot robot plugin (``--robot.task``), bench/envs.py and
bench/learning.py; an unknown name lists the registered ones. Tasks outside the package come in as plugins
(recorder/plugins.py: ``GLOVEREC_PLUGINS=module`` or the entry-point group ``gloverec.plugins``); docs/envs.md,
"Adding a task", is a worked example.

What the registry carries per task: its name, the environment class (and through it the config dataclass, the
instruction text of an episode, ``HandEnv.instruction``, and the environment-state names), the Gymnasium id, the
scripted demonstrator (a class, or "module:Class" for one in a layer above envs, which imports no layer above it:
recorder/demonstrator resolves it) and what a live view changes (``live``: options for `gloverec view`'s endless
scenes, e.g. no termination on success), and how its demonstrations split into segments for `gloverec
generate` (``segmentation``, envs/tasks/segments.py; a task without one cannot be generated from). What a view
draws besides comes from the environment's hooks: ``goal_qpos`` (a target drawn as a ghost) and ``schedule`` (the
next scripted move, "lift in 1.2 s").
"""

from __future__ import annotations

from dataclasses import dataclass, field

import gymnasium as gym

from recorder.config import ConfigError
from recorder.plugins import load_plugins


@dataclass(frozen=True)
class TaskSpec:
    name: str
    env: type  # the HandEnv subclass
    env_id: str  # its Gymnasium id (gym.make(env_id, robot=...))
    demonstrator: type | str | None = None  # the scripted demonstrator: a class or "module:Class"
    live: dict = field(default_factory=dict)  # options of `gloverec view`'s endless live scenes
    segmentation: object = None  # how its demonstrations split, for `gloverec generate` (envs/tasks/segments.py)

    @property
    def config_class(self) -> type:
        return self.env.config_class


_TASKS: dict[str, TaskSpec] = {}


def register_task(name: str, *, demonstrator: type | str | None = None, env_id: str | None = None,
                  live: dict | None = None, segmentation=None):  # fmt: skip
    """Class decorator: register a HandEnv subclass as task ``name`` (and with Gymnasium, as ``env_id``, by default
    ``gloverec/<ClassName without Env>-v0``). Registering a name twice is an error unless it is the same class."""

    def register(cls: type) -> type:
        old = _TASKS.get(name)
        if old is not None and old.env.__qualname__ != cls.__qualname__:
            raise ConfigError(f"task {name!r} is registered already (by {old.env.__module__}.{old.env.__qualname__})")
        spec = TaskSpec(name, cls, env_id or f"gloverec/{cls.__name__.removesuffix('Env')}-v0", demonstrator,
                        dict(live or {}), segmentation)  # fmt: skip
        cls.task_name = name
        _TASKS[name] = spec
        if spec.env_id in gym.registry:
            del gym.registry[spec.env_id]  # a module imported again (a plugin reloaded): the newest class
        gym.register(id=spec.env_id, entry_point=cls, kwargs={"robot": "glovehand"}, disable_env_checker=True,
                     order_enforce=False)  # fmt: skip
        return cls

    return register


def task_names() -> tuple[str, ...]:
    """The registered tasks, in the order they registered (the built-in ones first)."""
    load_plugins()
    return tuple(_TASKS)


def get_task(name: str) -> TaskSpec:
    """Task ``name``; an unknown one: one-line ConfigError listing the registered tasks."""
    load_plugins()
    if name not in _TASKS:
        raise ConfigError(f"unknown task {name!r}; valid tasks: {', '.join(_TASKS)}")
    return _TASKS[name]
