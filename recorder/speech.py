"""LeRobot's spoken prompts on this machine. lerobot-record and lerobot-replay speak ("Recording episode 0",
"Stop recording") with the system's speech command, ``spd-say`` on Linux, unless ``--play_sounds=false``; where
it is not installed (a plain Debian), the prompt raises FileNotFoundError, and at the end of lerobot-record that
happens before the dataset is finalised: meta/tasks.parquet is never written and every episode is lost. The
plugins warn once when they connect in such a process (``warn_if_prompts_will_fail``)."""

from __future__ import annotations

import logging
import platform
import shutil
import sys

_warned = False
_OFF = {"false", "0", "no", "off"}


def sounds_on(argv: list[str] | None = None) -> bool:
    """Whether the LeRobot command line in ``argv`` (default: this process') leaves its prompts spoken."""
    args = list(sys.argv if argv is None else argv)
    for i, arg in enumerate(args):
        if arg.startswith("--play_sounds="):
            return arg.split("=", 1)[1].strip().lower() not in _OFF
        if arg == "--play_sounds" and i + 1 < len(args):
            return args[i + 1].strip().lower() not in _OFF
    return True  # LeRobot's default


def warn_if_prompts_will_fail(who: str, argv: list[str] | None = None) -> str | None:
    """Once per process: a warning line when the prompts are on and the speech command is missing (Linux)."""
    global _warned
    if _warned or platform.system() != "Linux" or shutil.which("spd-say") is not None or not sounds_on(argv):
        return None
    _warned = True
    text = (
        f"{who}: spd-say is not installed and --play_sounds is on: LeRobot's spoken prompts will fail, and at the "
        "end of lerobot-record before the dataset is finalised (every episode lost); pass --play_sounds=false "
        "(or install speech-dispatcher)"
    )
    logging.getLogger(__name__).warning(text)
    print(f"warning: {text}", file=sys.stderr, flush=True)
    return text
