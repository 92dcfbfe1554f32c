import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from filelock import FileLock

from recorder.paths import CACHE_ENV, CALIBRATION_ENV, HUB_ENV
from recorder.plugins import PLUGINS_ENV
from recorder.view.process import PRIORITY_ENV

REPO = Path(__file__).resolve().parents[1]
FW_BUILD = REPO / "build" / "firmware"  # `make firmware`'s host build: make test builds and ctests it first

os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("MUJOCO_GL", "egl")
# Sealed from the checkout's and the user's data: the hub, calibrations and plugins come from where a test says,
# never from the environment the suite was started in (see `sealed` below for datasets/ under the directory).
for _name in (HUB_ENV, CALIBRATION_ENV, PLUGINS_ENV):
    os.environ.pop(_name, None)


VIEWLESS = ("record", "calibrate")  # recorded without a live view here (`--view none`): CI has no display


def gloverec(*args: str, **kw) -> subprocess.CompletedProcess:
    """Run the CLI as a user would, in a child process of its own (record and calibrate with `--view none` unless
    a test chooses a view): forked by this worker's zygote (tests/zygote.py: the imports paid once) unless the
    call sets anything but ``timeout`` and ``env``, its ``env`` changes a variable other than those read when a
    command runs (PER_CALL_ENV; the zygote puts $PYTHONPATH on sys.path as a fresh interpreter would), or
    GLOVEREC_TEST_FRESH=1 (a fresh interpreter for every command)."""
    if args and args[0] in VIEWLESS and "--view" not in args:
        args = (args[0], "--view", "none", *args[1:])
    timeout = kw.pop("timeout", 60)
    env = kw.get("env") or dict(os.environ)
    changed = {k for k in env.keys() | os.environ.keys() if env.get(k) != os.environ.get(k)}
    if _zygote is not None and set(kw) <= {"env"} and changed <= PER_CALL_ENV:
        return _zygote.run(list(args), env, timeout)
    return subprocess.run(
        [sys.executable, "-m", "recorder.cli", *args], capture_output=True, text=True, timeout=timeout, **kw
    )


# (the live view's priority: the command checks it as it runs, and its view, a fresh interpreter, reads it)
PER_CALL_ENV = {CALIBRATION_ENV, HUB_ENV, CACHE_ENV, PLUGINS_ENV, PRIORITY_ENV, "PYTHONPATH"}


class Zygote:
    """tests/zygote.py, started once per xdist worker: ``run(argv, env, timeout)`` is subprocess.run's answer for
    `gloverec ARGV` (captured text output, the exit code; on timeout the command is killed and TimeoutExpired
    raised)."""

    def __init__(self, folder: Path):
        from zygote import LEROBOT, SHIM

        self.path = str(folder / "zygote.sock")
        self.started: list[str] = []
        self.proc = subprocess.Popen([sys.executable, str(REPO / "tests" / "zygote.py"), self.path],
                                     stdout=subprocess.PIPE, text=True)  # fmt: skip
        line = self.proc.stdout.readline()
        if line.strip() != "ready":
            self.proc.kill()
            raise RuntimeError(f"the test zygote did not start: {line!r}")
        self.bin = folder / "bin"  # its `gloverec` and LeRobot's commands, first on the docs runner's PATH
        self.bin.mkdir()
        for name in ("gloverec", *LEROBOT):
            (self.bin / name).write_text(SHIM.format(python=sys.executable))
            (self.bin / name).chmod(0o755)

    def run(self, argv: list[str], env: dict, timeout: float) -> subprocess.CompletedProcess:
        import selectors
        import socket

        self.started.append(" ".join(["gloverec", *argv]))  # what pytest_runtest_call checks, as for Popen

        out_r, out_w = os.pipe()
        err_r, err_w = os.pipe()
        stdin = os.open(os.devnull, os.O_RDONLY)
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            conn.connect(self.path)
            request = json.dumps({"argv": argv, "env": env, "cwd": os.getcwd()}).encode() + b"\n"
            socket.send_fds(conn, [request], [stdin, out_w, err_w])
        finally:
            for fd in (stdin, out_w, err_w):
                os.close(fd)
        reply, chunks = b"", {out_r: [], err_r: []}
        end = time.monotonic() + timeout
        sel = selectors.DefaultSelector()
        for fd in (out_r, err_r, conn.fileno()):
            sel.register(fd, selectors.EVENT_READ)
        pid = code = None
        try:
            while code is None or out_r in sel.get_map() or err_r in sel.get_map():
                left = end - time.monotonic()
                if left <= 0:
                    if pid is not None:
                        os.kill(pid, signal.SIGKILL)
                    raise subprocess.TimeoutExpired(["gloverec", *argv], timeout)
                for key, _ in sel.select(min(left, 1.0)):
                    data = os.read(key.fd, 65536)
                    if key.fd == conn.fileno():
                        reply += data
                        if not data:
                            sel.unregister(key.fd)
                            code = 1 if code is None else code
                    elif data:
                        chunks[key.fd].append(data)
                    else:
                        sel.unregister(key.fd)
                for line in reply.decode().splitlines():
                    kind, _, value = line.partition(" ")
                    pid = int(value) if kind == "pid" else pid
                    code = int(value) if kind == "exit" else code
        finally:
            sel.close()
            conn.close()
            os.close(out_r)
            os.close(err_r)
        text = [b"".join(chunks[fd]).decode(errors="replace") for fd in (out_r, err_r)]
        return subprocess.CompletedProcess(["gloverec", *argv], code, text[0], text[1])

    def close(self) -> None:
        self.proc.kill()
        self.proc.wait(10)


