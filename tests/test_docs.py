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

Each run block runs as a bash script (`set -e`; background jobs stopped at its end) in a working folder of its own,
with the document's write= blocks before it written there, HF_HUB_OFFLINE=1 and MUJOCO_GL=egl, and with only these
substitutions, so a user's command and the tested one stay the same:
- folders and ports: /tmp/... -> the working folder (/tmp/glove: its glove link), /dev/ttyACM0 -> an emulated glove
  started for the block on a pseudo-terminal in the working folder; configs/... (a file of the repository, as a
  user at its root names it) -> the checkout's;
- fewer and shorter: --episodes, --dataset.num_episodes and --eval.n_episodes at most 2, --steps at most 50,
  --duration at most 2 s, lerobot-record's --dataset.episode_time_s at most 3 s and --dataset.reset_time_s at most 1 s,
  lerobot-teleoperate's --teleop_time_s at most 2 s.
Each `gloverec` command runs through the test zygote's `gloverec` (tests/zygote.py: the same command in a process of
its own, forked from one that has done the imports); lerobot-* and every other command start as they would for a
user. A command that fails, or prints a traceback (but the one LeRobot prints on purpose when it finds no
display), fails the test with its output.
"""

from __future__ import annotations

import pytest
from docs_runner import DOCS, ROOT, blocks, run_blocks_of, substitute


def test_every_block_says_what_it_is():
    """A block of commands without a mark could be forgotten by this test: each must say run, hardware or
    synopsis; text and Python blocks need no mark."""
    unmarked = [
        b.where for d in DOCS for b in blocks(d) if b.lang in ("", "sh", "bash", "console", "shell") and b.kind is None
    ]
    assert not unmarked, f"fenced command blocks without a mark (run, hardware, slow, synopsis, ```text): {unmarked}"
    assert sum(b.kind == "run" for d in DOCS for b in blocks(d)) >= 5


# a block whose folder other tests read runs on their worker (xdist's loadgroup), so that none of them waits idle
GROUPS = {"lerobot.md": "lerobot.md"}
RUNS = [
    pytest.param(d, k, id=b.where, marks=[pytest.mark.xdist_group(GROUPS[d.name])] if d.name in GROUPS else [])
    for d in DOCS
    for k, b in enumerate(run_blocks_of(d))
]


@pytest.mark.process
@pytest.mark.parametrize("doc, index", RUNS)
def test_documented_commands_run_as_written(doc, index, docs_run):
    """Each run block (the conftest's docs_run: once per test run, so the tests that check what those commands
    made, e.g. tests/test_lerobot_plugins.py, read the same folder)."""
    name = doc.name if doc.parent.name == "docs" else doc.relative_to(ROOT).as_posix()
    work = docs_run(name, index)
    assert (work / ".ran").read_text().strip() == run_blocks_of(doc)[index].where


def test_the_substitutions_are_only_the_documented_ones(tmp_path):
    text = "gloverec record --episodes 20 --steps 3000 --glove /tmp/glove --plot /tmp/ep0.png --dataset.num_episodes=1"
    assert substitute(text, tmp_path) == (
        f"gloverec record --episodes 2 --steps 50 --glove {tmp_path}/glove --plot {tmp_path}/ep0.png "
        "--dataset.num_episodes=1"
    )
    assert substitute("gloverec train --config configs/train/history.yaml --out /tmp/x", tmp_path) == (
        f"gloverec train --config {ROOT}/configs/train/history.yaml --out {tmp_path}/x"
    )
