"""Where the marker sits on the glove (issue 24): the solver (recorder/wrist/mounting.py) recovers a known mounting
from noisy marker and palm orientations, IPPE's flipped poses among them, and refuses turns about one axis;
`gloverec calibrate --wrist marker:emulated:RX,RY,RZ --glove emulator` finds the emulated marker's mounting and
saves it where `gloverec record --wrist` takes it; a session log keeps the mounting it was recorded with; a bad
mounting file is one line."""

import json

import numpy as np
import pytest

from conftest import cli
from recorder import GloverecError, quat
from recorder.wrist.format import WristPose
from recorder.wrist.mounting import MarkerMount, mounting, solve_mount

TILTED_12 = quat.from_axis_angle([0.6, -0.5, 0.62], np.radians(12.0))  # 12° off about a tilted axis


def _noisy(rng, q, deg):
    """``q`` turned by isotropic noise of ``deg`` RMS."""
    return quat.mul(q, quat.from_rotvec(rng.normal(0.0, np.radians(deg) / np.sqrt(3.0), q.shape[:-1] + (3,))))


def _pairs(mount, seed=0, n=400, spread_deg=(25.0, 25.0, 35.0), flipped=0.15):
    """A wearer's palm tilting and turning for 15 s (``spread_deg``: amplitudes about the palm's x, y, z), its IMU
    within 0.5° and the marker within 2.7°, seen by a camera looking along its z; ``flipped`` of the frames have
    IPPE's other pose (the marker's normal mirrored about the line of sight) first. (marker, palm, alternative)."""
    rng = np.random.default_rng(seed)
    x = quat.normalize(rng.normal(size=4))  # the IMU's world in the camera's frame
    t = np.linspace(0.0, 15.0, n)
    turns = [
        np.radians(a) * np.sin(2 * np.pi * f * t + p) for a, f, p in zip(spread_deg, (0.21, 0.33, 0.13), (0, 1, 2))
    ]
    palm = quat.mul(quat.from_axis_angle([0, 0, 1.0], 0.3), quat.from_rotvec(np.stack(turns, axis=1)))
    marker = _noisy(rng, quat.mul(x, quat.mul(palm, mount)), 2.7)
    normal, sight = quat.rotate(marker, [0, 0, 1.0]), np.array([0.0, 0.0, -1.0])
    other = quat.mul(quat.from_two_vectors(normal, 2 * (normal @ sight)[:, None] * sight - normal), marker)
    swap = (rng.random(n) < flipped)[:, None]
    return np.where(swap, other, marker), _noisy(rng, palm, 0.5), np.where(swap, marker, other)


@pytest.mark.parametrize(
    "mount", [TILTED_12, quat.from_axis_angle([0, 0, 1.0], np.pi / 2)], ids=["12deg_tilted", "90deg_turned"]
)
@pytest.mark.parametrize("seed", [0, 1])
def test_the_solver_recovers_a_known_mounting_from_noisy_pairs(mount, seed):
    marker, palm, other = _pairs(mount, seed)
    found = solve_mount(marker, palm, other)
    assert np.degrees(quat.angle_between(found.q, mount)) < 1.0
    assert 2.0 < found.residual_deg < 3.5  # the marker's 2.7° and the IMU's 0.5°
    assert found.flipped > 30 and found.dropped == 0  # IPPE's other pose taken where it was the right one
    assert min(found.turned_deg) > 30


def test_pairs_that_turn_about_one_axis_only_are_refused_in_one_line():
    marker, palm, other = _pairs(TILTED_12, spread_deg=(0.0, 30.0, 0.0))
    with pytest.raises(GloverecError, match="turn the hand more: tilt it forward/back and left/right") as exc:
        solve_mount(marker, palm, other)
    assert "\n" not in str(exc.value) and "forward/back 59°" in str(exc.value)
    with pytest.raises(GloverecError, match="only 10 tracked marker poses"):
        solve_mount(marker[:10], palm[:10])


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """`gloverec calibrate --wrist marker:emulated:7,-6,8 --glove emulator`: its folder and JSON summary."""
    folder = tmp_path_factory.mktemp("mount")
    r = cli("calibrate", "--glove", "emulator", "--wrist", "marker:emulated:7,-6,8", "--duration", "10", "--dir",
            str(folder), "--json")  # fmt: skip
    assert r.returncode == 0, r.stderr
    return folder, json.loads(r.stdout)


def test_calibrate_finds_the_emulated_marker_s_mounting(calibrated):
    folder, summary = calibrated
    glued = quat.from_rotvec(np.radians([7.0, -6.0, 8.0]))  # 12.2° about a tilted axis
    saved = MarkerMount.load(folder / "marker_mount.json")
    assert np.degrees(quat.angle_between(saved.q, glued)) < 1.5
    assert summary["emulated_error_deg"] < 1.5 and summary["path"] == str(folder / "marker_mount.json")
    assert saved.residual_deg < 2.0 and saved.samples > 200 and saved.source == "marker:emulated:7,-6,8"
    assert min(saved.turned_deg) >= 30


