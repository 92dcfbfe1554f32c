"""What every wrist source shares: a reader thread that queues (WristPose, arrival time) pairs, ``take()`` for
whoever consumes them, the counters `gloverec wrist` reports, and a context manager that opens and closes it."""

from __future__ import annotations

import threading
from collections import deque


class WristSource:
    """Subclasses set ``name``, open what they read in ``_open()`` (raising GloverecError in one line) and
    release it in ``_release()``, and queue poses from ``_run()`` (the thread) with ``self._queue.append``."""

    name = "wrist"

    def __init__(self):
        self.bad = 0  # messages that were not wrist poses
        self.late = 0  # older than the newest pose
        self.last_error: str | None = None
        self.finished = False  # a live stream never finishes; a video does at its end
        self._queue: deque = deque(maxlen=4096)  # (pose, arrival, Unix s)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def open(self):
        args = self._open()
        self._thread = threading.Thread(target=self._run, args=args, name=f"wrist {self.name}", daemon=True)
        self._thread.start()
        return self

    def _open(self) -> tuple:  # what ``_run`` is called with
        return ()

    def _run(self, *args) -> None:
        raise NotImplementedError

    def _release(self) -> None:
        pass

    def take(self) -> list:
        """The poses that arrived since the last call, each with its arrival time (Unix s)."""
        out = []
        while self._queue:
            out.append(self._queue.popleft())
        return out

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
        self._release()

    def __enter__(self):
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()