_zygote: Zygote | None = None


@pytest.fixture(scope="session", autouse=True)
def sealed_worker(tmp_path_factory):
    """Every test process works in a folder of its own, so that no command reads or writes the checkout's
    `datasets/` (its hub, recordings and calibrations: a wrist mounting a user saved there once changed what a
    test's command printed). Session fixtures that run commands (shared recordings) run here too."""
    os.chdir(tmp_path_factory.mktemp("cwd"))


@pytest.fixture(autouse=True)
def sealed(tmp_path_factory, monkeypatch):
    """Each test's commands run in an empty working directory of the test's own (`datasets/` under it)."""
    monkeypatch.chdir(tmp_path_factory.mktemp("cwd"))


@pytest.fixture(scope="session", autouse=True)
def zygote(request, tmp_path_factory):
    """This worker's zygote, for ``gloverec``, when the run has a test that starts processes (not in `make check`)."""
    global _zygote
    wanted = any(item.get_closest_marker("process") for item in request.session.items)
    if os.environ.get("GLOVEREC_TEST_FRESH") == "1" or not wanted:
        yield None
        return
    _zygote = Zygote(tmp_path_factory.mktemp("zygote"))
    os.environ["GLOVEREC_TEST_ZYGOTE_SOCKET"] = _zygote.path
    os.environ["GLOVEREC_TEST_BIN"] = str(_zygote.bin)
    yield _zygote
    for name in ("GLOVEREC_TEST_ZYGOTE_SOCKET", "GLOVEREC_TEST_BIN"):
        os.environ.pop(name, None)
    _zygote.close()
    _zygote = None


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


def cli(*args: str, env: dict | None = None, **_) -> CliResult:
    """Run `gloverec ARGS` in this process, for what no process boundary is part of (argument handling, error
    messages, inspect, the hub, training): its exit code, stdout and stderr as a child's would be, with ``env``
    (variables set for the call). The global state a command sets (the SIGTERM and SIGINT handlers, torch's thread
    count, the root logger's level) is put back; other keyword arguments (a child's ``timeout``) are ignored."""
    import io
    import logging
    from contextlib import redirect_stderr, redirect_stdout

    import torch  # loaded first, so that its thread count can be put back (the policy commands set it)

    from recorder.cli import main

    out, err = io.StringIO(), io.StringIO()
    handlers, level = {n: signal.getsignal(n) for n in (signal.SIGTERM, signal.SIGINT)}, logging.getLogger().level
    threads = torch.get_num_threads()
    saved = {k: os.environ.get(k) for k in (env or {})}
    os.environ.update({k: str(v) for k, v in (env or {}).items()})
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:  # argparse: usage errors and --help
                code = exc.code if isinstance(exc.code, int) else 1
    finally:
        for n, handler in handlers.items():
            signal.signal(n, handler)
        logging.getLogger().setLevel(level)
        torch.set_num_threads(threads)
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return CliResult(["gloverec", *args], code, out.getvalue(), err.getvalue())


# ---------------------------------------------------------------- shared, built once per run


@pytest.fixture(scope="session")
def shared(tmp_path_factory, worker_id):
    """``shared(name, build)``: the folder ``build(path)`` makes, made once per test run and shared read-only by
    every test and every xdist worker (a session fixture runs once per worker: a file lock lets the first one
    build it and the others wait for it). Tests copy what they change."""
    base = tmp_path_factory.getbasetemp()
    base = (base.parent if worker_id != "master" else base) / "shared"
    base.mkdir(parents=True, exist_ok=True)

    def get(name: str, build) -> Path:
        path, done = base / name, base / f"{name}.done"
        with FileLock(str(base / f"{name}.lock")):
            if not done.exists():
                shutil.rmtree(path, ignore_errors=True)  # what a build that failed before left
                build(path)
                done.touch()
        return path

    return get


