"""Synthetic MPU9250 readings and the SyntheticGlove façade."""

import numpy as np
import pytest

from recorder import quat
from recorder.emulator.glove import GloveBlock, SyntheticGlove
from recorder.emulator.imu import G, ImuArray
from recorder.hand import kinematics as kin
from recorder.hand.motion import Motion
from recorder.hand.skeleton import JOINT_MAP, N_IMUS, N_SEGMENTS

RATE = 200.0


def still(n, q=quat.IDENTITY):
    return np.broadcast_to(q, (n, N_IMUS, 4)), np.zeros((n, N_IMUS, 3))


def spinning(n, rate_dps, axis=(0.0, 0.0, 1.0), t0=0):
    """All IMUs turning at a constant rate about a fixed world axis, from a tilted start."""
    t = (t0 + np.arange(n)) / RATE
    start = quat.from_rotvec([0.2, -0.1, 0.4])
    turn = quat.from_axis_angle(axis, np.radians(rate_dps) * t)
    q = quat.mul(turn, start)
    return np.broadcast_to(q[:, None], (n, N_IMUS, 4)), np.zeros((n, N_IMUS, 3)), start


def accel_g(raw, fs=16):
    return raw[..., 0:3].astype(float) * fs / 32768.0


def gyro_dps(raw, fs=2000):
    return raw[..., 3:6].astype(float) * fs / 32768.0


def test_still_flat_hand_reads_one_g_up_and_gyro_bias():
    imu = ImuArray(RATE, seed=1)
    b = imu.sample(*still(400))
    assert b.raw.dtype == np.int16 and b.raw.shape == (400, N_IMUS, 7)
    a = accel_g(b.raw).mean(axis=0)
    np.testing.assert_allclose(a, np.tile([0.0, 0.0, 1.0], (N_IMUS, 1)), atol=0.065)  # ±60 mg offsets
    np.testing.assert_allclose(a, (b.accel_true[0] + b.accel_offset) / G, atol=0.002)
    np.testing.assert_allclose(b.accel_true, np.broadcast_to([0, 0, G], b.accel_true.shape), atol=1e-9)
    # gyro = bias + noise: 0.01 dps/√Hz · √100 Hz = 0.1 dps per sample, so the 400-sample mean is ±0.02
    bias_dps = np.degrees(b.gyro_bias)
    g = gyro_dps(b.raw)
    np.testing.assert_allclose(g.mean(axis=0), bias_dps.mean(axis=0), atol=0.05)
    assert 0.05 < np.std(g - bias_dps) < 0.2
    assert np.abs(bias_dps).max() <= 5.0 + 0.1 and np.abs(bias_dps).max() > 1.0
    assert np.abs(b.gyro_true).max() < 1e-12


def test_tilted_still_imu_sees_gravity_in_its_own_frame():
    q = quat.from_rotvec([np.radians(90), 0.0, 0.0])  # IMU z now points along world -y
    b = ImuArray(RATE, noise=False, bias=False).sample(*still(10, q))
    np.testing.assert_allclose(accel_g(b.raw)[-1], np.tile([0.0, 1.0, 0.0], (N_IMUS, 1)), atol=1e-3)


@pytest.mark.parametrize("rate_dps", [90.0, -250.0])
def test_constant_rotation_rate_is_recovered(rate_dps):
    q, p, _ = spinning(600, rate_dps)
    imu = ImuArray(RATE, seed=3, noise=False)
    b = imu.sample(q, p)
    body = np.array([0.0, 0.0, rate_dps])  # rotation about world z, expressed in the body frame:
    start = quat.from_rotvec([0.2, -0.1, 0.4])
    body = quat.rotate(quat.conj(start), body)
    measured = (gyro_dps(b.raw) - np.degrees(b.gyro_bias)).mean(axis=0)
    np.testing.assert_allclose(measured, np.tile(body, (N_IMUS, 1)), atol=0.1)
    np.testing.assert_allclose(np.degrees(b.gyro_true), np.broadcast_to(body, b.gyro_true.shape), atol=1e-9)


def test_gyro_integrates_back_to_the_trajectory():
    m = Motion("random", seed=7, rate_hz=RATE).next_block(400)
    g, pos, _ = kin.forward(m.angles, m.palm_quat)
    q = g[:, list(JOINT_MAP)]
    b = ImuArray(RATE, noise=False, bias=False).sample(q, pos[:, list(JOINT_MAP)] + m.palm_pos[:, None])
    est = q[0]
    for k in range(1, len(q)):
        est = quat.mul(est, quat.from_rotvec(b.gyro_true[k] / RATE))
    assert np.degrees(quat.angle_between(est, q[-1])).max() < 1e-6


