"""HostFusion: raw frames -> segment quaternions, joint angles and quality; pose frames; bad input."""

import dataclasses

import numpy as np
import pytest

from recorder import quat
from recorder.emulator import procedure as emulated
from recorder.fusion import FusionConfig, HostFusion
from recorder.fusion.quality import DEAD, MISSING, NONFINITE, SATURATED, STUCK, describe
from recorder.hand import calibration as cal, joints
from recorder.hand.kinematics import JOINTS
from recorder.paths import configs_dir
from recorder.protocol.frames import EventCode, EventFrame, PoseFrame, RawFrame

RATE = 200
SECONDS = 8.0
CONFIGS = configs_dir() / "fusion"


@pytest.fixture(scope="module")
def glove():
    g = emulated.procedure_glove("gestures", RATE, seed=2)
    b = g.next_block(int((emulated.START + SECONDS) * RATE))
    t = np.round(np.arange(len(b.t)) * 1e6 / RATE).astype(np.int64)
    rec = {p: (b.raw[emulated.phase(p, RATE)], t[emulated.phase(p, RATE)]) for p in emulated.PHASES}
    return {
        "block": b,
        "t": t,
        "rec": rec,
        "k1": emulated.phase("rest", RATE).stop,
        "k0": int(emulated.START * RATE),
        "imus": g.imus,
    }


def started(glove, **config) -> HostFusion:
    hf = HostFusion(FusionConfig(rate_hz=RATE, **config))
    rec = glove["rec"]
    hf.calibrate(rec["still"], rec["flex"], rec["tilt"], glove_id=0xC0FFEE)
    hf.start(rec["rest"])
    return hf


def rms_deg(out, glove):
    k = glove["k0"] - glove["k1"]
    return np.degrees(np.sqrt(np.mean((out.angles[k:] - glove["block"].angles[glove["k0"] :]) ** 2, axis=0)))


@pytest.mark.parametrize("name", ["inertial", "complementary", "mahony", "relative", "madgwick"])
def test_joint_angles_and_fingertips_match_the_ground_truth(glove, name):
    hf = started(glove, filter=name)
    k1 = glove["k1"]
    out = hf.process_block(glove["block"].raw[k1:], glove["t"][k1:])
    err = rms_deg(out, glove)
    assert np.sqrt(np.mean(err**2)) < 1.0 and err.max() < 2.0, dict(zip(JOINTS, err.round(2)))
    k = glove["k0"] - k1
    tips = joints.fingertips(out.angles[k:])
    truth = joints.fingertips(glove["block"].angles[glove["k0"] :])
    assert np.sqrt(np.mean(np.sum((tips - truth) ** 2, axis=-1))) < 0.003  # 3 mm
    assert out.valid.all() and not out.flags.any()
    # the constrained pose: quats are the model at the angles, the palm row its world orientation
    np.testing.assert_allclose(out.quats[-1, 1:], joints.constrained_relative(out.angles[-1])[1:], atol=1e-12)


@pytest.mark.parametrize("name", ["inertial", "mahony", "relative"])
def test_an_imu_first_seen_mid_block_starts_from_gravity(glove, name):
    """Without ``start`` every IMU starts at its first fused sample: attitude from gravity (eq. 3.5-3.6), its
    clock, and its heading reference from the hand model in the reference pose (eq. 3.21). IMU 7 (middle
    proximal) answers from frame 20 on; the joints then follow the ground truth as after ``start``."""
    hf = HostFusion(FusionConfig(filter=name, rate_hz=RATE))
    rec = glove["rec"]
    hf.calibrate(rec["still"], rec["flex"], rec["tilt"])
    k1 = glove["k1"]
    raw, t = glove["block"].raw[k1:], glove["t"][k1:]
    ok = np.full(len(raw), 0xFFF)
    ok[:20] &= ~(1 << 7)
    first = hf.process_block(raw[:20], t[:20], ok[:20])
    assert not hf.started[7] and hf.started[np.arange(12) != 7].all()
    wrong = quat.from_axis_angle([1, 0, 0], 1.0)  # what IMU 7 held before its first sample does not matter
    hf.filter.q[7] = wrong
    if name == "relative":
        hf.filter.rel[7] = wrong
    at = hf.process_block(raw[20:21], t[20:21])
    a = raw[20, 7, :3] * (16 / 32768.0) - hf.calibration.accel_offset[7]
    np.testing.assert_allclose(quat.rotate(hf.filter.q[7], a / np.linalg.norm(a)), [0, 0, 1], atol=1e-3)
    assert hf.started.all() and hf.last_t[7] == t[20]
    rest = hf.process_block(raw[21:], t[21:])
    err = rms_deg(dataclasses.replace(rest, angles=np.concatenate((first.angles, at.angles, rest.angles))), glove)
    assert np.sqrt(np.mean(err**2)) < 1.0 and err.max() < 2.0, dict(zip(JOINTS, err.round(2)))


