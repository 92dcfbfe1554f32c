"""Code from outside the package that registers with gloverec's registries (tasks: envs/tasks/registry.py,
fusion filters: recorder/fusion/registry.py, glove sources: recorder/glove/config.py, wrist sources:
recorder/wrist/config.py), loaded once, the first time a registry is asked for a name. Two ways, so that a
command in a child process finds it too:

- the environment variable ``GLOVEREC_PLUGINS``: modules to import, comma-separated (``my_lab.tasks,my_lab.imu``;
  on ``PYTHONPATH`` or installed), for a module you are writing;
- the entry-point group ``gloverec.plugins`` of an installed distribution (in its pyproject.toml:
  ``[project.entry-points."gloverec.plugins"] my_tasks = "my_lab.tasks"``), for one you ship.

A plugin module registers by importing and calling the registries' decorators (docs/envs.md "Adding a task",
docs/fusion.md "Adding a filter", docs/recording.md "Adding a glove source", docs/wrist.md "Adding a wrist
source"). A module that does not import, or fails while importing, is a one-line error naming it.
"""

from __future__ import annotations

import importlib
import os
from importlib.metadata import entry_points

from recorder import GloverecError, one_line

PLUGINS_ENV = "GLOVEREC_PLUGINS"
ENTRY_POINTS = "gloverec.plugins"
_loaded = False


def load_plugins() -> list[str]:
    """Import every plugin module (once per process); returns their names."""
    global _loaded
    if _loaded:
        return []
    _loaded = True  # first: a plugin that asks a registry for a name while importing does not recurse
    names = [n.strip() for n in os.environ.get(PLUGINS_ENV, "").split(",") if n.strip()]
    for name in names:
        _import(name, f"${PLUGINS_ENV}")
    for ep in entry_points(group=ENTRY_POINTS):
        _import(ep.value, f"entry point {ep.name!r} of group {ENTRY_POINTS}")
        names.append(ep.value)
    return names


def _import(module: str, where: str) -> None:
    try:
        importlib.import_module(module.partition(":")[0])
    except GloverecError:
        raise
    except Exception as exc:  # noqa: BLE001  (whatever a plugin raises: the user needs its name and one line)
        raise GloverecError(
            f"cannot load the plugin {module} ({where}): {type(exc).__name__}: {one_line(exc)}"
        ) from None
