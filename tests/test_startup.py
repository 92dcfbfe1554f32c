"""Start-up (issue 42): every check that needs no heavy import comes before torch and LeRobot load, and a person at
a terminal is told when they start loading. How fast: bench/startup.py, not here."""

import io
import json
import os
import subprocess
import sys

import pytest

import recorder.record.recorder as recorder_module
from conftest import REPO
from recorder import GloverecError
from recorder.cli import main

HEAVY = ("torch", "lerobot")

# a fresh interpreter: each command's exit code and the heavy modules loaded once it has failed
CHECK = """
import json, sys
from recorder.cli import main
out = {}
for name, argv in json.loads(sys.argv[1]).items():
    out[name] = [main(argv), sorted(m for m in HEAVY if m in sys.modules)]
print(json.dumps(out))
""".replace("HEAVY", repr(HEAVY))


def _record(root, *more) -> list[str]:
    return ["record", "--robot", "glovehand", "--task", "pose", "--repo-id", "t/startup", "--root", str(root),
            "--view", "none", *more]  # fmt: skip


@pytest.mark.process
def test_bad_paths_files_and_datasets_fail_before_torch_and_lerobot_load(tmp_path):
    empty, missing = tmp_path / "empty", tmp_path / "missing"
    empty.mkdir()
    (tmp_path / "hub").mkdir()
    cases = {
        "record: a port not plugged in": _record(tmp_path / "a", "--glove", "serial:/dev/nonexistent"),
        "record: a missing log": _record(tmp_path / "b", "--glove", f"mcap:{missing}.mcap"),
        "record: a folder without a policy": _record(tmp_path / "c", "--glove", "emulator", "--policy", str(empty)),
        "record: resume a folder that is no recording": _record(empty, "--glove", "emulator", "--resume"),
        "eval: a folder without a policy": ["eval", "--policy", str(empty), "--episodes", "1"],
        "train: a folder that is no dataset": [
            "train",
            "--repo-id",
            "t/x",
            "--root",
            str(empty),
            "--steps",
            "1",
            "--out",
            str(tmp_path / "out"),
        ],  # fmt: skip
        "train: no such dataset in the hub": [
            "train",
            "--repo-id",
            "t/x",
            "--hub",
            str(tmp_path / "hub"),
            "--steps",
            "1",
            "--out",
            str(tmp_path / "out"),
        ],  # fmt: skip
        "replay: a folder that is no dataset": ["replay", "--repo-id", "t/x", "--root", str(empty), "--episode", "0"],
        "inspect: no dataset": ["inspect", "--repo-id", "t/x", "--root", str(missing)],
    }
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    r = subprocess.run([sys.executable, "-c", CHECK, json.dumps(cases)], capture_output=True, text=True, env=env,
                       timeout=120, cwd=tmp_path)  # fmt: skip
    assert r.returncode == 0, r.stderr
    results = json.loads(r.stdout)
    assert {name: code for name, (code, _) in results.items()} == dict.fromkeys(cases, 1), r.stderr
    assert {name: loaded for name, (_, loaded) in results.items()} == dict.fromkeys(cases, []), r.stderr
    errors = r.stderr.splitlines()
    assert len(errors) == len(cases) and all(e.startswith("gloverec: error: ") for e in errors), r.stderr
    assert "no such port" in errors[0] and "no such file" in errors[1] and "holds no LeRobot policy" in errors[2]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_loading_is_said_on_a_terminal_once_the_checks_pass(tmp_path, monkeypatch):
    def stop(*_, **__):
        raise GloverecError("stopped before recording")

    monkeypatch.setattr(recorder_module, "record", stop)
    err = _Terminal()
    monkeypatch.setattr(sys, "stderr", err)
    assert main(_record(tmp_path / "ds", "--glove", "emulator")) == 1
    assert err.getvalue() == "loading LeRobot and MuJoCo…\ngloverec: error: stopped before recording\n"

    err.seek(0)
    err.truncate()
    assert main(_record(tmp_path / "ds", "--glove", "serial:/dev/nonexistent")) == 1  # a check failed: no loading
    assert err.getvalue() == "gloverec: error: cannot open serial:/dev/nonexistent: no such port\n"


def test_loading_is_not_said_to_a_pipe(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(recorder_module, "record", lambda *_, **__: (_ for _ in ()).throw(GloverecError("stop")))
    assert main(_record(tmp_path / "ds", "--glove", "emulator")) == 1
    assert capsys.readouterr().err == "gloverec: error: stop\n"