def test_a_drifting_bias_does_not_become_drifting_joints():
    """After calibration every gyro gets an extra bias growing to 0.5 deg/s per axis over 30 s (temperature):
    with bias tracking and the joint-constraint feedback the joints stay; without them they drift. (30 s, not
    the 8 s of the other tests: the default filter's tilt follows a steady drift by itself, so the difference
    is the heading, which takes time to add up.)"""
    long = emulated.procedure_glove("gestures", RATE, seed=2)
    b = long.next_block(int((emulated.START + 30.0) * RATE))
    t = np.round(np.arange(len(b.t)) * 1e6 / RATE).astype(np.int64)
    glove = {
        "block": b,
        "t": t,
        "rec": {p: (b.raw[emulated.phase(p, RATE)], t[emulated.phase(p, RATE)]) for p in emulated.PHASES},
        "k1": emulated.phase("rest", RATE).stop,
        "k0": int(emulated.START * RATE),
    }
    k1 = glove["k1"]
    raw = b.raw[k1:].copy()
    T = len(raw)
    rng = np.random.default_rng(5)
    ramp = np.linspace(0, 1, T)[:, None, None] * rng.choice([-0.5, 0.5], (1, 12, 3)) * 16.4  # LSB, 16.4/dps
    raw[..., 3:6] = np.clip(raw[..., 3:6] + np.round(ramp), -32768, 32767).astype(np.int16)
    errs = []
    for config in ({}, {"track_bias": False, "heading_rate": 0.0}):
        out = started(glove, **config).process_block(raw, t[k1:])
        errs.append(rms_deg(out, glove))
    assert np.sqrt(np.mean(errs[0] ** 2)) < 1.0, errs[0].round(2)
    assert np.sqrt(np.mean(errs[1] ** 2)) > 1.5 * np.sqrt(np.mean(errs[0] ** 2)), (errs[0].round(2), errs[1].round(2))


def test_bad_input_is_flagged_and_not_fused(glove):
    hf = started(glove)
    k1 = glove["k1"]
    raw = glove["block"].raw[k1 : k1 + 400].astype(float)
    ok = np.full(len(raw), 0xFFF)
    raw[100:110, 2, 0] = np.nan  # thumb proximal: NaN
    raw[120:130, 4, 3] = 32767  # index proximal: gyro saturated
    raw[140:150, 6, :6] = 0  # middle proximal: a dead IMU answering zeros
    ok[160:170] &= ~(1 << 8)  # ring proximal: did not answer
    raw[180:200, 10, :6] = raw[180, 10, :6]  # pinky proximal: stuck registers
    out = hf.process_block(raw, glove["t"][k1 : k1 + 400], ok)
    assert describe(out.flags[105, 2]) == ["nonfinite"]
    assert out.flags[125, 4] & SATURATED and out.flags[145, 6] & DEAD and out.flags[165, 8] & MISSING
    assert out.flags[199, 10] & STUCK and not out.flags[185, 10]  # stuck after 10 identical frames
    assert np.all(np.isfinite(out.angles)) and np.all(np.isfinite(out.quats))  # nothing propagated
    bad = out.flags != 0
    assert bad[:, [2, 4, 6, 8, 10]].any(axis=0).all() and not bad[:, [0, 1, 3, 5, 7, 9, 11]].any()
    j = JOINTS.index
    assert not out.valid[105, j("thumb_mcp")] and not out.valid[105, j("thumb_ip")]
    assert not out.valid[125, j("index_mcp_flex")] and not out.valid[125, j("index_pip")]
    assert not out.valid[125, j("index_dip")]  # interpolated from the PIP, which is invalid
    assert out.valid[105, j("index_pip")] and out.valid[125, j("thumb_ip")]
    assert out.valid[:100].all() and out.valid[300:].all()
    f = out.frame(125)
    assert f.detail["flagged_imus"] == 1 and f.flags[4] == SATURATED and np.isfinite(f.quality)
    assert NONFINITE and MISSING  # (flag values are non-zero bits)


def test_a_flagged_imu_keeps_its_filter_state(glove):
    hf = started(glove)
    k1 = glove["k1"]
    raw = glove["block"].raw[k1 : k1 + 50].copy()
    hf.process_block(raw[:10], glove["t"][k1 : k1 + 10])
    before = hf.filter.q[7].copy()
    ok = np.full(40, 0xFFF & ~(1 << 7))
    hf.process_block(raw[10:], glove["t"][k1 + 10 : k1 + 50], ok)
    np.testing.assert_array_equal(hf.filter.q[7], before)


