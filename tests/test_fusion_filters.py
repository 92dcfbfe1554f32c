"""The glove filters: the thesis' complementary filter (eq. 3.4-3.19), Mahony (Santaera Alg. 1), the relative
two-IMU form (Alg. 2) and Madgwick, all over the 12 IMUs at once, on their numba kernels (recorder/fusion/
kernels.py): ``update`` and ``filter_block`` run the same step kernels (tests/test_fusion_block.py)."""

import numpy as np
import pytest

from recorder import quat
from recorder.fusion import filter_names, make_filter
from recorder.fusion.bias import BiasTracker
from recorder.fusion.block import filter_block
from recorder.fusion.complementary import ComplementaryFilter, ComplementarySettings, adaptive_gain
from recorder.fusion.gravity import attitude_from_gravity
from recorder.fusion.relative import RelativeFilter, RelativeSettings

UP = np.array([0.0, 0.0, 1.0])
RATE = 200.0


def up_in_body(q):
    return quat.rotate(quat.conj(q), UP)


def tilt_error_deg(est, truth):
    """Angle between the true and estimated up directions, per IMU."""
    a = quat.rotate(est, up_in_body(truth))
    return np.degrees(np.arccos(np.clip(a[..., 2], -1.0, 1.0)))


def random_orientations(n, seed=0, max_tilt=1.396):  # 80 degrees
    rng = np.random.default_rng(seed)
    yaw = quat.from_axis_angle(UP, rng.uniform(-np.pi, np.pi, n))
    axis = np.concatenate((rng.normal(size=(n, 2)), np.zeros((n, 1))), axis=1)
    tilt = quat.from_axis_angle(axis, rng.uniform(0, max_tilt, n))
    return quat.mul(tilt, yaw)


def still(q, T, seed=1, noise=True):
    """gyro (rad/s), accel (g) of still IMUs with orientations q (n, 4), MPU9250-like noise at 200 Hz."""
    rng = np.random.default_rng(seed)
    n = len(q)
    accel = np.broadcast_to(up_in_body(q), (T, n, 3)).copy()
    gyro = np.zeros((T, n, 3))
    if noise:
        accel += rng.normal(0, 300e-6 * np.sqrt(RATE / 2), accel.shape)
        gyro += rng.normal(0, np.radians(0.01) * np.sqrt(RATE / 2), gyro.shape)
    return gyro, accel


# ------------------------------------------------------------------------------------------------ registry
def test_unknown_filter_name_lists_the_valid_ones():
    with pytest.raises(ValueError) as e:
        make_filter("kalman")
    for name in filter_names():
        assert name in str(e.value)
    assert set(filter_names()) == {"inertial", "complementary", "mahony", "relative", "madgwick"}


def test_unknown_setting_is_refused_and_known_ones_apply():
    with pytest.raises(ValueError, match="static_gain"):
        make_filter("complementary", gain=0.1)
    f = make_filter("mahony", kp=2.5)
    assert f.settings.kp == 2.5 and f.q.shape == (12, 4)


# ------------------------------------------------------------------------------------------------ thesis filter
def test_adaptive_gain_is_eq_3_19():
    s = ComplementarySettings()
    norms = np.array([1.0, 1.1, 0.9, 1.15, 0.85, 1.19, 1.2, 3.0, 0.0, np.nan])
    expected = 0.005 * np.array([1, 1, 1, 0.5, 0.5, 0.1, 0, 0, 0, 0])
    np.testing.assert_allclose(adaptive_gain(s, norms), expected, atol=1e-12)


def test_attitude_from_gravity_eq_3_5_3_6():
    q = random_orientations(200, seed=4)
    a = up_in_body(q) * 1.3  # the magnitude does not matter
    est = attitude_from_gravity(a)
    np.testing.assert_allclose(quat.rotate(est, a / 1.3), np.tile(UP, (200, 1)), atol=1e-12)
    # eq. 3.6 with yaw 0: roll 0.3 rad about x is (cos 0.15, sin 0.15, 0, 0)
    np.testing.assert_allclose(
        attitude_from_gravity([0, np.sin(0.3), np.cos(0.3)]), [np.cos(0.15), np.sin(0.15), 0, 0], atol=1e-15
    )
    # pitch: the x axis tipped down (a = (sin p, 0, cos p) is a rotation of -p about y)
    np.testing.assert_allclose(
        attitude_from_gravity([np.sin(0.4), 0, np.cos(0.4)]), [np.cos(0.2), 0, -np.sin(0.2), 0], atol=1e-15
    )
    np.testing.assert_array_equal(attitude_from_gravity(np.zeros(3)), quat.IDENTITY)


