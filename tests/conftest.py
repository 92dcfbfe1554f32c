import os
import signal
import subprocess
import sys
import time

import pytest

os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("MUJOCO_GL", "egl")


VIEWLESS = ("record", "calibrate")  # recorded without a live view here (`--view none`): CI has no display


def gloverec(*args: str, **kw) -> subprocess.CompletedProcess:
    """Run the CLI as a user would, in a child process (record and calibrate with `--view none` unless a test
    chooses a view)."""
    if args and args[0] in VIEWLESS and "--view" not in args:
        args = (args[0], "--view", "none", *args[1:])
    return subprocess.run(
        [sys.executable, "-m", "recorder.cli", *args],
        capture_output=True,
        text=True,
        timeout=kw.pop("timeout", 60),
        **kw,
    )


class EmulatorProcess:
    """`gloverec emulate` in a child process: a real pseudo-terminal, a real separate writer."""

    def __init__(self, *args: str):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "recorder.cli", "emulate", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        line = self.proc.stdout.readline()
        if not line.startswith("port: "):
            self.proc.kill()
            raise RuntimeError(f"emulator did not start: {line!r} {self.proc.stderr.read()}")
        self.port = line.split(": ", 1)[1].strip()

    def unplug(self):
        self.proc.send_signal(signal.SIGUSR1)

    def replug(self):
        self.proc.send_signal(signal.SIGUSR2)

    def stop(self) -> str:
        if self.proc.poll() is None:
            self.proc.terminate()
        try:
            _, err = self.proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            _, err = self.proc.communicate()
        return err


@pytest.fixture
def emulator(tmp_path):
    started = []

    def start(*args: str, link: bool = True) -> EmulatorProcess:
        extra = ("--link", str(tmp_path / f"glove{len(started)}")) if link else ()
        emu = EmulatorProcess(*args, *extra)
        started.append(emu)
        return emu

    yield start
    for emu in started:
        emu.stop()


def wait_for(predicate, timeout: float = 5.0, step: float = 0.02) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return predicate()


class CliResult(subprocess.CompletedProcess):
    pass


def cli(*args: str) -> CliResult:
    """Run `gloverec ARGS` in this process, for what no process boundary is part of (argument handling, error
    messages, inspect, the hub, training): its exit code, stdout and stderr as a child's would be. The global
    state a command sets (the SIGTERM handler, torch's thread count, the root logger's level) is put back."""
    import io
    import logging
    from contextlib import redirect_stderr, redirect_stdout

    import torch  # loaded first, so that its thread count can be put back (the policy commands set it)

    from recorder.cli import main

    out, err = io.StringIO(), io.StringIO()
    handler, level = signal.getsignal(signal.SIGTERM), logging.getLogger().level
    threads = torch.get_num_threads()
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:  # argparse: usage errors and --help
                code = exc.code if isinstance(exc.code, int) else 1
    finally:
        signal.signal(signal.SIGTERM, handler)
        logging.getLogger().setLevel(level)
        torch.set_num_threads(threads)
    return CliResult(["gloverec", *args], code, out.getvalue(), err.getvalue())
