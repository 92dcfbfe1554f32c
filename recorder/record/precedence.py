"""The recording loop's precedence over the rest of the machine, during a real-time episode.

On a loaded machine the loop's ticks wait for a core behind whatever else runs: a browser showing the web view,
a training job, a compiler. Measured on 2 cores with one busy job (docs/recording.md, "Priority"), the recorder's
threads waited 0.3-0.6 s per second in the run queue and its latency p99 rose from 10 ms to 20-130 ms; a lower
nice value (-10) left that wait at 0.1-0.4 s (the kernel's EEVDF scheduler wakes a sleeper by its deadline, and
the weight a nice value gives does not shorten that much), while the round-robin real-time class (``SCHED_RR``)
took it to about 1 ms and the latency p99 back to 10 ms. So an episode's latency path (the loop's thread and the
glove's: its link reader, the built-in emulator) runs in ``SCHED_RR`` at a low real-time priority:

- ``SCHED_RESET_ON_FORK``: processes and threads started from these threads (the view, the writer's encoders,
  torch's pool in a takeover) get the normal class, never this one;
- the loop sleeps between ticks and a real-time session never runs faster than its clock, so the class costs the
  rest of the machine only the loop's own work (the kernel keeps a share of every second for normal tasks anyway);
- faster-than-real-time sessions (which spin) never ask for it, and each episode gives it back as it ends.

Linux grants it to root and to users whose ``ulimit -r`` (RLIMIT_RTPRIO) allows it (``@audio - rtprio 95`` in
/etc/security/limits.conf, as audio programs ask); elsewhere the loop keeps the normal class and the session says
so once. ``$GLOVEREC_LOOP_PRIORITY=normal`` keeps the normal class on purpose. (No library does this: the standard
library's ``os.sched_setscheduler`` is the whole interface.)
"""

from __future__ import annotations

import os
import threading
from contextlib import contextmanager

from recorder.config import ConfigError

RT_PRIORITY = 10  # low among real-time priorities: the kernel's own threads and audio servers run above it
PRIORITY_ENV = "GLOVEREC_LOOP_PRIORITY"
PRIORITIES = ("realtime", "normal")
THREAD_PREFIX = "gloverec-"  # the glove's threads: its link reader (gloverec-<source>), the built-in emulator


def wanted() -> str:
    """``realtime`` (the default) or ``normal``, from $GLOVEREC_LOOP_PRIORITY."""
    value = os.environ.get(PRIORITY_ENV, "").strip().lower() or "realtime"
    if value not in PRIORITIES:
        raise ConfigError(f"${PRIORITY_ENV}={os.environ[PRIORITY_ENV]!r}: valid: {', '.join(PRIORITIES)}")
    return value


def _policy() -> int:
    return os.SCHED_RR | getattr(os, "SCHED_RESET_ON_FORK", 0)


def available() -> tuple[bool, str | None]:
    """Whether episodes will run in the real-time class, and if not, the line that says why (None when that was
    asked for)."""
    if wanted() == "normal":
        return False, None
    if not hasattr(os, "sched_setscheduler"):
        return False, "the recording loop runs at normal priority (no real-time scheduling on this system)"
    try:
        old = os.sched_getscheduler(0), os.sched_getparam(0)
        os.sched_setscheduler(0, _policy(), os.sched_param(RT_PRIORITY))
        os.sched_setscheduler(0, *old)
    except OSError:
        return False, (
            "the recording loop runs at normal priority (this user may not use real-time scheduling: `ulimit -r` "
            "is 0): on a busy machine its frames may come late; docs/recording.md, Priority, says how to allow it"
        )
    return True, None


def _latency_threads() -> list[int]:
    """The calling thread (the loop) and the glove's threads, by their native ids."""
    ids = [threading.get_native_id()]
    for t in threading.enumerate():
        if t.name.startswith(THREAD_PREFIX) and t.native_id is not None and t.native_id not in ids:
            ids.append(t.native_id)
    return ids


@contextmanager
def precedence(enabled: bool):
    """Inside, the loop's and the glove's threads run in the real-time class (``enabled``: what ``available``
    said); on leaving, each gets back the class it had. A thread that went away meanwhile is skipped."""
    saved = []
    if enabled:
        for tid in _latency_threads():
            try:
                old = os.sched_getscheduler(tid), os.sched_getparam(tid)
                os.sched_setscheduler(tid, _policy(), os.sched_param(RT_PRIORITY))
                saved.append((tid, old))
            except OSError:
                pass
    try:
        yield
    finally:
        for tid, (policy, param) in saved:
            try:
                os.sched_setscheduler(tid, policy, param)
            except OSError:
                pass
