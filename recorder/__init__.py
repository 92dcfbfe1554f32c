"""gloverec recorder: glove link, fusion, hand model, retargeting, the recording loop and the local hub.

Data flows one way through the subpackages, which are layers (docs/decisions.md; `lint-imports` checks them):
``protocol`` (bytes <-> frames) -> ``link``, ``log`` (ports, threads, clocks; session logs) -> ``hand`` (the
16-segment hand model, HandPose) -> ``fusion`` -> ``glove`` (open_glove) -> (envs.robots) -> ``retarget`` ->
(envs.tasks) -> ``emulator``, ``demonstrator`` (the emulated wearer) -> ``view`` -> ``record``, ``calibrate``,
``hub`` -> (policies) -> ``cli``.
"""

__version__ = "0.1.0"


class GloverecError(Exception):
    """An error the CLI reports as one line and a non-zero exit (bad input, missing port, ...)."""


def one_line(exc: BaseException) -> str:
    """An exception's message as one short line (its first), or its type's name when it has none."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def loading(what: str) -> None:
    """Say that a command now loads its heavy modules (``what``: seconds of them), once its quick checks have
    passed: the person who pressed Enter sees it has started. On a terminal only: where stderr is a pipe or a
    file, a script reads a failure as one line."""
    import sys

    if sys.stderr is not None and sys.stderr.isatty():
        print(f"loading {what}…", file=sys.stderr, flush=True)
