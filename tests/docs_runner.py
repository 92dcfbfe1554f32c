"""The docs runner of tests/test_docs.py (its docstring says what the marks mean and which substitutions it makes):
``blocks(doc)`` parses a document's fenced blocks, ``run_block(doc, k, work)`` runs its k-th run block in ``work``."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "firmware" / "README.md"]
KINDS = {"run", "hardware", "slow", "synopsis"}
FENCE = re.compile(r"^```(?P<info>.*)$")
CAPS = {  # flag -> the most the test runs (fewer and shorter; see the module docstring)
    "--episodes": 2,
    "--dataset.num_episodes": 2,
    "--eval.n_episodes": 2,
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


def substitute(text: str, work: Path) -> str:
    """The documented substitutions (module docstring)."""
    text = re.sub(r"(?<![\w./])/tmp/", f"{work}/", text).replace("/dev/ttyACM0", str(work / "ttyACM0"))
    text = re.sub(r"(?<![\w./])configs/", f"{ROOT}/configs/", text)  # the checkout's, as from its root
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


def run_blocks_of(doc: Path) -> list[Block]:
    return [b for b in blocks(doc) if b.kind == "run"]


def run_block(doc: Path, index: int, work: Path) -> Block:
    """The index-th run block of ``doc``, in ``work``, after writing the doc's write= blocks that come before it
    (the modules and configs it uses); a failure, or a traceback, is an AssertionError with the output."""
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl", "PYTHONPATH": str(work)}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"  # gloverec, lerobot-*, python
    if env.get("GLOVEREC_TEST_BIN"):  # the zygote's `gloverec` (tests/zygote.py): the same command, imports paid once
        env["PATH"] = f"{env['GLOVEREC_TEST_BIN']}{os.pathsep}{env['PATH']}"
    b = run_blocks_of(doc)[index]
    for w in blocks(doc):
        if w.line < b.line and w.kind and w.kind.startswith("write="):
            (work / w.kind.removeprefix("write=")).write_text(w.text + "\n")
    body = substitute(b.text, work)
    emulator = EMULATOR.format(port=work / "ttyACM0") if "/dev/ttyACM0" in _commands(b.text) else ""
    r = subprocess.run(["bash", "-c", SCRIPT.format(emulator=emulator, body=body)], cwd=work, env=env,
                       capture_output=True, text=True, timeout=600)  # fmt: skip
    out = _without_headless_notice(r.stdout + r.stderr)
    assert r.returncode == 0 and "Traceback" not in out, (
        f"{b.where} failed ({r.returncode}):\n{body}\n---\n{_around_traceback(out)}"
    )
    (work / ".ran").write_text(b.where + "\n")
    return b


TRACEBACK = re.compile(r"Traceback \(most recent call last\):\n(?:[ \t].*\n)*.*")


def _without_headless_notice(out: str) -> str:
    """The output without the traceback LeRobot prints on purpose when it finds no display (is_headless)."""
    return TRACEBACK.sub(lambda m: "" if "in is_headless" in m.group(0) else m.group(0), out)