def test_linear_acceleration_from_positions():
    n = 800
    t = np.arange(n) / RATE
    f, amp = 1.5, 0.03
    p = np.zeros((n, N_IMUS, 3))
    p[..., 0] = amp * np.sin(2 * np.pi * f * t)[:, None]
    q = np.broadcast_to(quat.IDENTITY, (n, N_IMUS, 4))
    imu = ImuArray(RATE, noise=False, bias=False)
    b = imu.sample(q[:300], p[:300])
    b2 = imu.sample(q[300:], p[300:])
    acc = np.concatenate((b.accel_true, b2.accel_true))
    expect_x = -((2 * np.pi * f) ** 2) * amp * np.sin(2 * np.pi * f * t)
    # O(dt²) difference error: 11/12 dt² ω⁴ A ≈ 5e-3 m/s² here; a one-sample lag would be off by 0.12
    np.testing.assert_allclose(acc[..., 0], np.broadcast_to(expect_x[:, None], (n, N_IMUS)), atol=1e-2)
    np.testing.assert_allclose(acc[..., 2], G, atol=1e-9)


def test_mount_offset_sees_centripetal_acceleration():
    w = np.radians(360.0)  # 1 turn/s about world z
    q, p, start = spinning(400, 360.0)
    offsets = np.zeros((N_IMUS, 3))
    offsets[:, 0] = 0.05
    b = ImuArray(RATE, noise=False, bias=False, mount_offsets=offsets).sample(q, p)
    r_horizontal = np.linalg.norm(quat.rotate(start, [0.05, 0, 0])[:2])
    a_world = quat.rotate(q[100:], b.accel_true[100:]) - [0, 0, G]
    np.testing.assert_allclose(np.linalg.norm(a_world, axis=-1), w * w * r_horizontal, rtol=1e-3)


@pytest.mark.parametrize("fs", [2, 4, 8, 16])
def test_accel_quantisation_scale(fs):
    b = ImuArray(RATE, accel_fs_g=fs, noise=False, bias=False).sample(*still(5))
    assert b.raw[-1, 0, 2] == round(32768 / fs)  # 1 g; 2048 LSB/g at ±16 g (datasheet)


@pytest.mark.parametrize("fs", [250, 500, 1000, 2000])
def test_gyro_quantisation_scale(fs):
    q, p, start = spinning(50, 200.0, axis=quat.rotate(quat.from_rotvec([0.2, -0.1, 0.4]), [0, 0, 1]))
    b = ImuArray(RATE, gyro_fs_dps=fs, noise=False, bias=False).sample(q, p)
    expected = min(round(200.0 * 32768 / fs), 32767)
    assert abs(int(b.raw[-1, 0, 5]) - expected) <= 1
    if fs == 2000:
        assert b.raw[-1, 0, 5] / 200.0 == pytest.approx(16.4, abs=0.05)  # datasheet sensitivity


def test_saturation_at_full_scale():
    q, p, _ = spinning(20, 3000.0, axis=(0.0, 0.0, 1.0))
    b = ImuArray(RATE, noise=False, bias=False, gyro_fs_dps=2000).sample(q, p)
    gz = b.raw[5:, 0, 3:6].astype(float)
    assert np.abs(gz).max() == 32767  # clipped, not wrapped
    q, p, _ = spinning(20, -3000.0, axis=(0.0, 0.0, 1.0))
    b = ImuArray(RATE, noise=False, bias=False, gyro_fs_dps=2000).sample(q, p)
    assert b.raw[5:, 0, 3:6].min() == -32768
    b = ImuArray(RATE, accel_fs_g=2, noise=False, bias=False).sample(*still(5, quat.from_rotvec([np.pi, 0, 0])))
    assert b.raw[-1, 0, 2] == -16384  # -1 g fits
    n = 50
    p = np.zeros((n, N_IMUS, 3))
    p[..., 2] = 0.5 * 30 * G * (np.arange(n) / RATE)[:, None] ** 2  # 30 g upward
    b = ImuArray(RATE, accel_fs_g=16, noise=False, bias=False).sample(*still(n)[:1], p)
    assert b.raw[10:, :, 2].min() == 32767 and b.accel_true[10:, :, 2].min() > 30 * G


def test_invalid_full_scale():
    with pytest.raises(ValueError):
        ImuArray(RATE, accel_fs_g=3)
    with pytest.raises(ValueError):
        ImuArray(RATE, gyro_fs_dps=300)


def test_temperature_rises_and_decodes():
    rate = 10.0
    imu = ImuArray(rate, seed=2)
    b = imu.sample(*still(int(600 * rate)))
    decoded = b.raw[..., 6].astype(float) / 333.87 + 21.0
    np.testing.assert_allclose(decoded, b.temp_c, atol=0.1)
    assert np.all((b.temp_c[0] > 23) & (b.temp_c[0] < 25))
    assert np.all(b.temp_c[-1] > b.temp_c[0] + 3)
    assert np.all(b.temp_c[-1] < 33)
    assert np.all(np.diff(b.temp_c, axis=0) > 0)
    # the gyro bias drifts with temperature, by at most 0.03 dps/°C
    drift = np.degrees(b.gyro_bias[-1] - b.gyro_bias[0])
    dtemp = (b.temp_c[-1] - b.temp_c[0])[:, None]
    assert np.all(np.abs(drift) <= 0.03 * dtemp + 1e-9) and np.abs(drift).max() > 0.01


