"""`gloverec calibrate` and calibration in recordings: the procedure through the emulator's real pty, a moving
hand refused, the calibration travelling with a raw-mode recording (calibration.json, the MCAP session
metadata, `rerecord`), raw-mode joint angles against pose mode, and the reset key."""

import dataclasses
import json
import os
import time

import numpy as np
import pyarrow.parquet as pq
import pytest

from conftest import cli, gloverec, wait_for
from recorder import GloverecError
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.performer import Performer
from recorder.emulator import procedure as emulated
from recorder.emulator.emulator import GLOVE_ID, Emulator
from recorder.fusion.session import SessionFusion, load_config, load_fusion
from recorder.glove.config import GloveConfig
from recorder.hand.calibration import GloveCalibration
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS
from recorder.log.playback import log_calibration
from recorder.record.control import Control

G = 9.80665


def run_json(*args, env=None, timeout=120):
    r = gloverec(*args, "--json", env=env, timeout=timeout)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def with_dir(folder) -> dict:
    return dict(os.environ, GLOVEREC_CALIBRATION_DIR=str(folder))


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("calibration")
    r = cli("calibrate", "--glove", "emulator", "--dir", str(folder), "--json")  # the emulator runs in-process
    assert r.returncode == 0, r.stderr
    return folder, json.loads(r.stdout)


@pytest.fixture(scope="module")
def recordings(calibrated, tmp_path_factory):
    """The same seed recorded twice with the emulated glove: raw frames fused here, and poses from the glove."""
    folder, _ = calibrated
    base = tmp_path_factory.mktemp("rec")
    common = ("--episodes", "2", "--seed", "5", "--repo-id", "test/cal")
    raw = run_json("record", "--glove-output", "raw", "--root", str(base / "raw"), *common, env=with_dir(folder))
    run_json("record", "--root", str(base / "pose"), *common, env=with_dir(folder))
    return {"raw": base / "raw", "pose": base / "pose", "raw_log": base / "raw" / raw["log"], "base": base}


def test_calibrate_recovers_the_emulators_true_gyro_bias(calibrated):
    folder, summary = calibrated
    assert summary["glove_id"] == GLOVE_ID != 0 and summary["path"] == str(folder / f"glove_{GLOVE_ID:08x}.json")
    saved = GloveCalibration.load(folder, GLOVE_ID)
    # the emulated glove's own errors (seeded by its glove id, the same in every session)
    truth = Emulator(200.0, "raw", emulated.ProcedureMotion("gestures", 0, 200.0)).glove.imus
    assert np.abs(np.degrees(truth.gyro_bias0)).max() > 2.0  # the MPU9250's turn-on bias: up to 5 deg/s
    # 2.6 s of 200 Hz samples with 0.1 deg/s noise average to 0.004 deg/s; the bias drifts with the warming IMU
    # by tempco (<= 0.03 deg/s/degC) x a few 0.1 degC in 3 s: 0.05 deg/s is ten times what either gives
    np.testing.assert_allclose(np.degrees(saved.gyro_bias), np.degrees(truth.gyro_bias0), atol=0.05)
    np.testing.assert_allclose(summary["gyro_bias_dps"], np.degrees(saved.gyro_bias), atol=1e-3)
    # the tilts give the accelerometer offsets (the datasheet's +-60 mg), the flexions every finger's axis
    np.testing.assert_allclose(saved.accel_offset, truth.accel_offset / G, atol=0.006)
    assert all(summary["accel_offset_ok"]) and summary["flexion_axis_ok"] == [False] + [True] * 11
    q = summary["quality"]
    assert q["still_attempts"] == 1 and q["rest_still"] and q["frames"]["still"] == 600
    assert q["rest_bias_change_dps"] < 0.1 and q["rest_pose_change_deg"] < 1.0


def test_calibrate_prints_a_table_and_takes_a_glove_id(tmp_path):
    r = cli("calibrate", "--glove", "emulator", "--dir", str(tmp_path), "--glove-id", "c0ffee")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "glove_00c0ffee.json").exists() and "glove 00c0ffee calibrated" in r.stdout
    assert "pinky_intermediate" in r.stdout and "step 4/4" in r.stderr
    assert GloveCalibration.load(tmp_path, 0xC0FFEE).glove_id == 0xC0FFEE


