"""`gloverec doctor` and the faults of `gloverec emulate --fault` (docs/recording.md, "Bringing up a new glove").
Most checks run the doctor's analysis in this process on the bytes the emulator's encoder sends (decoded as a host
decodes them); the documented block runs it end to end once, through a pseudo-terminal, and `gloverec calibrate`
refuses a swapped glove through the real serial path of the in-process emulator."""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest

from conftest import cli
from recorder.emulator.checkup import checkup_emulator
from recorder.glove.checks import examine
from recorder.hand import checkup
from recorder.hand.kinematics import HandSize
from recorder.protocol import StreamDecoder
from recorder.protocol.frames import RawFrame


def _frames(faults=(), seed: int = 0, **kw) -> list:
    dec = StreamDecoder("binary")
    out = []
    for chunk in checkup_emulator(faults, seed=seed, **kw).stream(checkup.TOTAL_S + 0.2):
        out += dec.feed(chunk)
    return out


@pytest.mark.parametrize(
    "fault, kind, imus",
    [
        ("swap:3,4", "swapped", [3, 4]),
        ("swap:0,9", "swapped", [0, 9]),
        ("rotate:5:180", "rotated", [5]),
        ("rotate:10:90", "rotated", [10]),
        ("dead:7", "dead", [7]),
        ("stuck:2", "stuck", [2]),
        ("flaky:6", "intermittent", [6]),
        ("rate:60", "slow_rate", []),
    ],
)
def test_each_fault_is_found_and_named_with_its_imu_and_channel(fault, kind, imus):
    found = examine(_frames([fault], seed=3, misalign_deg=3.0))
    assert [(p.kind, sorted(p.imus)) for p in found.problems] == [(kind, imus)]
    d = found.problems[0].as_dict()
    assert d["channels"] == [i // 2 for i in imus]  # two IMUs per multiplexer channel (table 4.1)
    assert all(f"IMU {i} (channel {i // 2}," in d["found"] for i in imus)
    if kind == "rotated":
        assert f"{fault.split(':')[2]} degrees" in d["found"]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_healthy_glove_passes_with_noise_misalignment_and_another_hand(seed):
    size = HandSize(scale=0.8 + 0.1 * seed)
    found = examine(_frames(seed=seed, misalign_deg=5.0, size=size, glove_id=0xE0E00000 + seed))
    assert found.ok, [p.line() for p in found.problems]
    assert found.rate_hz == pytest.approx(200.0, rel=0.01)


def test_the_channel_map_gives_back_the_glove_as_built():
    """The fix for a swap and a turned sensor, applied to the faulty glove's frames, gives the same registers as
    the glove built right (same seed): exactly, not roughly."""
    faulty = [f for f in _frames(["swap:3,4", "rotate:5:270", "swap:0,8"]) if isinstance(f, RawFrame)]
    good = [f for f in _frames() if isinstance(f, RawFrame)]
    fix = examine(faulty).channel_map
    assert fix is not None and not fix.identity
    mapped = np.stack([fix.apply(f).data for f in faulty])
    assert np.array_equal(mapped, np.stack([f.data for f in good]))


def test_host_fusion_loads_the_saved_map(tmp_path):
    from recorder.fusion.session import load_fusion

    fix = examine(_frames(["swap:3,4"])).channel_map
    fix.__class__(glove_id=7, order=fix.order, turns=fix.turns).save(tmp_path)
    assert load_fusion(7, tmp_path).channels.order == fix.order
    (tmp_path / "channels_00000007.json").write_text("{")
    with pytest.raises(Exception, match="bad channel map"):
        load_fusion(7, tmp_path)


@pytest.mark.parametrize("spelling, words", [("swap:3,12", "not an IMU index"), ("rotate:5:45", "90, 180 or 270"),
                                             ("melt:3", "unknown --fault")])  # fmt: skip
def test_a_bad_fault_is_one_line(spelling, words):
    r = cli("emulate", "--fault", spelling)
    assert r.returncode == 1 and words in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_calibrate_refuses_a_swapped_glove_in_one_line(monkeypatch, tmp_path):
    from recorder.emulator import source
    from recorder.emulator.emulator import Emulator

    monkeypatch.setattr(source, "Emulator", functools.partial(Emulator, faults=["swap:3,4"]))
    r = cli("calibrate", "--glove", "emulator", "--yes", "--view", "none", "--dir", str(tmp_path))
    error = [line for line in r.stderr.splitlines() if "error" in line]
    assert r.returncode == 1 and len(error) == 1, r.stderr
    assert "IMU 3" in error[0] and "gloverec doctor" in error[0]
    assert not list(tmp_path.glob("glove_*.json"))


@pytest.mark.process
def test_the_documented_bring_up_finds_the_build_errors_and_fixes_them(docs_run):
    from docs_runner import ROOT, run_blocks_of

    k = next(i for i, b in enumerate(run_blocks_of(ROOT / "docs" / "recording.md")) if "gloverec doctor" in b.text)
    work = docs_run("recording.md", k)
    found = json.loads((work / "doctor.json").read_text())
    assert {(p["kind"], tuple(sorted(p["imus"]))) for p in found["problems"]} == {
        ("swapped", (3, 4)),
        ("rotated", (5,)),
    }
    assert found["fix"]["saved"] and found["wearer_s"] < 90


def test_the_live_view_shows_each_move_on_the_human_hand(tmp_path, monkeypatch):
    """`gloverec doctor --view web`: the page says the move the wearer is on while the doctor records it, as
    calibrate's view does (the emulated wearer in real time: each move lasts seconds, the page is read every 50 ms)."""
    import socket
    import threading
    import time
    import urllib.request

    from recorder.calibrate.doctor import Doctor
    from recorder.view.process import PRIORITY_ENV

    monkeypatch.setenv(PRIORITY_ENV, "normal")  # the view at the test's priority, however busy the machine
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    doctor = Doctor("emulator", folder=tmp_path, realtime=True, view=f"web:{port}", out=None)
    seen, done = set(), threading.Event()

    def read_the_page():
        while not done.is_set():
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/status", timeout=1) as page:
                    seen.update(" ".join(map(str, row)) for row in json.load(page)["rows"])
            except OSError:
                pass  # not up yet, or gone
            time.sleep(0.05)

    reader = threading.Thread(target=read_the_page, daemon=True)
    reader.start()
    try:
        verdict = doctor.run()
    finally:
        done.set()
        reader.join(5)
    assert verdict.checkup.ok
    text = "\n".join(seen)
    assert "checking emulator" in text and "Rest the hand flat" in text, text
    assert "Curl the index finger" in text and "Curl the little finger" in text, text
