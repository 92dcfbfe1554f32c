"""The layer contract (pyproject.toml [tool.importlinter], docs/decisions.md) holds, and it catches a wrong arrow:
the same tree with one upward import added fails it."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT = [
    sys.executable,
    "-c",
    "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())",
]


def _lint(tree: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(tree))
    return subprocess.run([*LINT, "--no-cache"], cwd=tree, env=env, capture_output=True, text=True, timeout=300)


def _copy(tmp_path: Path) -> Path:
    tree = tmp_path / "tree"
    for name in ("recorder", "envs", "policies"):
        shutil.copytree(ROOT / name, tree / name, ignore=shutil.ignore_patterns("__pycache__", "plugin"))
    shutil.copy(ROOT / "pyproject.toml", tree)
    return tree


@pytest.mark.process
def test_the_layers_hold_and_a_wrong_arrow_breaks_them(tmp_path):
    tree = _copy(tmp_path)
    r = _lint(tree)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "2 kept, 0 broken" in r.stdout
    frames = tree / "recorder" / "protocol" / "frames.py"  # the wire format now reaches up to the recorder
    frames.write_text(frames.read_text() + "\n\ndef _up():\n    from recorder.record import store  # noqa\n")
    r = _lint(tree)
    assert r.returncode != 0 and "recorder.protocol is not allowed to import recorder.record" in r.stdout, r.stdout