def test_accelerometer_disturbance_shows_in_the_quality(glove):
    hf = started(glove)
    k1 = glove["k1"]
    raw = glove["block"].raw[k1 : k1 + 100].copy()
    raw[50:60, 3, :3] = np.round(raw[50:60, 3, :3] * 1.5).astype(np.int16)  # |a| = 1.5 g on one IMU
    out = hf.process_block(raw, glove["t"][k1 : k1 + 100])
    assert out.accel_error[55, 3] > 0.1 and out.trust[55, 3] < 1.0
    assert out.accel_error[20, 3] < 0.05 and out.trust[20, 3] == 1.0
    assert np.all(out.constraint >= 0) and np.all(out.bias_change >= 0)


def test_single_frames_pose_frames_and_the_button(glove):
    hf = started(glove)
    k1 = glove["k1"]
    b = glove["block"]
    out = hf.process(RawFrame(7, int(glove["t"][k1]), b.raw[k1]))
    assert out.quats.shape == (16, 4) and out.angles.shape == (20,) and out.seq == 7 and out.source == "raw"
    assert 0.0 <= out.quality < 0.2 and set(out.detail) >= {"accel_error", "bias_change", "constraint"}
    # the button: a corrupted reference pose comes back while the hand rests in the reference pose
    rest = emulated.phase("rest", RATE)
    hf2 = started(glove)
    hf2.C[4] = quat.mul(quat.from_axis_angle([0, 0, 1], np.radians(20)), hf2.C[4])
    assert hf2.process(EventFrame(1, 0, EventCode.BUTTON)) is None
    still = hf2.process(RawFrame(8, int(glove["t"][rest.stop - 1]), b.raw[rest.stop - 1]))
    assert np.degrees(np.abs(still.angles)).max() < 1.0 and still.quality < 0.05  # at rest: no disturbance
    # pose frames (fused on the glove) pass through
    pose = hf.process(PoseFrame(9, 0, b.truth_rel[k1 + 300].astype(np.float32)))
    assert pose.source == "pose"
    np.testing.assert_allclose(pose.quats, b.truth_rel[k1 + 300], atol=1e-6)
    np.testing.assert_allclose(pose.angles, b.angles[k1 + 300], atol=1e-4)
    assert pose.quality == 0.0
    bad = hf.pose_block(np.full((1, 16, 4), np.nan), [0])
    assert not bad.valid.any() and np.all(np.isfinite(bad.angles))


def test_calibration_travels_as_json(glove, tmp_path):
    hf = started(glove)
    path = hf.calibration.save(tmp_path)
    assert path.name == "glove_00c0ffee.json"
    back = cal.GloveCalibration.load(tmp_path, 0xC0FFEE)
    for k in ("gyro_bias", "accel_offset", "mounts", "reference_angles"):
        np.testing.assert_array_equal(getattr(back, k), getattr(hf.calibration, k))
    again = HostFusion(FusionConfig(rate_hz=RATE), back)
    again.start(glove["rec"]["rest"])
    np.testing.assert_allclose(again.C, hf.C, atol=1e-12)


def test_config_files_load_and_bad_names_are_refused(tmp_path):
    for path in sorted(CONFIGS.glob("*.yaml")):
        config = FusionConfig.load(path)
        HostFusion(config)
    assert {p.stem for p in CONFIGS.glob("*.yaml")} >= {"complementary", "madgwick", "relative", "thesis"}
    assert FusionConfig.load() == FusionConfig()  # the defaults live in the dataclass
    assert FusionConfig.load(CONFIGS / "complementary.yaml", limits=False).limits is False
    bad = tmp_path / "bad.yaml"
    bad.write_text("filter: mahony\nfliter_settings: {}\n")
    with pytest.raises(ValueError, match="bad.yaml: fliter_settings: unknown key; valid: filter, filter_settings"):
        FusionConfig.load(bad)
    bad.write_text("filter: mahony\nengine: numpy\n")  # gone: the numba kernels are the one implementation
    with pytest.raises(ValueError, match="engine"):
        FusionConfig.load(bad)
    with pytest.raises(ValueError, match="complementary"):
        FusionConfig(filter="ekf")
    bad.write_text("filter: madgwick\nfilter_settings: {kp: 1}\n")
    with pytest.raises(ValueError, match="bad.yaml: filter_settings: unknown setting"):
        FusionConfig.load(bad)
