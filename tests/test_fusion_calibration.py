"""Calibration: gyro bias with a stillness check, accelerometer offsets, sensor-to-segment alignment
(Kortier eq. 34), the reference pose (thesis eq. 3.21), and the versioned JSON file."""

import numpy as np
import pytest

from recorder import quat
from recorder.emulator import procedure as emulated
from recorder.emulator.glove import SyntheticGlove
from recorder.fusion import make_filter
from recorder.hand import calibration as cal
from recorder.protocol.frames import RawFrame

RATE = 200
G = 9.80665


@pytest.fixture(scope="module")
def procedure():
    """The calibration procedure on a glove whose IMUs sit up to ~10 degrees off their segments' axes."""
    glove = emulated.procedure_glove("gestures", RATE, seed=3, misalign_deg=6.0)
    b = glove.next_block(int(emulated.START * RATE))
    accel = b.raw[..., 0:3] * (16 / 32768.0)
    gyro = np.radians(b.raw[..., 3:6] * (2000 / 32768.0))
    return {
        "b": b,
        "a": accel,
        "g": gyro,
        "imus": glove.imus,
        "ph": {p: emulated.phase(p, RATE) for p in emulated.PHASES},
    }


def test_gyro_bias_from_a_still_hand(procedure):
    p, s = procedure, procedure["ph"]["still"]
    bias = cal.gyro_bias(p["g"][s], p["a"][s])
    true = (
        p["imus"].gyro_bias0
        + p["imus"].gyro_tempco * (p["imus"].temperature(np.array([1.5]))[0] - p["imus"].temp0)[:, None]
    )
    np.testing.assert_allclose(np.degrees(bias), np.degrees(true), atol=0.02)  # MPU9250 ZRO is up to 5 deg/s
    assert np.abs(np.degrees(true)).max() > 1.0


@pytest.mark.parametrize("phase", ["flex", "tilt"])
def test_calibration_refuses_a_moving_hand(procedure, phase):
    s = procedure["ph"][phase]
    with pytest.raises(cal.CalibrationRefused, match="moved") as e:
        cal.gyro_bias(procedure["g"][s], procedure["a"][s])
    assert e.value.imus


def test_calibration_refuses_a_slow_steady_turn():
    """Turning at 12 deg/s about the vertical (invisible to the accelerometers, steady for the gyro) is not a
    bias: the datasheet's zero-rate offset stays below 5 deg/s."""
    b = SyntheticGlove("gestures", RATE, seed=1, noise=False, bias=False).next_block(10)
    a = np.tile(b.raw[0, :, 0:3] * (16 / 32768.0), (400, 1, 1))
    g = np.zeros((400, 12, 3))
    g[..., 2] = np.radians(12.0)
    with pytest.raises(cal.CalibrationRefused, match="turning"):
        cal.gyro_bias(g, a)
    g[..., 2] = np.radians(3.0)
    np.testing.assert_allclose(cal.gyro_bias(g, a)[:, 2], np.radians(3.0))


def test_accelerometer_offsets_from_the_tilts(procedure):
    p = procedure
    bias = cal.gyro_bias(p["g"][p["ph"]["still"]], p["a"][p["ph"]["still"]])
    s = p["ph"]["tilt"]
    offsets, ok = cal.accel_offsets(p["g"][s] - bias, p["a"][s], 1.0 / RATE)
    assert ok.all()
    true = p["imus"].accel_offset / G
    assert np.abs(true).max() > 0.03  # the datasheet's +-60 mg
    np.testing.assert_allclose(offsets, true, atol=0.006)
    # flexing the fingers turns the palm about no axis at all and the fingers about one: not enough
    f = p["ph"]["flex"]
    _, ok = cal.accel_offsets(p["g"][f] - bias, p["a"][f], 1.0 / RATE)
    assert not ok[0]


