"""Hand profiles per wearer: stored with the calibrations and read back exactly, refused in one line when no hand
could have them or when none is saved, made by `gloverec calibrate` from measurements or its pinch step, and
carried into a recording (recorder/hand/profile.py, recorder/hand/pinch.py)."""

import json
import os

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import cli
from recorder.config import ConfigError
from recorder.hand.kinematics import HandSize
from recorder.hand.pinch import estimate_proportions, pinch_pose, sized, tip_gap
from recorder.hand.pose import HandPose
from recorder.hand.profile import HandProfile, load_profile, profile_path, save_profile
from recorder.hand.skeleton import FINGERS
from recorder.view.scene import Stage, frame_of


@settings(max_examples=25, deadline=None)
@given(
    length=st.floats(150.0, 230.0),
    ratio=st.floats(0.38, 0.55),
    thumb=st.floats(0.8, 1.25),
)
def test_profiles_round_trip(tmp_path_factory, length, ratio, thumb):
    folder = tmp_path_factory.mktemp("cal")
    proportional = HandSize(hand_length_mm=length).lengths()[1:4] * 1000.0
    profile = HandProfile("ana", length, length * ratio, {"thumb": tuple(thumb * proportional)})
    path = save_profile(profile, folder)
    assert path == profile_path("ana", folder) and path.parent.name == "wearers"
    back = load_profile("ana", folder)
    assert back.created  # stamped when saved
    assert back.size() == profile.size()  # the hand FK, retargeting and the view use: exactly the same
    np.testing.assert_allclose(back.size().lengths()[1:4], thumb * proportional / 1000.0, rtol=1e-12)


@pytest.mark.parametrize(
    "profile, needle",
    [
        (HandProfile("ana", 400.0), "hand length 400 mm is not an adult hand's"),
        (HandProfile("ana", 190.0, 200.0), "hand breadth 200 mm"),
        (HandProfile("ana", 190.0, 60.0), "not a hand's proportion"),
        (HandProfile("ana", 190.0, None, {"thumb": (5.0, 40.0, 30.0)}), "segments_mm.thumb[0]: 5 mm"),
        (HandProfile("ana", 190.0, None, {"toe": (40.0, 30.0, 20.0)}), "unknown finger"),
        (HandProfile("../x", 190.0), "bad wearer name"),
    ],
)
def test_impossible_profiles_are_one_line(tmp_path, profile, needle):
    with pytest.raises(ConfigError) as exc:
        save_profile(profile, tmp_path)
    assert needle in str(exc.value) and "\n" not in str(exc.value)
    assert not (tmp_path / "wearers").exists() or not list((tmp_path / "wearers").iterdir())


def test_damaged_and_missing_profiles_are_one_line(tmp_path):
    with pytest.raises(ConfigError, match="no hand profile for wearer 'bob'.*gloverec calibrate --wearer bob"):
        load_profile("bob", tmp_path)
    (tmp_path / "wearers").mkdir()
    for text, needle in [
        ("{", "cannot read the hand profile"),
        (json.dumps({"wearer": "bob", "hand_length_mm": "big"}), "hand_length_mm: Input should be a valid number"),
        (json.dumps({"wearer": "bob", "length": 190}), "length: unknown key"),
        (json.dumps({"wearer": "eve", "hand_length_mm": 190}), "holds the hand profile of 'eve'"),
        (json.dumps({"wearer": "bob", "hand_length_mm": 90}), "not an adult hand's"),
    ]:
        (tmp_path / "wearers" / "bob.json").write_text(text)
        with pytest.raises(ConfigError) as exc:
            load_profile("bob", tmp_path)
        assert needle in str(exc.value) and "\n" not in str(exc.value), str(exc.value)


def test_pinch_poses_touch_and_proportions_come_back():
    """A hand with a long thumb and a short index pinches with other angles; from those angles (measured with
    1 degree of noise) the estimate finds the lengths again, and the reference hand's are 1."""
    true = sized(HandSize(), [1.12, 0.94, 1.0, 1.05, 1.0])
    rng = np.random.default_rng(0)
    pinches = {}
    for f in FINGERS[1:]:
        pose = pinch_pose(f, true)
        assert tip_gap(pose, true, f) < 5e-4
        pinches[f] = pose + rng.normal(0.0, np.radians(1.0), (15, 20))
    k = estimate_proportions(pinches)
    np.testing.assert_allclose(k, [1.12, 0.94, 1.0, 1.05, 1.0], atol=0.03)
    ref = {f: np.array([pinch_pose(f, HandSize())]) for f in FINGERS[1:]}
    np.testing.assert_allclose(estimate_proportions(ref), 1.0, atol=0.01)


