"""The CLI as a user meets it: flags, first lines, one-line errors."""

import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import cli, gloverec
from recorder import quat
from recorder.link.serial_source import SerialSource
from recorder.protocol import PoseFrame


@pytest.mark.parametrize(
    "args, needle",
    [
        (["emulate", "--rate", "-5"], "must be positive"),
        (["emulate", "--output", "binary"], "invalid choice"),
        (["monitor"], "--glove"),
        (["bridge", "--glove", "x", "--udp", "nohost"], "HOST:PORT"),
        (["frobnicate"], "invalid choice"),
    ],
)
def test_usage_errors_are_one_line(args, needle):
    r = cli(*args)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and needle in r.stderr and "Traceback" not in r.stderr


@pytest.mark.parametrize(
    "command, old, new, value",
    [
        (["monitor"], "--port", "--glove", "udp:9000"),
        (["log", "--out", "s.mcap"], "--port", "--glove", "udp:9000"),
        (["bridge", "--udp", "host:9001"], "--port", "--glove", "udp:9000"),
        (["emulate"], "--mode", "--output", "raw"),
        (["view", "--glove", "emulator"], "--mode", "--retarget", "pinch"),
        (["record"], "--glove-mode", "--glove-output", "raw"),
        (["review", "--repo-id", "a/b"], "--port", "--http-port", "0"),
        (["wrist"], "--source", "--wrist", "udp:9100"),
        (["wrist", "--wrist", "marker:0"], "--camera", "--wrist-camera", "cam.json"),
    ],
)
def test_one_idea_one_flag_and_the_old_names_still_work(capsys, command, old, new, value):
    """The flags renamed so that one idea has one name across commands (docs/decisions.md): the old name parses
    to the same arguments, with a one-line note on stderr and nothing on stdout; usage shows the new name only."""
    from recorder.cli import build_parser

    parser = build_parser()
    given = parser.parse_args([*command, new, value])
    assert capsys.readouterr() == ("", "")
    assert vars(parser.parse_args([*command, old, value])) == vars(given)
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and f"{old} is now {new}" in err, err
    usage = next(a for a in parser._actions if a.dest == "command").choices[command[0]].format_usage()
    assert new in usage and old not in usage.replace(new, ""), usage


def test_bad_udp_source_is_one_line():
    r = cli("monitor", "--glove", "udp:notaport", "--duration", "1")
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "udp:PORT" in r.stderr


def test_emulator_prints_its_port_first_and_exposes_ground_truth(emulator, tmp_path):
    truth = tmp_path / "truth.npz"
    emu = emulator("--rate", "100", "--truth", str(truth), "--seed", "3")
    got = []
    with SerialSource(emu.port) as src:
        while len(got) < 100:
            f = src.read(timeout=2)
            assert f is not None
            if isinstance(f, PoseFrame):
                got.append(f)
    assert "ground truth of" in emu.stop()
    t = np.load(truth)
    by_seq = {int(s): i for i, s in enumerate(t["seq"])}
    assert all(f.seq in by_seq for f in got)
    idx = [by_seq[f.seq] for f in got]
    assert np.array_equal(t["t_us"][idx], [f.t_us for f in got])
    err = np.degrees(quat.angle_between(np.stack([f.quats for f in got]), t["rel_quats"][idx]))
    assert np.median(err) < 1.5 and err.max() < 5  # pose = truth + 0.5° RMS noise
    assert t["angles"].shape[1] == 20 and t["tips"].shape[1:] == (5, 3)


def test_log_then_play_back_through_the_cli(emulator, tmp_path, monkeypatch):
    import json

    emu = emulator("--rate", "200", "--output", "raw")
    out = tmp_path / "s.mcap"
    r = gloverec("log", "--glove", emu.port, "--out", str(out), "--duration", "2", "--json")
    assert r.returncode == 0, r.stderr
    live = json.loads(r.stdout)
    back = gloverec("monitor", "--glove", f"mcap:{out}", "--fast", "--json")
    assert back.returncode == 0, back.stderr
    replay = json.loads(back.stdout)
    assert live["samples"] > 300 and replay["samples"] == live["samples"]
    old = cli("monitor", "--port", f"mcap:{out}", "--fast", "--json")  # the old name: the same JSON, a note beside it
    assert json.loads(old.stdout)["samples"] == live["samples"] and "--port is now --glove" in old.stderr, old.stderr
    assert replay["errors"] == live["errors"] == 0 and replay["gaps"] == 0
    bad = tmp_path / "not.mcap"
    bad.write_bytes(b"hello")
    r = gloverec("monitor", "--glove", f"mcap:{bad}")
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "not an MCAP file" in r.stderr
    # a glove source from outside the package (tests/plugins/replay_source.py, @register_glove_source): every
    # command that opens a glove takes its KIND:ADDRESS, with its own check of the address
    from recorder.glove import config

    config.kinds()  # the built-in sources registered, then a copy for this test: the other tests see those only
    monkeypatch.setattr(config, "_SOURCES", dict(config._SOURCES))
    monkeypatch.syspath_prepend(str(Path(__file__).parent / "plugins"))
    monkeypatch.delitem(sys.modules, "replay_source", raising=False)
    import replay_source  # noqa: F401

    r = cli("monitor", "--glove", f"replay:{out}", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["samples"] == live["samples"], r.stderr
    r = cli("monitor", "--glove", f"replay:{tmp_path / 'none.mcap'}")
    assert r.returncode == 1 and "replay:" in r.stderr and "no such log" in r.stderr, r.stderr
    r = cli("monitor", "--glove", "relay:x")
    assert r.returncode == 1 and "bad glove 'relay:x'" in r.stderr and "replay:FILE" in r.stderr, r.stderr