def test_sensor_to_segment_alignment_kortier_eq_34(procedure):
    p = procedure
    still, flex, tilt = (p["ph"][k] for k in ("still", "flex", "tilt"))
    bias = cal.gyro_bias(p["g"][still], p["a"][still])
    offsets, _ = cal.accel_offsets(p["g"][tilt] - bias, p["a"][tilt], 1.0 / RATE)
    axes = cal.flexion_axes(p["g"][flex] - bias)
    axes[0] = np.nan  # the palm does not flex: tilt only
    mounts = cal.align(p["a"][still].mean(0) - offsets, axes)
    true = p["imus"].mount_quat
    err = np.degrees(quat.angle_between(mounts, true))
    naive = np.degrees(quat.angle_between(np.tile(quat.IDENTITY, (12, 1)), true))
    assert err[1:].max() < 1.0, err.round(2)
    assert naive[1:].min() > 2.0  # the glove really is misaligned
    # the palm: its up axis is right, its heading about it unknowable from a flat hand
    up = np.array([0.0, 0.0, 1.0])
    tilt_err = quat.angle_between(
        quat.from_two_vectors(quat.rotate(mounts[0], up), quat.rotate(true[0], up)), quat.IDENTITY
    )
    assert np.degrees(tilt_err) < 0.5


def test_reference_pose_eq_3_21(procedure):
    """C (x) q_imu (x) mount^-1 is the model's reference pose at the moment of the reference, whatever the
    filters' own headings (yaw 0 per IMU from gravity)."""
    p = procedure
    rest = p["ph"]["rest"]
    f = make_filter("mahony")
    f.reset(p["a"][rest].mean(0) - p["imus"].accel_offset / G)
    seg_model = cal.model_frames()
    C = cal.reference(f.q, p["imus"].mount_quat)
    seg = quat.mul(quat.mul(C, f.q), quat.conj(p["imus"].mount_quat))
    # relative to the palm, the segments are where the model puts them (tilts from gravity, headings from C)
    rel = quat.mul(quat.conj(seg[:1]), seg)
    rel_model = quat.mul(quat.conj(seg_model[:1]), seg_model)
    assert np.degrees(quat.angle_between(rel, rel_model)).max() < 0.3
    np.testing.assert_allclose(C[:, 1:3], 0.0, atol=1e-12)  # headings only


def test_calibration_json_is_versioned_per_glove(tmp_path):
    c = cal.GloveCalibration(glove_id=0x1234, gyro_bias=np.full((12, 3), 0.01))
    c.gyro_bias_temp_c[:] = 25.0
    path = c.save(tmp_path)
    assert path.name == "glove_00001234.json"
    back = cal.GloveCalibration.load(tmp_path, 0x1234)
    np.testing.assert_array_equal(back.gyro_bias, c.gyro_bias)
    assert back.version == cal.VERSION
    with pytest.raises(FileNotFoundError):
        cal.GloveCalibration.load(tmp_path, 0x9999)
    path.write_text(path.read_text().replace(f'"version": {cal.VERSION}', '"version": 99'))
    with pytest.raises(ValueError, match="version 99"):
        cal.GloveCalibration.load(tmp_path, 0x1234)


def test_host_calibrates_from_raw_frames(procedure):
    from recorder.fusion import HostFusion

    b = procedure["b"]
    t = np.round(np.arange(len(b.t)) * 1e6 / RATE).astype(np.int64)
    frames = [RawFrame(k, int(t[k]), b.raw[k]) for k in range(len(b.t))]
    ph = procedure["ph"]
    hf = HostFusion()
    c = hf.calibrate(frames[ph["still"]], frames[ph["flex"]], frames[ph["tilt"]], glove_id=7)
    assert c.glove_id == 7 and all(c.quality["accel_offset_ok"]) and c.quality["flexion_axis_ok"][1:] == [True] * 11
    assert np.all(np.abs(c.gyro_bias_temp_c - 24) < 1.5)  # the MPU9250's die temperature register
    with pytest.raises(cal.CalibrationRefused):
        hf.calibrate(frames[ph["flex"]])