def frame_kinds(port: str, seconds: float = 0.5) -> set[str]:
    """The kinds of the hand frames a glove on ``port`` sends now (read through the real serial path)."""
    from recorder.link.serial_source import SerialSource

    source = SerialSource(port)
    source.open()
    try:
        end, kinds = time.monotonic() + seconds, set()
        while time.monotonic() < end:
            f = source.read(0.05)
            if f is not None and type(f).__name__ in ("PoseFrame", "RawFrame", "PoseCompactFrame"):
                kinds.add(type(f).__name__)
        return kinds
    finally:
        source.close()


def test_a_moving_hand_is_refused(emulator, tmp_path):
    """A real pty and pyserial, as with a glove: the pose-mode emulator is switched to raw frames by the
    set-mode command; its wearer never stops moving, so step 1 is refused, repeated and finally given up, and
    the glove is put back in pose mode (it used to stay in raw mode, so every later recording fused on the
    host without a word)."""
    emu = emulator("--rate", "200", "--output", "pose", "--motion", "gestures")
    r = gloverec(
        "calibrate",
        "--glove",
        f"serial:{emu.port}",
        "--dir",
        str(tmp_path / "cal"),
        "--attempts",
        "2",
        stdin=open(os.devnull),
    )
    assert r.returncode == 1, r.stderr
    err = r.stderr.strip().splitlines()
    assert err[-1].startswith("gloverec: error: calibration refused: the hand moved") and "2 attempt(s)" in err[-1]
    assert sum(line.startswith("refused: the hand moved") for line in err) == 1 and "Traceback" not in r.stderr
    assert not (tmp_path / "cal").exists()
    assert "glove back in pose mode" in r.stderr and frame_kinds(emu.port) == {"PoseFrame"}


def test_a_standalone_emulator_performs_the_steps_when_calibrate_asks(emulator, tmp_path):
    """`gloverec emulate --motion calibration` (docs/recording.md): its wearer rests until calibrate switches it
    to raw frames, then performs the steps: step 1 passes at the first attempt, and the glove ends in the mode it
    started in. (A second calibration restarts the steps from a gesturing hand: the next test, on the motion.)"""
    emu = emulator("--rate", "200", "--output", "compact", "--motion", "calibration")
    r = gloverec("calibrate", "--glove", emu.port, "--yes", "--dir", str(tmp_path), "--json", stdin=open(os.devnull))
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["quality"]["still_attempts"] == 1 and summary["quality"]["rest_still"]
    assert all(summary["accel_offset_ok"]) and "glove back in compact mode" in r.stderr
    assert frame_kinds(emu.port) == {"PoseCompactFrame"}


def test_the_emulated_wearer_starts_the_steps_again_from_where_its_hand_is():
    """OnRequest: at rest until the cue, then the procedure from session time 0; a second cue, while the hand
    gestures, brings it back to flat within SETTLE_S (inside the margin a step leaves out) and still from there
    for step 1's 3 s."""
    from recorder.calibrate.procedure import MARGIN_S
    from recorder.emulator.procedure import HOLD, OnRequest

    m = OnRequest("gestures", 0, 200.0)
    t = np.arange(0, 2.0, 0.005)
    assert np.ptp(m.at(t).angles, axis=0).max() == 0.0  # resting until asked
    m.restart(10.0)
    np.testing.assert_array_equal(m.at(10.0 + t).angles, m.procedure.at(t).angles)
    busy = 10.0 + emulated.START + 1.3  # gesturing, after the procedure
    assert np.ptp(m.at(busy + np.arange(0, 0.5, 0.005)).angles, axis=0).max() > 0.05
    m.restart(busy)
    assert m.start_s == pytest.approx(busy + OnRequest.SETTLE_S) and OnRequest.SETTLE_S + 0.05 < MARGIN_S
    flat = m.at(m.start_s + np.arange(0.0, HOLD, 0.005))
    assert np.ptp(flat.angles, axis=0).max() == 0.0 and np.ptp(flat.palm_quat, axis=0).max() == 0.0
    step_in = m.at(np.linspace(busy, m.start_s, 11))
    assert np.all(np.diff(np.abs(step_in.angles - flat.angles[0]).max(axis=1)) <= 1e-12)  # closing in on flat