def _open_wrist(wrist: str, said: list, **options):
    """The WristTrack that `gloverec record --wrist WRIST` opens (the rig's, recorder/rig/rig.py), with no
    recording."""
    from recorder.record.config import RecordConfig
    from recorder.rig.rig import open_wrist_track

    cfg = RecordConfig.load(task="relocate", wrist=wrist, **options)
    palm = lambda t: (np.zeros(3), quat.IDENTITY.copy())  # noqa: E731  (the emulated wearer's: nothing records here)
    return open_wrist_track(cfg, fast=cfg.is_fast, wearer=palm, say=said.append)


def test_record_takes_the_saved_mounting(calibrated, monkeypatch, tmp_path):
    folder, _ = calibrated
    saved = MarkerMount.load(folder / "marker_mount.json")
    said = []
    monkeypatch.setenv("GLOVEREC_CALIBRATION_DIR", str(folder))
    track = _open_wrist("marker:emulated:7,-6,8", said)
    try:
        np.testing.assert_allclose(track.fusion.marker_in_palm, saved.q)
        np.testing.assert_allclose(track.source.camera.marker_in_palm, quat.from_rotvec(np.radians([7, -6, 8])))
    finally:
        track.close()
    assert said == [f"the marker's mounting on the glove: 12.2° off flat (from {folder / 'marker_mount.json'})"]
    # the plain marker:emulated is another marker than the one calibrated (marker:emulated:7,-6,8): the saved
    # mounting is not applied to it, and the line says so
    said.clear()
    track = _open_wrist("marker:emulated", said)
    track.close()
    np.testing.assert_allclose(track.fusion.marker_in_palm, quat.IDENTITY)
    assert len(said) == 1 and "was calibrated for marker:emulated:7,-6,8, not marker:emulated: not applied" in said[0]
    monkeypatch.setenv("GLOVEREC_CALIBRATION_DIR", str(tmp_path))  # none saved: flat on the back of the hand
    track = _open_wrist("marker:emulated", said)
    track.close()
    np.testing.assert_allclose(track.fusion.marker_in_palm, quat.IDENTITY)
    track = _open_wrist("marker:emulated", said, wrist_mount=str(folder / "marker_mount.json"))  # --wrist-mount
    track.close()
    np.testing.assert_allclose(track.fusion.marker_in_palm, saved.q)


def test_a_session_log_keeps_the_mounting_it_was_recorded_with(tmp_path):
    from recorder.log.writer import McapLogger
    from recorder.wrist.log import LogWrist

    q = quat.from_rotvec(np.radians([0.0, 0.0, 90.0]))
    with McapLogger(tmp_path / "session.mcap", {"source": "emulator"}) as logger:
        logger.wrist_channel("udp:0.0.0.0:9100", 0.0, q)
        logger.wrist(WristPose(0, 1.0, np.zeros(3), quat.IDENTITY.copy()), 1.0)
    said = []
    source = LogWrist(str(tmp_path / "session.mcap"))
    np.testing.assert_allclose(mounting(source, say=said.append), q)  # what the recording used, not a saved one
    assert said == ["the marker's mounting on the glove: 90.0° off flat (the session log's)"]


@pytest.mark.parametrize(
    ("text", "says"),
    [
        (None, "no marker mounting at"),
        ("{not json", "bad marker mounting"),
        ('{"quat": [1, 0, 0], "residual_deg": 1.0, "samples": 300}', "'quat' must be 4 numbers"),
        ('{"quat": [2, 0, 0, 0], "residual_deg": 1.0, "samples": 300}', "not a unit quaternion"),
        ('{"kind": "gloverec.GloveCalibration"}', "not a marker mounting"),
    ],
)
def test_a_bad_mounting_file_is_one_line(tmp_path, text, says):
    path = tmp_path / "marker_mount.json"
    if text is not None:
        path.write_text(text)
    with pytest.raises(GloverecError, match=says) as exc:
        _open_wrist("marker:emulated", [], wrist_mount=str(path))
    assert "\n" not in str(exc.value) and str(path) in str(exc.value)


def test_the_step_s_bad_input_is_one_line(tmp_path):
    for args, says in [
        (("--wrist", "marker:emulated"), "add --glove GLOVE"),
        (("--wrist", "marker:emulated", "--glove", "udp:9100"), "calibrate with --glove emulator"),
        (("--wrist", "marker:emulated:7,x", "--glove", "emulator"), "three numbers in degrees"),
        (("--wrist", "scripted", "--glove", "emulator"), "no marker to calibrate"),
        (("--wrist", "marker:emulated", "--glove", "emulator", "--camera", "0"), "drop --camera"),
    ]:
        r = cli("calibrate", *args, "--dir", str(tmp_path))
        assert r.returncode == 1 and says in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not (tmp_path / "marker_mount.json").exists()
