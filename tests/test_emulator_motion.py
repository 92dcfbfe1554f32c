"""Ground-truth motion generators of the glove emulator."""

import numpy as np
import pytest

from recorder import quat
from recorder.hand import kinematics as kin
from recorder.hand.gestures import GESTURES
from recorder.hand.motion import KINDS, Motion

J = kin.JOINTS.index
RATE = 100.0


def tips(angles):
    return kin.forward(angles, quat.IDENTITY)[2]


def extended(tip, wrist_dist=0.12):
    return np.linalg.norm(tip) > wrist_dist


@pytest.mark.parametrize("name", sorted(GESTURES))
def test_gestures_within_limits_and_follow_eq_3_3(name):
    a = GESTURES[name]
    assert a.shape == (kin.N_JOINTS,)
    assert np.all(a >= kin.LIMITS[:, 0]) and np.all(a <= kin.LIMITS[:, 1])
    np.testing.assert_allclose(a, kin.interpolate_dip(a))


def test_named_gestures_exist():
    assert {"open", "fist", "pinch", "point", "two_fingers", "spiderman"} <= set(GESTURES)


def test_pinch_brings_thumb_and_index_tips_together():
    t = tips(GESTURES["pinch"])
    assert np.linalg.norm(t[0] - t[1]) < 0.015
    t_open = tips(GESTURES["open"])
    assert np.linalg.norm(t_open[0] - t_open[1]) > 0.05


def test_gesture_shapes():
    # thumb, index, middle, ring, pinky tips: extended = far from the wrist
    two = [extended(t) for t in tips(GESTURES["two_fingers"])[1:]]
    spider = [extended(t) for t in tips(GESTURES["spiderman"])[1:]]
    point = [extended(t) for t in tips(GESTURES["point"])[1:]]
    fist = [extended(t) for t in tips(GESTURES["fist"])[1:]]
    assert two == [True, True, False, False]
    assert spider == [True, False, False, True]
    assert point == [True, False, False, False]
    assert fist == [False] * 4
    assert GESTURES["spiderman"][J("thumb_ip")] <= 0 and GESTURES["spiderman"][J("thumb_mcp")] <= 0


@pytest.mark.parametrize("kind", KINDS)
def test_blocks_are_continuous(kind):
    whole = Motion(kind, seed=5, rate_hz=RATE).next_block(700)
    m = Motion(kind, seed=5, rate_hz=RATE)
    parts = [m.next_block(n) for n in (1, 99, 250, 7, 343)]
    for field in ("t", "angles", "palm_quat", "palm_pos"):
        joined = np.concatenate([getattr(p, field) for p in parts])
        np.testing.assert_allclose(joined, getattr(whole, field), rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_deterministic_per_seed(kind):
    a = Motion(kind, seed=11, rate_hz=RATE).next_block(300)
    b = Motion(kind, seed=11, rate_hz=RATE).next_block(300)
    c = Motion(kind, seed=12, rate_hz=RATE).next_block(300)
    np.testing.assert_array_equal(a.angles, b.angles)
    np.testing.assert_array_equal(a.palm_quat, b.palm_quat)
    assert np.abs(a.angles - c.angles).max() > np.radians(1)


@pytest.mark.parametrize("kind", KINDS)
def test_long_run_within_limits_smooth_and_eq_3_3(kind):
    b = Motion(kind, seed=2, rate_hz=RATE).next_block(int(30 * RATE))
    assert b.t[0] == 0.0 and b.t[-1] == pytest.approx(30 - 1 / RATE)
    assert np.all(b.angles >= kin.LIMITS[:, 0]) and np.all(b.angles <= kin.LIMITS[:, 1])
    np.testing.assert_allclose(b.angles, kin.interpolate_dip(b.angles), atol=1e-12)
    speed = np.abs(np.diff(b.angles, axis=0)) * RATE  # rad/s
    assert speed.max() < np.radians(800)  # no jumps
    assert np.ptp(b.angles[:, J("index_pip")]) > np.radians(40)  # and it does move
    np.testing.assert_allclose(np.linalg.norm(b.palm_quat, axis=1), 1.0, atol=1e-12)


def test_random_motion_is_low_frequency():
    b = Motion("random", seed=4, rate_hz=RATE).next_block(int(40 * RATE))
    x = b.angles - b.angles.mean(axis=0)
    power = np.abs(np.fft.rfft(x * np.hanning(len(x))[:, None], axis=0)) ** 2
    f = np.fft.rfftfreq(len(x), 1 / RATE)
    assert power[f > 2.5].sum() < 1e-3 * power.sum()


def test_gestures_hold_then_move_between_different_gestures():
    b = Motion("gestures", seed=1, rate_hz=RATE).next_block(int(20 * RATE))
    names = list(GESTURES)
    ref = np.stack([GESTURES[n] for n in names])
    nearest = np.argmin(np.abs(b.angles[:, None, :] - ref[None]).max(axis=2), axis=1)
    changes = np.count_nonzero(np.diff(nearest))
    assert changes >= 8  # a gesture every 0.9-2.5 s
    # during holds the hand is nearly still: a good share of samples has slow joints
    speed = np.abs(np.diff(b.angles, axis=0)).max(axis=1) * RATE
    still = np.mean(speed < np.radians(15))
    assert 0.3 < still < 0.8


def test_palm_moves_a_little():
    b = Motion("gestures", seed=3, rate_hz=RATE).next_block(int(20 * RATE))
    tilt = np.degrees(quat.angle_between(b.palm_quat, quat.IDENTITY))
    assert 10 < tilt.max() < 60
    span = np.ptp(b.palm_pos, axis=0)
    assert np.all(span > 0.005) and np.all(span < 0.1)
    acc = np.diff(b.palm_pos, 2, axis=0) * RATE**2
    assert 0.1 < np.linalg.norm(acc, axis=1).max() < 5.0  # m/s²


def test_unknown_kind_lists_valid_ones():
    with pytest.raises(ValueError, match="gestures.*random"):
        Motion("dance")


def test_rate_sets_time_base():
    b = Motion("random", rate_hz=50.0).next_block(10)
    np.testing.assert_allclose(np.diff(b.t), 0.02)
    assert Motion("random").next_block(0).angles.shape == (0, kin.N_JOINTS)