@pytest.mark.process
def test_bad_gloves_and_files_are_one_line_errors(tmp_path):
    from recorder.log.writer import McapLogger
    from recorder.protocol import PoseFrame, encode_frame

    log = tmp_path / "pose.mcap"  # a glove that only sends fused poses and takes no command
    with McapLogger(str(log), {"source": "test"}) as logger:
        q = np.tile(np.float32([1, 0, 0, 0]), (16, 1))
        for k in range(300):
            logger(encode_frame(PoseFrame(k, k * 5000, q)), 1_000_000_000 + k * 5_000_000, [])
    for glove, needle in (
        (f"mcap:{log}", "did not switch to raw mode"),
        ("serial:/dev/does-not-exist", "no such port"),
    ):
        r = cli("calibrate", "--glove", glove, "--dir", str(tmp_path))
        assert r.returncode == 1 and needle in r.stderr.strip().splitlines()[-1], r.stderr
        assert r.stderr.count("gloverec: error:") == 1 and "Traceback" not in r.stderr
    bad = tmp_path / f"glove_{GLOVE_ID:08x}.json"
    bad.write_text("{not json")
    with pytest.raises(GloverecError, match="bad calibration file"):
        load_fusion(GLOVE_ID, tmp_path)
    d = json.loads(GloveCalibration(glove_id=GLOVE_ID).to_json())
    bad.write_text(json.dumps(d | {"version": 99}))
    with pytest.raises(GloverecError, match="version 99"):
        load_fusion(GLOVE_ID, tmp_path)
    bad.write_text(json.dumps(d | {"gyro_bias": [[0, 0, 0]]}))
    with pytest.raises(GloverecError, match="gyro_bias has shape"):
        load_fusion(GLOVE_ID, tmp_path)
    # the recorder forks its writer before the glove (and its calibration) opens: as a user runs it, a child
    r = gloverec(
        "record", "--glove-output", "raw", "--episodes", "1", "--root", str(tmp_path / "ds"), env=with_dir(tmp_path)
    )
    assert r.returncode == 1 and "bad calibration file" in r.stderr and r.stderr.count("\n") == 1, r.stderr


def test_without_a_saved_calibration_fusion_says_so(tmp_path):
    fusion = load_fusion(GLOVE_ID, tmp_path)
    assert fusion.calibrated is False and not fusion.calibration.gyro_bias.any()
    said = []
    session = SessionFusion(calibration_dir=tmp_path)
    session.expect(GLOVE_ID, raw=True)
    session.keep_in(tmp_path / "work", said.append)
    record = json.loads((tmp_path / "work/meta/gloverec/calibration.json").read_text())
    assert record["host_fusion"] and not record["calibrated"] and record["calibration"] is None
    assert len(said) == 1 and "no saved calibration" in said[0] and "gloverec calibrate" in said[0]


def test_the_calibration_travels_with_a_raw_recording(calibrated, recordings):
    folder, _ = calibrated
    saved = json.loads((folder / f"glove_{GLOVE_ID:08x}.json").read_text())
    record = json.loads((recordings["raw"] / "meta/gloverec/calibration.json").read_text())
    assert record["glove_id"] == GLOVE_ID and record["calibrated"] and record["host_fusion"]
    assert record["calibration"] == saved
    assert record["fusion_config"] == dataclasses.asdict(load_config())
    assert log_calibration(str(recordings["raw_log"])) == record  # the session log's metadata: the same
    pose = json.loads((recordings["pose"] / "meta/gloverec/calibration.json").read_text())
    assert pose["host_fusion"] is False and pose["calibration"] is None  # the glove fused those poses


def test_a_serial_glove_in_raw_mode_is_fused_with_the_calibration_of_its_id(calibrated, emulator, tmp_path):
    """A glove on a port: its id comes with its status frames, after the log has opened, so the record reaches
    calibration.json and the log (a second session metadata record) once the frames come."""
    folder, _ = calibrated
    emu = emulator("--rate", "200", "--output", "raw", "--motion", "gestures")
    root = tmp_path / "ds"
    summary = run_json(
        "record",
        "--glove",
        f"serial:{emu.port}",
        "--episodes",
        "1",
        "--episode-time-s",
        "1.5",
        "--root",
        str(root),
        "--repo-id",
        "test/serial",
        env=with_dir(folder),
    )
    assert summary["episodes_saved"] == 1
    record = json.loads((root / "meta/gloverec/calibration.json").read_text())
    assert record["glove_id"] == GLOVE_ID and record["calibrated"] and record["host_fusion"]
    assert record["calibration"] == json.loads((folder / f"glove_{GLOVE_ID:08x}.json").read_text())
    assert log_calibration(str(root / summary["log"])) == record


def _glove(root):
    t = pq.read_table(root / "data", columns=["index", "episode_index", "observation.glove"]).to_pandas()
    t = t.sort_values("index")
    return np.stack(t["observation.glove"].to_numpy())[:, :20], t["episode_index"].to_numpy()