def test_sampling_is_continuous_across_calls():
    m = Motion("gestures", seed=9, rate_hz=RATE).next_block(300)
    g, pos, _ = kin.forward(m.angles, m.palm_quat)
    q, p = g[:, list(JOINT_MAP)], pos[:, list(JOINT_MAP)] + m.palm_pos[:, None]
    whole = ImuArray(RATE, seed=4, noise=False).sample(q, p)
    imu = ImuArray(RATE, seed=4, noise=False)
    parts = [imu.sample(q[a:b], p[a:b]) for a, b in ((0, 10), (10, 11), (11, 150), (150, 300))]
    for field in ("raw", "gyro_true", "accel_true", "gyro_bias", "temp_c"):
        joined = np.concatenate([getattr(x, field) for x in parts])
        np.testing.assert_allclose(joined, getattr(whole, field), rtol=0, atol=1e-9)


def test_misalignment_tilts_the_readings():
    aligned = ImuArray(RATE, noise=False, bias=False).sample(*still(5))
    tilted = ImuArray(RATE, noise=False, bias=False, misalign_deg=3.0, seed=1).sample(*still(5))
    np.testing.assert_allclose(aligned.accel_true[-1], np.tile([0, 0, G], (N_IMUS, 1)), atol=1e-9)
    angle = np.degrees(np.arccos(np.clip(tilted.accel_true[-1, :, 2] / G, -1, 1)))
    assert 0.3 < angle.mean() < 8


# ---- SyntheticGlove ----------------------------------------------------------------------------------


def test_glove_block_shapes_and_truth():
    glove = SyntheticGlove("gestures", rate_hz=RATE, seed=1, pose_noise_deg=0.5)
    b = glove.next_block(400)
    assert isinstance(b, GloveBlock)
    assert b.raw.shape == (400, N_IMUS, 7) and b.raw.dtype == np.int16
    assert b.pose.shape == (400, N_SEGMENTS, 4) and b.pose.dtype == np.float32
    assert b.truth_rel.shape == (400, N_SEGMENTS, 4) and b.angles.shape == (400, 20)
    assert b.tips.shape == (400, 5, 3) and b.t.shape == (400,)
    assert (b.accel_fs_g, b.gyro_fs_dps) == (16, 2000)
    np.testing.assert_allclose(kin.joint_angles_from_relative(b.truth_rel), b.angles, atol=1e-9)
    err = np.degrees(quat.angle_between(b.pose.astype(float), b.truth_rel))
    assert 0.3 < np.sqrt(np.mean(err**2)) < 0.7  # 0.5° RMS
    # the palm IMU: gravity plus a little hand motion, bias-level gyro when slow
    a = accel_g(b.raw[:, 0])
    assert np.mean(np.linalg.norm(a, axis=1)) == pytest.approx(1.0, abs=0.1)


def test_glove_continuous_and_deterministic():
    a = SyntheticGlove("random", rate_hz=RATE, seed=3)
    whole = a.next_block(200)
    b = SyntheticGlove("random", rate_hz=RATE, seed=3)
    parts = [b.next_block(n) for n in (50, 150)]
    np.testing.assert_array_equal(np.concatenate([x.raw for x in parts]), whole.raw)
    np.testing.assert_array_equal(np.concatenate([x.truth_rel for x in parts]), whole.truth_rel)
    c = SyntheticGlove("random", rate_hz=RATE, seed=4).next_block(200)
    assert not np.array_equal(c.raw, whole.raw)


def test_a_glove_sending_poses_synthesises_no_readings_and_keeps_their_history():
    """next_block(raw=False): no IMU readings (a glove sending fused poses), the same motion; readings taken after
    it continue the IMUs' history as if every block had been read (without noise: the noise is drawn afresh)."""
    a = SyntheticGlove("random", rate_hz=RATE, seed=3, noise=False)
    b = SyntheticGlove("random", rate_hz=RATE, seed=3, noise=False)
    first_a, first_b = a.next_block(50), b.next_block(50, raw=False)
    assert first_b.raw is None
    np.testing.assert_array_equal(first_a.pose, first_b.pose)
    np.testing.assert_array_equal(a.next_block(100).raw, b.next_block(100).raw)


def test_glove_accel_matches_the_imu_pose():
    b = SyntheticGlove("random", rate_hz=RATE, seed=5, noise=False, bias=False).next_block(600)
    # the accelerometer's gravity direction is the IMU's global z, within the linear acceleration
    g = kin.global_from_relative(b.truth_rel)[:, list(JOINT_MAP)]
    up_in_body = quat.rotate(quat.conj(g), [0.0, 0.0, 1.0])
    a = accel_g(b.raw)
    cos = np.sum(a * up_in_body, axis=-1) / np.linalg.norm(a, axis=-1)
    assert np.median(cos) > 0.99