def test_median_window_matches_the_firmware_definition():
    f = ComplementaryFilter(1, ComplementarySettings(median_window=12))
    np.testing.assert_array_equal(f.median(), np.zeros((1, 3)))  # empty: zeros
    outs = []
    for v in [5.0, 1.0, 3.0, 2.0]:
        f.observe(np.full((1, 3), v))
        outs.append(f.median()[0, 0])
    assert outs == [5.0, 3.0, 3.0, 2.5]  # the samples held; even count: mean of the two middle ones
    for v in range(10):
        f.observe(np.full((1, 3), 100.0 + v))
    # full (12): the last 12 samples are 3, 2, 100..109 -> middle two 103, 104 (the 5 and 1 fell out)
    assert f.median()[0, 0] == pytest.approx(103.5)
    f.observe(np.full((1, 3), 200.0))  # overwrites the oldest (the 3): 2, 100..109, 200 -> 104.5
    assert f.median()[0, 0] == pytest.approx(104.5) and list(f.count) == [12] and list(f.head) == [3]
    masked = ComplementaryFilter(2)
    masked.observe(np.ones((2, 3)), mask=np.array([True, False]))
    assert list(masked.count) == [1, 0]
    np.testing.assert_array_equal(masked.median(), [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="median window"):
        ComplementaryFilter(1, ComplementarySettings(median_window=0))


def test_median_rejects_accelerometer_spikes():
    f = ComplementaryFilter(1)
    f.reset(np.array([[0, 0, 1.0]]))
    for _ in range(12):
        f.update(np.zeros((1, 3)), np.array([[0, 0, 1.0]]), 0.005)
    for _ in range(5):  # 5 spikes in a window of 12 do not move the median
        f.update(np.zeros((1, 3)), np.array([[0.9, 0, 0.2]]), 0.005)
    assert quat.angle_between(f.q[0], quat.IDENTITY) < 1e-12
    f.update(np.zeros((1, 3)), np.array([[0.9, 0, 0.2]]), 0.005)  # the 6th: the median moves
    f.update(np.zeros((1, 3)), np.array([[0.9, 0, 0.2]]), 0.005)
    assert quat.angle_between(f.q[0], quat.IDENTITY) > 1e-4


def test_one_step_removes_alpha_of_a_small_tilt_error():
    """Eq. 3.14: one step with the static gain removes 0.5 % of a small tilt error."""
    f = ComplementaryFilter(1, ComplementarySettings(median_window=1))
    f.q[0] = quat.from_axis_angle([1, 0, 0], np.radians(2))
    f.update(np.zeros((1, 3)), np.array([[0, 0, 1.0]]), 0.005)
    assert np.degrees(quat.angle_between(f.q[0], quat.IDENTITY)) == pytest.approx(2 * 0.995, abs=1e-4)


def thesis_listing_step(q, gyro, a, dt, alpha=0.005):
    """The thesis' Hand::updateJoint as printed: the correction multiplied from the right."""
    h = 0.5 * dt * gyro
    qw = quat.normalize(q + quat.mul(q, np.concatenate(([0.0], h))))
    gp = quat.rotate(qw, a / np.linalg.norm(a))
    dq = quat.from_two_vectors(gp, UP)
    dq = quat.normalize((1 - alpha) * quat.IDENTITY + alpha * dq)
    return quat.normalize(quat.mul(qw, dq))


def test_correction_is_applied_in_the_world_frame():
    """At a heading of 180 degrees the listing's right-multiplied correction drives a 10 degree tilt error
    away; multiplied from the left (the world frame, where g_p and (0, 0, 1) live) it converges."""
    truth = quat.from_axis_angle(UP, np.pi)
    start = quat.mul(truth, quat.from_axis_angle([1, 0, 0], np.radians(10)))
    a = up_in_body(truth)
    f = ComplementaryFilter(1)
    f.q[0] = start
    listing = start.copy()
    for _ in range(1000):
        f.update(np.zeros((1, 3)), a[None], 0.005)
        listing = thesis_listing_step(listing, np.zeros(3), a, 0.005)
    assert tilt_error_deg(f.q[0], truth) < 0.1
    assert tilt_error_deg(listing, truth) > 20.0
    assert np.degrees(quat.angle_between(f.q[0], truth)) < 0.2  # the heading is left alone


# ------------------------------------------------------------------------------------------------ all filters
@pytest.mark.parametrize("name", sorted(filter_names()))
def test_converges_from_a_wrong_start(name):
    truth = random_orientations(12, seed=2)
    # Madgwick's normalised gradient step turns at most beta = 0.01 rad/s (0.6 deg/s) towards gravity; the
    # inertial filter follows its low-pass (three stages of 4 s, settling in about a minute)
    gyro, accel = still(truth, int({"madgwick": 90, "inertial": 60}.get(name, 20) * RATE))
    f = make_filter(name)
    wrong = quat.rotate(quat.from_axis_angle([1, 0.5, 0], np.radians(40)), up_in_body(truth))
    f.reset(wrong)
    start = tilt_error_deg(f.q, truth)
    assert np.all(start > 20)
    out = filter_block(f, gyro, accel, 1.0 / RATE)
    err = tilt_error_deg(out[-1], truth)
    assert np.all(err < 0.5), err.round(2)
    assert np.all(tilt_error_deg(out[len(out) // 3], truth) < 0.75 * start)  # converging, not jumping at the end


@pytest.mark.parametrize("name", ["complementary", "mahony", "madgwick"])
def test_adaptive_gain_ignores_linear_acceleration_bursts(name):
    """Bursts of 0.8 g sideways (|a| = 1.28 g, e_m beyond t2) for 0.6 s every second: with the eq. 3.19 ramp
    the tilt stays put; without it (thresholds at infinity) the filter tilts towards the fake gravity. (The
    complementary filter's median sees one sample of |a| = 1.08 g at each burst edge: a few tenths of a degree.)"""
    truth = np.tile(quat.IDENTITY, (12, 1))
    T = int(10 * RATE)
    gyro, accel = still(truth, T)
    burst = (np.arange(T) % int(RATE)) < int(0.6 * RATE)
    accel[burst, :, 0] += 0.8
    no_ramp = {"threshold1": np.inf, "threshold2": np.inf}
    errs = []
    for settings in ({}, no_ramp):
        f = make_filter(name, **settings)
        f.reset(up_in_body(truth))
        out = filter_block(f, gyro, accel, 1.0 / RATE)
        errs.append(tilt_error_deg(out, truth).max())
    assert errs[0] < 1.0 and errs[0] < 0.1 * errs[1], errs
    assert errs[1] > 2.0, errs


def test_mahony_integral_and_the_tracker_remove_a_constant_bias():
    """A constant 1 deg/s gyro bias on every axis of tilted, still IMUs: Mahony's integral (Alg. 1 step 8)
    and the bias tracker (gravity + stillness) learn it; the orientation does not drift."""
    truth = random_orientations(12, seed=5, max_tilt=np.radians(60))
    T = int(60 * RATE)
    gyro, accel = still(truth, T)
    bias = np.radians(1.0)
    f = make_filter("mahony", ki=0.2)
    f.reset(up_in_body(truth))
    f.q = truth.copy()
    out = filter_block(f, gyro + bias, accel, 1.0 / RATE)
    up = up_in_body(truth)
    horizontal = lambda b: b - np.sum(b * up, axis=1, keepdims=True) * up  # noqa: E731 (gravity sees these)
    np.testing.assert_allclose(
        np.degrees(horizontal(f.bias)), np.degrees(horizontal(np.full((12, 3), bias))), atol=0.03
    )
    assert tilt_error_deg(out[-1], truth).max() < 0.2
    # the tracker: stillness makes all three components observable
    tracker = BiasTracker(12)
    g = make_filter("madgwick")
    g.q = truth.copy()
    for k in range(int(10 * RATE)):
        q = g.update(gyro[k] + bias - tracker.b, accel[k], 1.0 / RATE)
        tracker.update(gyro[k] + bias, accel[k], q, np.ones(12), 1.0 / RATE)
    np.testing.assert_allclose(np.degrees(tracker.b), 1.0, atol=0.05)


def test_relative_filter_follows_a_hinge_while_the_parent_turns():
    """Alg. 2 on a pair: the child flexes to 90 degrees about y while the parent turns about its z. The
    relative rate must be gyro_c - R^T gyro_p; eq. 18 as printed (gyro_c - gyro_p) loses track."""
    T = int(6 * RATE)
    t = np.arange(T) / RATE
    parent = quat.from_axis_angle(UP, 0.8 * t)
    flex = np.radians(90) * np.clip(t / 2.0, 0, 1)
    rel_true = quat.from_axis_angle([0, 1, 0], flex)
    child = quat.mul(parent, rel_true)
    q = np.stack((parent, child), axis=1)
    dq = quat.mul(quat.conj(q[:-1]), q[1:])
    gyro = np.concatenate((quat.to_rotvec(dq[:1]), quat.to_rotvec(dq))) * RATE
    accel = up_in_body(q)
    errs = []
    for rotate in (True, False):
        f = RelativeFilter(2, RelativeSettings(rotate_parent_rate=rotate), parents=(-1, 0))
        f.reset(accel[0])
        for k in range(1, T):
            f.update(gyro[k], accel[k], 1.0 / RATE)
        errs.append(np.degrees(quat.angle_between(f.rel[1], rel_true[-1])))
    assert errs[0] < 1.0, errs
    assert errs[1] > 10.0, errs


def test_a_masked_imu_keeps_its_state():
    f = make_filter("complementary")
    truth = random_orientations(12, seed=8)
    gyro, accel = still(truth, 50)
    f.reset(up_in_body(truth))
    before = f.q.copy()
    mask = np.ones(12, bool)
    mask[3] = False
    filter_block(f, gyro + 0.5, accel, 1.0 / RATE, mask=np.tile(mask, (50, 1)))
    np.testing.assert_array_equal(f.q[3], before[3])
    assert np.all(np.delete(quat.angle_between(f.q, before), 3) > 0.05)