def test_calibrate_saves_measurements_and_refuses_impossible_ones(tmp_path):
    r = cli("calibrate", "--wearer", "ana", "--hand-length", "172", "--hand-breadth", "79", "--dir", str(tmp_path))
    assert r.returncode == 0, r.stderr
    assert "hand profile of ana saved" in r.stdout
    p = load_profile("ana", tmp_path)
    assert (p.hand_length_mm, p.hand_breadth_mm, p.source) == (172.0, 79.0, "measured")
    for args, needle in [
        (("--wearer", "bob", "--hand-length", "400"), "hand length 400 mm"),
        (("--hand-length", "180"), "calibrate needs --glove"),
        (("--glove", "emulator", "--pinch"), "add --wearer NAME"),
        (("--wearer", "bob", "--pinch"), "calibrate needs --glove"),
    ]:
        r = cli("calibrate", *args, "--dir", str(tmp_path))
        err = r.stderr.strip()
        assert r.returncode != 0 and "\n" not in err and "Traceback" not in err and needle in err, err


def test_calibrate_pinch_step_estimates_the_wearers_fingers(tmp_path):
    """The emulated wearer (the reference hand's proportions) does the pinch step after the glove's steps; the
    profile keeps the measured length and gets finger lengths near that hand's proportions."""
    r = cli(
        "calibrate", "--glove", "emulator", "--wearer", "ana", "--hand-length", "172", "--pinch",
        "--dir", str(tmp_path), "--json", timeout=120,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout)
    assert out["quality"]["frames"]["pinch"] > 1000  # 9 s at 200 Hz
    p = load_profile("ana", tmp_path)
    assert p.source == "pinch" and p.hand_length_mm == 172.0 and set(p.segments_mm) == set(FINGERS)
    proportional = HandSize(hand_length_mm=172.0).lengths() * 1000.0
    got = p.size().lengths() * 1000.0
    np.testing.assert_allclose(got[1:], proportional[1:], rtol=0.06)
    assert (tmp_path / f"glove_{out['glove_id']:08x}.json").is_file()  # the glove's calibration as well


def _drawn_hand(size: HandSize) -> np.ndarray:
    """The ends of the human hand's bones (n, 3) the live view's scene draws for a flat hand."""
    stage = Stage("pose", "glovehand", hand_size=size)
    stage.show_ghost = False  # the human hand alone
    pose = HandPose(np.zeros(20), np.array([1.0, 0.0, 0.0, 0.0]), np.ones(20, bool))
    stage.apply(frame_of(stage.env, {"seed": 0}, pose))
    scn = mujoco.MjvScene(stage.model, maxgeom=200)
    stage.decorate(scn, mujoco.MjvOption())
    bones = [scn.geoms[i] for i in range(scn.ngeom) if not scn.geoms[i].label]  # the labels are text, not bones
    assert len(bones) == 21  # palm to each chain, three per finger, the knuckles
    axes = [np.array(g.mat).reshape(3, 3)[:, 2] * g.size[2] for g in bones]
    return np.concatenate([[np.array(g.pos) - a, np.array(g.pos) + a] for g, a in zip(bones, axes)])


def test_the_live_view_draws_the_wearers_hand():
    """The view's human hand is the profile's: a 210 mm hand is drawn 210/170 as long as a 170 mm one, and a
    broader hand broader, about the same wrist."""
    small, large = _drawn_hand(HandSize(hand_length_mm=170.0)), _drawn_hand(HandSize(hand_length_mm=210.0))
    broad = _drawn_hand(HandSize(hand_length_mm=170.0, hand_breadth_mm=95.0))
    wrist = small.min(axis=0)  # the scene's own coordinates: the hand lies along x, flat
    length = lambda p: p[:, 0].max() - wrist[0]  # noqa: E731
    width = lambda p: np.ptp(p[:, 1])  # noqa: E731
    assert length(large) / length(small) == pytest.approx(210.0 / 170.0, rel=0.03)
    assert width(broad) > 1.05 * width(small) and length(broad) == pytest.approx(length(small), rel=0.01)


def test_view_takes_a_wearer(tmp_path):
    """`gloverec view --wearer NAME` retargets and draws that wearer's hand; a missing one is one line."""
    save_profile(HandProfile("ana", 172.0, 79.0), tmp_path)
    env = {**os.environ, "GLOVEREC_CALIBRATION_DIR": str(tmp_path)}
    video = tmp_path / "ana.mp4"
    args = ("view", "--glove", "emulator", "--robot", "shadow", "--retarget", "pinch", "--video", str(video))
    r = cli(*args, "--duration", "1", "--wearer", "ana", env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    assert video.stat().st_size > 0
    r = cli(*args, "--duration", "1", "--wearer", "bob", env=env)
    err = r.stderr.strip()
    assert r.returncode == 1 and "\n" not in err and "no hand profile for wearer 'bob'" in err, err