def test_raw_mode_joint_angles_match_pose_mode(recordings):
    """The same seed, the same demonstrations: the glove's own poses (the truth plus 0.5 deg of noise) against
    raw IMU frames fused on the host with the saved calibration. Each episode is compared frame by frame from its
    start (the button); an episode may end a frame sooner or later (the task ends on success). What may differ:
    the pose noise (0.5 deg), host fusion's error (0.2-0.3 deg RMS in bench/fusion.py), and the hand's slow
    wander (0.75 deg), which runs on session time while the raw session's first demonstration starts later
    (the hand rests while fusion starts) and whose value at each button press goes into the reference pose.
    Measured: 0.67 deg RMS, 2.5 deg at worst; the bound is the issue's 2 deg RMS goal (without the saved
    calibration the same comparison gives about 20 deg RMS: the emulated wearer never rests still enough for
    the gyro bias to be measured at the start)."""
    a, ea = _glove(recordings["raw"])
    b, eb = _glove(recordings["pose"])
    assert set(ea) == set(eb) == {0, 1}
    diffs = []
    for e in (0, 1):
        x, y = a[ea == e], b[eb == e]
        assert abs(len(x) - len(y)) <= 3
        n = min(len(x), len(y))
        diffs.append(np.degrees(x[:n] - y[:n]))
    d = np.concatenate(diffs)
    rms = np.sqrt(np.mean(d**2, axis=0))
    assert np.sqrt(np.mean(d**2)) < 2.0 and np.abs(d).max() < 8.0, dict(zip(JOINTS, rms.round(2)))


@pytest.mark.process
def test_rerecord_fuses_with_the_logs_calibration(recordings, tmp_path):
    """No calibration where rerecord looks (an empty folder): it takes the one in the log, and reproduces."""
    out = tmp_path / "again"
    run_json(
        "rerecord",
        "--log",
        str(recordings["raw_log"]),
        "--repo-id",
        "test/again",
        "--root",
        str(out),
        env=with_dir(tmp_path),
    )
    a, ea = _glove(recordings["raw"])
    b, eb = _glove(out)
    np.testing.assert_array_equal(ea, eb)
    np.testing.assert_allclose(b, a, atol=1e-5)
    assert json.loads((out / "meta/gloverec/calibration.json").read_text()) == json.loads(
        (recordings["raw"] / "meta/gloverec/calibration.json").read_text()
    )


def test_the_reset_key_and_the_button_retake_the_reference_pose(calibrated):
    """The emulated wearer spreads the fingers and holds; `zero` on stdin then makes that the reference pose:
    the fused abductions jump from the spread hand's to the rest pose's, and C changes."""
    folder, _ = calibrated
    spread = GESTURES["open"].copy()
    abd = [JOINTS.index(f"{f}_mcp_abd") for f in ("index", "ring", "pinky")]
    spread[abd] = np.radians([20.0, -15.0, -25.0])
    r, w = os.pipe()
    control = Control(stdin=os.fdopen(r))
    session = SessionFusion(calibration_dir=folder)
    config = GloveConfig.parse("emulator", mode="raw", seed=1)
    performer = Performer(config, fast=True, fusion=session)
    glove = performer.glove
    control.on_reset(glove.reset_pose)
    glove.open()
    try:
        assert session.record["calibrated"]
        assert glove.wait_past(float("-inf")) and session.started  # the first pose: fusion started at rest
        performer.demonstrate(DemoMotion([0.0, 0.6], [GESTURES["open"], spread], np.random.default_rng(0)))
        end = time.monotonic() + 20
        while not glove.buttons and time.monotonic() < end:  # the demonstrator presses the button at its start
            glove.wait_past(glove.now() + 0.05)
        start = glove.take_button()
        assert start is not None and glove.wait_past(start + 1.5)
        assert session.resets == 1  # the button
        before = glove.track.at(start + 1.5).pose.angles
        c_before = session.fusion.C.copy()
        np.testing.assert_allclose(np.degrees(before[abd]), [20.0, -15.0, -25.0], atol=2.5)
        os.write(w, b"zero\n")
        assert wait_for(lambda: session._reset_requested, 5.0)
        assert glove.wait_past(start + 1.7) and session.resets == 2
        after = glove.track.at(start + 1.7).pose.angles
        np.testing.assert_allclose(np.degrees(after[abd]), np.degrees(GESTURES["open"][abd]), atol=2.5)
        assert not np.allclose(session.fusion.C, c_before, atol=1e-3)
    finally:
        glove.close()
        control.close()
        os.close(w)
