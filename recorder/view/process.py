"""A live view beside a command, never in its way: ``open_view(spec, ...)`` starts the view in a process of its
own (a fresh interpreter at lower scheduling priority, so its software rendering takes only the CPU the command
leaves; ``GLOVEREC_VIEW_PRIORITY=normal`` lets it compete with the command instead), hands it frames through a
latest-frame slot (recorder/view/state.py: ``publish`` copies a few kilobytes and never waits), and passes its
keys and buttons back as requests (``on_event``). View frames are dropped when the view is slow; the command's own
frames never are.

View specs: ``native`` (MuJoCo's viewer; needs a display), ``web[:PORT]`` or ``web:HOST:PORT`` (a page on
127.0.0.1:8765 by default), ``rerun[:spawn|serve|connect|save[:TARGET]]`` (recorder/view/rerun_view.py),
``none``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import socket
import sys
import threading
import time
from dataclasses import dataclass

from recorder.config import ConfigError
from recorder.view.state import Layout, SharedFrame, ViewFrame

KINDS = ("native", "web", "rerun", "none")
RERUN_MODES = ("spawn", "serve", "connect", "save")
WEB_PORT = 8765
NICE = 10  # the view's scheduling priority below the command's
PRIORITY_ENV = "GLOVEREC_VIEW_PRIORITY"
PRIORITIES = ("idle", "normal")  # idle: only the CPU the command leaves (default); normal: competes with it


@dataclass(frozen=True)
class ViewSpec:
    kind: str = "none"
    host: str = "127.0.0.1"
    port: int = WEB_PORT
    mode: str = "save"  # rerun: spawn | serve | connect | save
    target: str | None = None  # rerun: the port, URL or file

    @classmethod
    def parse(cls, text: str) -> ViewSpec:
        kind, _, rest = str(text).strip().partition(":")
        if kind not in KINDS:
            raise ConfigError(f"unknown view {text!r}; valid: {', '.join(KINDS)} (web:PORT, rerun:MODE)")
        if kind == "web" and rest:
            host, _, port = rest.rpartition(":")
            if not port.isdigit() or not 0 < int(port) < 65536:
                raise ConfigError(f"bad view {text!r}: expected web, web:PORT or web:HOST:PORT")
            return cls("web", host or "127.0.0.1", int(port))
        if kind == "rerun":
            mode, _, target = rest.partition(":")
            if mode and mode not in RERUN_MODES:
                raise ConfigError(f"bad view {text!r}: rerun modes are {', '.join(RERUN_MODES)}")
            return cls("rerun", mode=mode or ("spawn" if has_display() else "save"), target=target or None)
        if rest:
            raise ConfigError(f"bad view {text!r}: {kind} takes no options")
        return cls(kind)

    def __str__(self) -> str:
        if self.kind == "web":
            return f"web:{self.host}:{self.port}"
        if self.kind == "rerun":
            return f"rerun:{self.mode}" + (f":{self.target}" if self.target else "")
        return self.kind


def view_arg(text: str) -> str:
    """An argparse type: a valid view spec (argparse reports a bad one, listing the valid views)."""
    try:
        ViewSpec.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def default_view() -> tuple[str, str | None]:
    """(view, hint): native with a display and a terminal, else none with a line saying how to get one."""
    if has_display() and sys.stdin is not None and sys.stdin.isatty():
        return "native", None
    return "none", "no live view (no display or no terminal): pass --view web for one in a browser"


def priority(beside_realtime: bool = False) -> str:
    """The view's scheduling priority, from $GLOVEREC_VIEW_PRIORITY: ``idle`` (the view takes only the CPU the
    command leaves, and on a saturated machine draws nothing) or ``normal`` (it competes for the CPU like the
    command's other processes). By default ``normal`` beside a recording whose episodes run in the real-time class
    (``beside_realtime``: recorder/record/precedence.py; the loop then needs no yielding view, and an idle one
    drew 0 frames/s with both cores busy), else ``idle``."""
    value = os.environ.get(PRIORITY_ENV, "").strip().lower() or ("normal" if beside_realtime else "idle")
    if value not in PRIORITIES:
        raise ConfigError(f"${PRIORITY_ENV}={os.environ[PRIORITY_ENV]!r}: valid: {', '.join(PRIORITIES)}")
    return value


def check(spec: ViewSpec) -> None:
    """What can be refused before anything starts: one-line ConfigError."""
    priority()
    if spec.kind == "native" and not has_display():
        raise ConfigError("--view native needs a display (DISPLAY is not set): use --view web (a browser page)")
    if spec.kind == "web":
        with socket.socket() as s:
            # as the view's HTTP server binds (http.server's allow_reuse_address): a port whose last connections
            # wait out TIME-WAIT after a browser's session is free to serve again; one something listens on is not
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                s.bind((spec.host, spec.port))
            except OSError as exc:
                raise ConfigError(
                    f"cannot serve the view on {spec.host}:{spec.port}: {exc.strerror or exc} (pass --view web:PORT)"
                ) from None


class View:
    """A started view. ``publish(frame)`` never waits; ``on_event(name)`` is called (from a thread) for the
    view's keys and buttons: next, rerecord, reset, stop; ``say(line)`` for what the operator should read
    (where the page is, a view that failed)."""

    def __init__(self, spec: ViewSpec, stage: dict, layout: Layout, on_event=None, say=None, beside_realtime=False):
        self.spec = spec
        self.shared = SharedFrame.create(layout)
        ctx = mp.get_context("spawn")  # a fresh interpreter: the command's threads and locks are not copied
        self._conn, child = ctx.Pipe()
        self._closing = ctx.Event()
        self._proc = ctx.Process(
            target=_main, args=(spec, stage, self.shared.path, layout, child, self._closing, beside_realtime),
            name="gloverec-view",
            daemon=True,
        )  # fmt: skip
        self._proc.start()
        child.close()
        self._on_event, self._say = on_event, say or (lambda line: None)
        self._ready = threading.Event()
        self.stats: dict = {}  # the view's frame rate, reported as it ends
        self._thread = threading.Thread(target=self._listen, name="gloverec-view-events", daemon=True)
        self._thread.start()

    def wait_ready(self, timeout: float = 30.0) -> bool:
        """Wait until the view is up (or has failed): its start-up (a fresh interpreter loading MuJoCo) then
        stays out of the command's timed work."""
        return self._ready.wait(timeout)

    def publish(self, frame: ViewFrame) -> None:
        self.shared.write(frame)

    @property
    def alive(self) -> bool:
        return self._proc.is_alive()

    def close(self) -> None:
        self._closing.set()
        self._proc.join(5.0)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join(2.0)
        self._thread.join(1.0)
        self.shared.close()

    def _listen(self) -> None:
        while True:
            try:
                kind, value = self._conn.recv()
            except (EOFError, OSError):
                return
            if kind == "event" and self._on_event is not None:
                self._on_event(value)
            elif kind == "stats":
                self.stats = value
            elif kind in ("ready", "error"):
                self._ready.set()
                self._say(value)


def open_view(spec: ViewSpec | str, task: str, robot: str, layout: Layout, options: dict | None = None,
              hide_robot: bool = False, on_event=None, say=None, hand_size=None,
              beside_realtime: bool = False) -> View | None:  # fmt: skip
    """The view ``spec`` names for a scene of ``task`` on ``robot`` (None for ``none``); checked first.
    ``hand_size``: the wearer's HandSize, for the human hand (default: the reference hand). ``beside_realtime``:
    the command's loop runs in the real-time class (the view's default priority: ``priority``)."""
    spec = spec if isinstance(spec, ViewSpec) else ViewSpec.parse(spec)
    if spec.kind == "none":
        return None
    check(spec)
    stage = {"task": task, "robot": robot, "options": dict(options or {}), "hide_robot": hide_robot}
    if hand_size is not None:
        stage["hand_size"] = hand_size
    return View(spec, stage, layout, on_event, say, beside_realtime)


def _main(spec: ViewSpec, stage_args: dict, path: str, layout: Layout, conn, closing, beside_realtime) -> None:
    """The view process."""
    _step_aside(beside_realtime)
    from recorder.view.scene import Stage  # the view process's own imports (mujoco, the task)

    def send(kind: str, value) -> None:
        try:
            conn.send((kind, value))
        except (BrokenPipeError, OSError):
            pass

    shared = SharedFrame.attach(path, layout)
    meter = _Meter(send)
    try:
        stage = Stage(**stage_args)
        events = lambda name: send("event", name)  # noqa: E731
        if spec.kind == "native":
            from recorder.view import native  # GLFW: only with a display

            native.run(stage, shared, events, closing.is_set, ready=lambda text: send("ready", text), meter=meter)
        elif spec.kind == "web":
            from recorder.view import web  # the web view's modules: only for this view

            web.serve(stage, shared, events, closing.is_set, spec.host, spec.port,
                      ready=lambda url: send("ready", f"live view: {url}"), meter=meter)  # fmt: skip
        elif spec.kind == "rerun":
            from recorder.view import rerun_view  # rerun-sdk: only for this view

            rerun_view.run(stage, shared, events, closing.is_set, spec.mode, spec.target,
                           ready=lambda where: send("ready", f"live view: rerun, to {where}"), meter=meter)  # fmt: skip
    except Exception as exc:  # noqa: BLE001  (the view failing must not take the command down: say it once)
        send("error", f"the {spec.kind} view stopped: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}")
    finally:
        meter.report()
        shared.close()
        conn.close()


def _step_aside(beside_realtime: bool = False) -> None:
    """Take only the CPU the command leaves: the idle scheduling class where Linux has it (the process runs only
    when a core would otherwise idle), else a lower priority; and one software-rendering thread (Mesa's llvmpipe
    starts one per core, which would compete with the command on every core). At ``normal`` priority (``priority``)
    the process keeps the command's priority (still one rendering thread)."""
    os.environ.setdefault("LP_NUM_THREADS", "1")
    try:
        if priority(beside_realtime) == "normal":
            return
    except ConfigError:
        pass  # the command checked it before starting the view: idle, as by default
    try:
        os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):
        try:
            os.nice(NICE)
        except OSError:
            pass


class _Meter:
    """Counts the frames a view draws; ``report`` sends its frame rate back once (the benchmark reads it)."""

    def __init__(self, send):
        self.send, self.frames, self.first, self.last, self.done = send, 0, None, None, False

    def tick(self) -> None:
        now = time.monotonic()
        self.first = self.first if self.first is not None else now
        self.last, self.frames = now, self.frames + 1

    def report(self) -> None:
        if not self.done:
            self.done = True
            span = (self.last - self.first) if self.frames > 1 else 0.0
            self.send("stats", {"frames": self.frames, "fps": (self.frames - 1) / span if span > 0 else 0.0})