@pytest.fixture(scope="session")
def fw_build() -> Path:
    """The firmware core's host build (build/firmware, incremental: up to date after `make firmware`, built here
    otherwise, once, under a file lock); fails, never skips, without cmake and g++."""
    from recorder.emulator.firmware import FirmwareError, build_core

    with FileLock(str(FW_BUILD) + ".lock"):
        try:
            build_core(FW_BUILD, target=None, source_dir=REPO / "firmware")
        except FirmwareError as exc:
            pytest.fail(str(exc), pytrace=False)
    return FW_BUILD


POSE_REPO = "test/pose"


@pytest.fixture(scope="session")
def pose_recording(shared) -> tuple[Path, dict]:
    """A recording made once per test run, as a user makes it (`gloverec record`, the emulated glove, its session
    log): 4 HandPose episodes on glovehand, seeds 0-3, repo id test/pose. (root, the record command's summary);
    read-only: copy it to change it."""
    import json

    def build(path: Path) -> None:
        r = gloverec("record", "--episodes", "4", "--root", str(path / "ds"), "--repo-id", POSE_REPO, "--json",
                     timeout=240)  # fmt: skip
        assert r.returncode == 0, r.stderr
        (path / "summary.json").write_text(r.stdout.strip().splitlines()[-1])

    path = shared("pose_recording", build)
    return path / "ds", json.loads((path / "summary.json").read_text())


@pytest.fixture(scope="session")
def docs_run(shared):
    """``docs_run(name, k=0)``: the working folder in which the k-th run block of README.md or docs/NAME ran, as
    written (tests/docs_runner.py), once per test run; a failing block fails every test that asks for it."""
    from docs_runner import ROOT, run_block

    def get(name: str, index: int = 0) -> Path:
        doc = ROOT / name if name == "README.md" else ROOT / "docs" / name
        return shared(f"docs-{name}-{index}", lambda path: (path.mkdir(parents=True), run_block(doc, index, path)))

    return get


def pytest_configure(config):
    """Before parallel workers start (in the process that starts them): host fusion's numba kernels compiled once
    into their on-disk cache, so that the workers load them instead of each compiling the same kernels at once
    (cold, three workers compiling together cost minutes of CPU on two cores)."""
    if getattr(config, "workerinput", None) is None and config.getoption("numprocesses", default=None):
        from recorder.fusion.host import compile_every_filter

        compile_every_filter()


# ---------------------------------------------------------------- the mark: process (pyproject.toml)

SPAWNING_FIXTURES = {"emulator", "docs_run", "display"}  # a test that asks for one starts a process
_CHILDREN = ("python", "bash", "Xvfb", "xdotool", "chromium", "lerobot-", "gloverec")


def pytest_collection_modifyitems(items):
    for item in items:
        if SPAWNING_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.process)
    # The longest first, so that no worker starts a minute-long test while the others are out of work: the
    # documented blocks (the tests that read their results come later, when they are built), then the other tests
    # that start processes (many wait on real time), then the in-process ones that fill the gaps.
    items.sort(key=lambda item: 0 if item.nodeid.startswith("tests/test_docs.py::test_documented_commands") else
               1 if item.get_closest_marker("process") else 2)  # fmt: skip


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item):
    """A test not marked ``process`` that starts a child process of ours (the CLI, an emulator, a browser) fails,
    so that `make check` (not process) stays the in-process loop it says it is; fixtures may start them."""
    if item.get_closest_marker("process"):
        yield
        return
    started: list[str] = []
    original = subprocess.Popen.__init__

    def watch(self, args, *rest, **kw):
        first = str(args[0] if isinstance(args, (list, tuple)) else args).split()[0]
        if Path(first).name.startswith(_CHILDREN) or first == sys.executable:
            started.append(" ".join(map(str, args)) if isinstance(args, (list, tuple)) else str(args))
        original(self, args, *rest, **kw)

    subprocess.Popen.__init__ = watch
    forked = len(_zygote.started) if _zygote is not None else 0
    try:
        yield
    finally:
        subprocess.Popen.__init__ = original
    if _zygote is not None:
        started += _zygote.started[forked:]
    if started:
        pytest.fail(f"{item.nodeid} starts a child process ({started[0][:120]}): mark it @pytest.mark.process")
