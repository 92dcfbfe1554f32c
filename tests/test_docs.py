"""The documentation's commands, run as written. Every fenced block of README.md, docs/*.md and firmware/README.md
says what it is in its info string, after the language:

    ```sh run            commands that run here with the emulated glove: this test runs them
    ```sh hardware       commands that need a real glove, a Teensy or another machine: not run
    ```sh slow           commands that run here but not in this test (a second firmware build: make test has one)
    ```text synopsis     a command's flags, placeholders in capitals: not run
    ```text              a diagram, a tree, an output: not run
    ```python write=F    a module (or ```yaml write=F, a config) the run blocks after it use: written to F in their
                         working folder
    ```python            an example in Python: not run (tests/plugins/ holds the ones the tests run)

A document's run blocks run in order, each as a bash script (`set -e`; background jobs stopped at its end), in one
working folder per document, with HF_HUB_OFFLINE=1 and MUJOCO_GL=egl, and with only these substitutions, so a
user's command and the tested one stay the same:
- folders and ports: /tmp/... -> the working folder (/tmp/glove: its glove link), /dev/ttyACM0 -> an emulated glove
  started for the block on a pseudo-terminal in the working folder;
- fewer and shorter: --episodes and --dataset.num_episodes at most 2, --steps at most 50, --duration at most 2 s,
  lerobot-record's --dataset.episode_time_s at most 3 s and --dataset.reset_time_s at most 1 s,
  lerobot-teleoperate's --teleop_time_s at most 2 s.
A command that fails, or prints a traceback (but the one LeRobot prints on purpose when it finds no display), fails
the test with its output.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "firmware" / "README.md"]
KINDS = {"run", "hardware", "slow", "synopsis"}
FENCE = re.compile(r"^```(?P<info>.*)$")
CAPS = {  # flag -> the most the test runs (fewer and shorter; see the module docstring)
    "--episodes": 2,
    "--dataset.num_episodes": 2,
    "--steps": 50,
    "--duration": 2,
    "--dataset.episode_time_s": 3,
    "--dataset.reset_time_s": 1,
    "--teleop_time_s": 2,
}


@dataclass
class Block:
    doc: Path
    line: int
    lang: str
    marks: list[str]
    text: str

    @property
    def where(self) -> str:
        return f"{self.doc.relative_to(ROOT)}:{self.line}"

    @property
    def kind(self) -> str | None:
        return next((m for m in self.marks if m in KINDS or m.startswith("write=")), None)


def blocks(doc: Path) -> list[Block]:
    out, lines, i = [], doc.read_text().split("\n"), 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if m:
            info = m.group("info").split()
            j = i + 1
            while not lines[j].startswith("```"):
                j += 1
            out.append(Block(doc, i + 1, info[0] if info else "", info[1:], "\n".join(lines[i + 1 : j])))
            i = j
        i += 1
    return out


def test_every_block_says_what_it_is():
    """A block of commands without a mark could be forgotten by this test: each must say run, hardware or
    synopsis; text and Python blocks need no mark."""
    unmarked = [
        b.where for d in DOCS for b in blocks(d) if b.lang in ("", "sh", "bash", "console", "shell") and b.kind is None
    ]
    assert not unmarked, f"fenced command blocks without a mark (run, hardware, slow, synopsis, ```text): {unmarked}"
    assert sum(b.kind == "run" for d in DOCS for b in blocks(d)) >= 5


def substitute(text: str, work: Path) -> str:
    """The documented substitutions (module docstring)."""
    text = re.sub(r"(?<![\w./])/tmp/", f"{work}/", text).replace("/dev/ttyACM0", str(work / "ttyACM0"))
    for flag, cap in CAPS.items():
        text = re.sub(
            rf"({re.escape(flag)}[ =])(\d+(?:\.\d+)?)",
            lambda m, cap=cap: m.group(1) + (str(cap) if float(m.group(2)) > cap else m.group(2)),
            text,
        )
    return text


SCRIPT = """set -e
trap 'kill $(jobs -p) 2>/dev/null || true; wait 2>/dev/null || true' EXIT
{emulator}
{body}
"""
EMULATOR = (
    'gloverec emulate --link "{port}" >/dev/null & for i in $(seq 100); do [ -e "{port}" ] && break; sleep 0.05; done'
)


def _around_traceback(out: str) -> str:
    at = out.find("Traceback")
    return out[max(0, at - 500) : at + 3000] if at >= 0 else out[-6000:]


def _commands(text: str) -> str:
    """A block without its comments."""
    return "\n".join(line.split(" #")[0] for line in text.splitlines())


def run_blocks(doc: Path, work: Path) -> list[str]:
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl", "PYTHONPATH": str(work)}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"  # gloverec, lerobot-*, python
    ran = []
    for b in blocks(doc):
        if b.kind and b.kind.startswith("write="):
            (work / b.kind.removeprefix("write=")).write_text(b.text + "\n")
        if b.kind != "run":
            continue
        body = substitute(b.text, work)
        emulator = EMULATOR.format(port=work / "ttyACM0") if "/dev/ttyACM0" in _commands(b.text) else ""
        r = subprocess.run(["bash", "-c", SCRIPT.format(emulator=emulator, body=body)], cwd=work, env=env,
                           capture_output=True, text=True, timeout=600)  # fmt: skip
        out = r.stdout + r.stderr
        out = _without_headless_notice(out)
        assert r.returncode == 0 and "Traceback" not in out, (
            f"{b.where} failed ({r.returncode}):\n{body}\n---\n{out[-6000:]}"
        )
        ran.append(b.where)
    return ran


TRACEBACK = re.compile(r"Traceback \(most recent call last\):\n(?:[ \t].*\n)*.*")


def _without_headless_notice(out: str) -> str:
    """The output without the traceback LeRobot prints on purpose when it finds no display (is_headless)."""
    return TRACEBACK.sub(lambda m: "" if "in is_headless" in m.group(0) else m.group(0), out)


RUNNABLE = [d for d in DOCS if any(b.kind == "run" for b in blocks(d))]


@pytest.mark.process
@pytest.mark.parametrize("doc", RUNNABLE, ids=[str(d.relative_to(ROOT)) for d in RUNNABLE])
def test_documented_commands_run_as_written(doc, tmp_path):
    assert run_blocks(doc, tmp_path)


def test_the_substitutions_are_only_the_documented_ones(tmp_path):
    text = "gloverec record --episodes 20 --steps 3000 --glove /tmp/glove --plot /tmp/ep0.png --dataset.num_episodes=1"
    assert substitute(text, tmp_path) == (
        f"gloverec record --episodes 2 --steps 50 --glove {tmp_path}/glove --plot {tmp_path}/ep0.png "
        "--dataset.num_episodes=1"
    )
