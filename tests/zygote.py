"""A `gloverec` launcher for the tests that pays the interpreter's start-up once (tests/conftest.py ``gloverec``).

Importing what `gloverec record` needs (torch, LeRobot's dataset code, torchvision with torch._dynamo, MuJoCo,
the tasks) takes 6-8 s of CPU; the suite starts well over a hundred such commands on a 2-core machine, so start-up
was most of its time. The zygote (Android's name for the same idea) imports those modules once, stays
single-threaded, and forks a child per command, the way `multiprocessing`'s forkserver does. Each command still
runs in a process of its own, with its own stdio, environment, working directory, signals and exit code, through
the same ``recorder.cli.main`` the `gloverec` script calls (LeRobot's commands in the docs: their console
scripts' entry points); only the imports are shared. What a fresh interpreter's start-up does is tested where it
matters: the installed wheel (tests/test_wheel.py), every test that starts `python -m recorder.cli` itself, and the
whole suite with GLOVEREC_TEST_FRESH=1.

Protocol, over a Unix socket: the client (conftest's ``Zygote``, or the `gloverec` and `lerobot-*` that SHIM puts
first on the docs runner's PATH) sends one JSON line (argv, env, cwd, program) with its stdin, stdout and stderr as
file descriptors
(SCM_RIGHTS); the zygote forks a waiter, which forks the command, sends back "pid N\\n", waits for
it and sends "exit CODE\\n" (a negative code: killed by that signal, as subprocess reports it).
"""

from __future__ import annotations

import importlib
import importlib.metadata
import json
import os
import signal
import socket
import sys
import threading
import warnings

# What `gloverec record` imports before it forks its writer (recorder/record/writer.py): forking after them is what
# every recording does already. Their native threads (OpenBLAS's pool, pyarrow's jemalloc thread) handle a fork;
# what must not exist is a Python thread, or an OpenMP pool that torch started (none is, until torch computes).
# (LeRobot's dataset code and scipy's optimizer load when a recording opens its store or solves a posture, not with
# those modules: named here so that each command still finds them loaded)
PRELOAD = ("recorder.cli", "recorder.record.recorder", "recorder.fusion.session", "envs.tasks",
           "lerobot.datasets.lerobot_dataset", "recorder.record.episode_stats", "scipy.optimize")  # fmt: skip
# LeRobot's commands that the docs run (tests/docs_runner.py): after PRELOAD their imports take 0.3 s, where a fresh
# interpreter takes 5-8 s of CPU. Each has SHIM on the docs runner's PATH under its own name.
LEROBOT = ("lerobot-record", "lerobot-teleoperate", "lerobot-replay", "lerobot-train", "lerobot-edit-dataset",
           "lerobot-dataset-viz", "lerobot-eval")  # fmt: skip


def _command(argv: list[str], env: dict, cwd: str, program: str = "gloverec") -> int:
    """In the forked child: run ``PROGRAM ARGV`` as its script would (`gloverec`, or one of LeRobot's commands that
    the docs run: LEROBOT), exit with its code (atexit handlers run)."""
    import atexit
    import traceback

    os.chdir(cwd)
    extra = [os.path.abspath(d) for d in env.get("PYTHONPATH", "").split(os.pathsep) if d]
    sys.path[:1] = [cwd, *extra]  # as a fresh `python -m` has it: the working directory, then $PYTHONPATH
    os.environ.clear()
    os.environ.update(env)
    sys.argv = [program, *argv]
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGCHLD, signal.SIGPIPE):
        signal.signal(sig, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    code = 1
    try:
        if program == "gloverec":
            from recorder.cli import main

            code = main(argv) or 0
        else:  # the console script's entry point, as its launcher calls it (it reads sys.argv)
            (entry,) = importlib.metadata.entry_points(group="console_scripts", name=program)
            code = entry.load()() or 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except BaseException:  # noqa: BLE001  (what the interpreter would print, and its exit code)
        traceback.print_exc()
    try:
        atexit._run_exitfuncs()
        sys.stdout.flush()
        sys.stderr.flush()
    finally:
        os._exit(code)


def _serve_one(conn: socket.socket) -> None:
    """In the waiter (a child of the zygote): fork the command, report its pid and, once it ends, its exit code."""
    msg, fds, _, _ = socket.recv_fds(conn, 1 << 16, 3)
    while not msg.endswith(b"\n"):  # one JSON line, which a stream socket may deliver in parts
        part = conn.recv(1 << 16)
        if not part:
            os._exit(1)
        msg += part
    request = json.loads(msg)
    pid = os.fork()
    if pid == 0:
        conn.close()
        for target, fd in enumerate(fds):
            os.dup2(fd, target)
            os.close(fd)
        _command(request["argv"], request["env"], request["cwd"], request.get("program", "gloverec"))
    for fd in fds:
        os.close(fd)
    conn.sendall(f"pid {pid}\n".encode())
    _, status = os.waitpid(pid, 0)
    code = -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
    conn.sendall(f"exit {code}\n".encode())


def serve(path: str) -> None:
    for name in PRELOAD:
        importlib.import_module(name)
    if threading.active_count() != 1:  # a fork copies one thread: another's locks would stay held in the child
        raise SystemExit(f"zygote: {threading.active_count()} Python threads after the imports; forking is unsafe")
    warnings.filterwarnings("ignore", message=r"This process .* is multi-threaded")  # the native ones, above
    signal.signal(signal.SIGCHLD, signal.SIG_IGN)  # waiters are reaped by the kernel
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(path)
    server.listen(16)
    print("ready", flush=True)
    while True:
        conn, _ = server.accept()
        if os.fork() == 0:
            server.close()
            signal.signal(signal.SIGCHLD, signal.SIG_DFL)
            try:
                _serve_one(conn)
            finally:
                os._exit(0)
        conn.close()


# The `gloverec` (and LEROBOT's commands) on the docs runner's PATH (tests/docs_runner.py) while a zygote runs: it
# hands the command (the name it was called by), its environment and its stdio to the zygote, passes on the signals
# a shell sends (Ctrl-C, kill, a job's end), and ends as the command ended. {python} is this interpreter; -S: no
# site packages needed, a quick start.
SHIM = """#!{python} -S
import json, os, signal, socket, sys
conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
conn.connect(os.environ["GLOVEREC_TEST_ZYGOTE_SOCKET"])
request = {{"argv": sys.argv[1:], "env": dict(os.environ), "cwd": os.getcwd(),
           "program": os.path.basename(sys.argv[0])}}
socket.send_fds(conn, [json.dumps(request).encode() + b"\\n"], [0, 1, 2])
reply = conn.makefile("r")
pid = int(reply.readline().split()[1])
for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGUSR1, signal.SIGUSR2):
    signal.signal(sig, lambda s, _: os.kill(pid, s))
line = reply.readline()
code = int(line.split()[1]) if line.startswith("exit") else 1
if code < 0:
    signal.signal(-code, signal.SIG_DFL)
    os.kill(os.getpid(), -code)
sys.exit(code)
"""


if __name__ == "__main__":
    serve(sys.argv[1])
