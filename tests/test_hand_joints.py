"""Hand model: relative orientations -> joint angles (dimensionality, limits, eq. 3.3), fingertips."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from recorder import quat
from recorder.hand import joints, kinematics as kin
from recorder.hand.gestures import GESTURES
from recorder.hand.skeleton import FINGER_SEGMENTS, FINGERS, N_SEGMENTS

HINGE_SEGMENTS = [s for s, _, _ in joints.HINGE]
SWING_SEGMENTS = [s for s, _, _ in joints.SWING]


@st.composite
def joint_angles(draw):
    u = draw(arrays(float, kin.N_JOINTS, elements=st.floats(0.0, 1.0)))
    return kin.interpolate_dip(kin.LIMITS[:, 0] + u * (kin.LIMITS[:, 1] - kin.LIMITS[:, 0]))


rotvecs = arrays(float, (N_SEGMENTS, 3), elements=st.floats(-0.5, 0.5, allow_nan=False))


def test_flat_hand_is_all_zero():
    rel = np.tile(quat.IDENTITY, (N_SEGMENTS, 1))
    rel[FINGER_SEGMENTS["thumb"][0]] = kin.REST[FINGER_SEGMENTS["thumb"][0]]
    np.testing.assert_allclose(joints.joint_angles(rel), 0.0, atol=1e-12)


@pytest.mark.parametrize("name", sorted(GESTURES))
def test_thesis_demo_poses_round_trip(name):
    """Every gesture of the emulator (the thesis' demo poses: open, fist, pinch, point, two fingers, ...)."""
    pose = GESTURES[name]
    g, _, _ = kin.forward(pose, quat.from_rotvec([0.3, -0.2, 1.0]))  # any palm orientation
    got = joints.joint_angles(kin.relative_quats(g))
    np.testing.assert_allclose(np.degrees(got), np.degrees(pose), atol=1e-6)


def test_fist_within_tolerance_under_sensor_noise():
    """A fist seen through 1 degree of orientation noise per segment comes back within 2.5 degrees."""
    rng = np.random.default_rng(3)
    pose = GESTURES["fist"]
    g, _, _ = kin.forward(pose, quat.IDENTITY)
    noisy = quat.mul(g, quat.from_rotvec(rng.normal(0.0, np.radians(1.0) / np.sqrt(3), (200,) + g.shape[:-1] + (3,))))
    got = joints.joint_angles(kin.relative_quats(noisy))
    err = np.degrees(np.sqrt(np.mean((got - pose) ** 2, axis=0)))
    assert err.max() < 2.5, dict(zip(kin.JOINTS, err.round(2)))
    assert np.degrees(got[:, 4]).mean() == pytest.approx(np.degrees(pose[4]), abs=0.5)  # index MCP at ~85°


@settings(max_examples=80, deadline=None)
@given(joint_angles(), rotvecs)
def test_projection_never_yields_twist(angles, noise):
    """Kortier's dimensionality: whatever the measured rotations, the hinge joints come out as rotations about
    y only and the 2-DoF joints without twist about the bone (Rz(abd) Ry(flex)); projecting again changes
    nothing (idempotent)."""
    rel = quat.mul(joints.constrained_relative(angles), quat.from_rotvec(noise))
    out = joints.constrained_relative(joints.joint_angles(rel, limits=False, interpolate=False))
    local = quat.mul(quat.conj(kin.REST), out)
    hinge = local[HINGE_SEGMENTS]
    np.testing.assert_allclose(hinge[:, [1, 3]], 0.0, atol=1e-12)  # no x or z component: a pure y rotation
    sw = local[SWING_SEGMENTS]
    m = quat.to_matrix(sw)
    # Rz(a) Ry(f) keeps the y axis horizontal in the parent frame: no twist about the bone
    np.testing.assert_allclose(m[:, 2, 1], 0.0, atol=1e-12)
    again = joints.joint_angles(out, limits=False, interpolate=False)
    np.testing.assert_allclose(again, joints.joint_angles(rel, limits=False, interpolate=False), atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(joint_angles(), rotvecs)
def test_projection_is_the_closest_allowed_rotation(angles, noise):
    """The 2-DoF projection is at least as close to the measurement as the plain Euler decomposition."""
    rel = quat.mul(joints.constrained_relative(angles), quat.from_rotvec(noise))
    ours = joints.constrained_relative(joints.joint_angles(rel, limits=False, interpolate=False))
    euler = joints.constrained_relative(kin.joint_angles_from_relative(rel))
    s = SWING_SEGMENTS
    assert np.all(quat.angle_between(rel[s], ours[s]) <= quat.angle_between(rel[s], euler[s]) + 1e-9)


def test_hinge_twist_is_removed_not_turned_into_flexion():
    """A PIP rotation with 10 degrees of impossible twist about the bone keeps its flexion."""
    angles = np.zeros(kin.N_JOINTS)
    angles[kin.JOINTS.index("index_pip")] = np.radians(40)
    rel = joints.constrained_relative(angles)
    s = FINGER_SEGMENTS["index"][1]
    rel[s] = quat.mul(rel[s], quat.from_axis_angle([1, 0, 0], np.radians(10)))
    got = joints.joint_angles(rel)
    assert np.degrees(got[kin.JOINTS.index("index_pip")]) == pytest.approx(40.0, abs=1e-9)
    assert joints.twist(rel)[s] == pytest.approx(np.radians(10), abs=1e-9)


def test_limits_clamp_and_distal_interpolation():
    angles = np.zeros(kin.N_JOINTS)
    angles[kin.JOINTS.index("middle_pip")] = np.radians(150)  # beyond 110
    angles[kin.JOINTS.index("ring_pip")] = np.radians(-20)  # hyperextension beyond 0
    angles[kin.JOINTS.index("index_mcp_abd")] = np.radians(-40)  # beyond -25
    g, _, _ = kin.forward(angles, quat.IDENTITY)
    got = np.degrees(joints.joint_angles(kin.relative_quats(g)))
    assert got[kin.JOINTS.index("middle_pip")] == pytest.approx(110.0)
    assert got[kin.JOINTS.index("ring_pip")] == pytest.approx(0.0)
    assert got[kin.JOINTS.index("index_mcp_abd")] == pytest.approx(-25.0)
    assert got[kin.JOINTS.index("middle_dip")] == pytest.approx(110.0 * 65 / 115)  # eq. 3.3
    assert got[kin.JOINTS.index("ring_dip")] == 0.0  # eq. 3.3, alpha < 0
    free = np.degrees(joints.joint_angles(kin.relative_quats(g), limits=False, interpolate=False))
    assert free[kin.JOINTS.index("middle_pip")] == pytest.approx(150.0)


def test_distal_without_imu_follows_eq_3_3():
    """The glove has no distal IMUs: whatever the distal rows say, the DIPs come from the PIPs."""
    angles = GESTURES["point"]
    rel = joints.constrained_relative(angles)
    for f in FINGERS[1:]:
        rel[FINGER_SEGMENTS[f][2]] = quat.IDENTITY  # what a glove without distal IMUs measures
    got = joints.joint_angles(rel)
    np.testing.assert_allclose(got[list(kin.DIP)], kin.DIP_PER_PIP * np.maximum(got[list(kin.PIP)], 0))
    np.testing.assert_allclose(got, angles, atol=1e-9)


def test_fingertips_are_kinematics_forward():
    pose = GESTURES["pinch"]
    palm = quat.from_rotvec([0.1, 0.2, 0.3])
    np.testing.assert_allclose(joints.fingertips(pose, palm), kin.forward(pose, palm)[2])
    tips = joints.fingertips(pose)
    # the pinch: thumb tip on the index tip (the emulator places them about 1 mm apart)
    assert np.linalg.norm(tips[0] - tips[1]) < 0.01
