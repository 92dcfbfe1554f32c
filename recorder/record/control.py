"""Episode control from the keyboard, over SSH and headless: the keys lerobot-record uses, read from stdin.

On a terminal, stdin is put in cbreak mode and single keys act at once: → (or n, Enter) ends the episode and
saves it, ← (or r) re-records it, Esc (or q) stops the session after saving what is done, z re-takes host
fusion's reference pose (hold the hand in it), t passes control between the policy and the wearer in a takeover
recording. When stdin is not a terminal (a pipe, a script), whole lines do the same: "next", "rerecord", "stop",
"zero" (or "reset"), "takeover". The glove's reset button (an event frame) ends the
episode like → and re-takes the reference pose like z.
"""

from __future__ import annotations

import os
import select
import sys
import termios
import threading
import tty

NEXT, RERECORD, STOP, RESET, TAKEOVER = "next", "rerecord", "stop", "reset", "takeover"

_KEYS = {
    b"\x1b[C": NEXT,
    b"n": NEXT,
    b"\n": NEXT,
    b"\r": NEXT,
    b"\x1b[D": RERECORD,
    b"r": RERECORD,
    b"\x1b": STOP,
    b"q": STOP,
    b"z": RESET,
    b"t": TAKEOVER,
}
_LINES = {
    "next": NEXT,
    "n": NEXT,
    "": NEXT,
    "rerecord": RERECORD,
    "r": RERECORD,
    "stop": STOP,
    "q": STOP,
    "zero": RESET,
    "reset": RESET,
    "z": RESET,
    "takeover": TAKEOVER,
    "t": TAKEOVER,
}


class Control:
    """Collects requests; the recording loop polls ``take()`` once per frame."""

    def __init__(self, stdin=None, enabled: bool = True):
        self._lock = threading.Lock()
        self._pending: list[str] = []
        self._stdin = stdin if stdin is not None else sys.stdin
        self._saved_tty = None
        self._resetters: list = []
        self._stop = threading.Event()
        self._thread = None
        if enabled and self._stdin is not None and not self._stdin.closed:
            self._thread = threading.Thread(target=self._run, daemon=True, name="gloverec-keys")
            self._thread.start()

    def on_reset(self, fn) -> None:
        """Call ``fn()`` (from the key reader's thread: it must only flag the reset) for every RESET request,
        instead of queueing it for ``take()``."""
        self._resetters.append(fn)

    def request(self, what: str) -> None:
        if what == RESET and self._resetters:
            for fn in self._resetters:
                fn()
            return
        with self._lock:
            self._pending.append(what)

    def take(self) -> str | None:
        """The oldest request, or None."""
        with self._lock:
            return self._pending.pop(0) if self._pending else None

    def close(self) -> None:
        self._stop.set()
        if self._saved_tty is not None:
            termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved_tty)
            self._saved_tty = None

    # ---------------------------------------------------------------- reader thread
    def _run(self) -> None:
        try:
            self._fd = self._stdin.fileno()
        except (OSError, ValueError):
            return
        if os.isatty(self._fd):
            self._saved_tty = termios.tcgetattr(self._fd)
            tty.setcbreak(self._fd)
            self._keys()
        else:
            self._lines()

    def _keys(self) -> None:
        buf = b""
        while not self._stop.is_set():
            ready, _, _ = select.select([self._fd], [], [], 0.1)
            if not ready:
                if buf == b"\x1b":  # a lone Esc, not the start of an arrow key
                    self.request(STOP)
                buf = b""
                continue
            data = os.read(self._fd, 16)
            if not data:
                return
            buf = self._parse(buf + data)

    def _parse(self, buf: bytes) -> bytes:
        """Act on the complete keys in ``buf``; return an incomplete escape sequence to wait on."""
        while buf:
            if buf.startswith(b"\x1b["):
                if len(buf) < 3:
                    return buf
                key, buf = buf[:3], buf[3:]
            elif buf.startswith(b"\x1b") and len(buf) == 1:
                return buf
            else:
                key, buf = buf[:1], buf[1:]
            if key in _KEYS:
                self.request(_KEYS[key])
        return b""

    def _lines(self) -> None:
        # the descriptor's bytes, not stdin's readline: that buffers every line a read brings, and select() would
        # then wait for more input with the second of two lines that came together ("next\nstop\n") unread
        buf = b""
        while not self._stop.is_set():
            ready, _, _ = select.select([self._fd], [], [], 0.1)
            if not ready:
                continue
            data = os.read(self._fd, 4096)
            if not data:
                return  # end of input: counts and durations drive the session
            *lines, buf = (buf + data).split(b"\n")
            for line in lines:
                what = _LINES.get(line.decode(errors="replace").strip().lower())
                if what:
                    self.request(what)
