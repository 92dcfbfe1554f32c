"""Quaternion helpers and the hand model's forward / inverse kinematics."""

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from recorder import quat
from recorder.hand import kinematics as kin
from recorder.hand.skeleton import FINGER_SEGMENTS, N_SEGMENTS

finite = st.floats(-1.0, 1.0, allow_nan=False)
vec3 = arrays(float, 3, elements=st.floats(-10.0, 10.0, allow_nan=False))


@st.composite
def unit_quats(draw):
    q = draw(arrays(float, 4, elements=finite))
    if np.linalg.norm(q) < 1e-3:
        q = np.array([1.0, 0.0, 0.0, 0.0])
    return quat.normalize(q)


@st.composite
def joint_angles(draw):
    u = draw(arrays(float, kin.N_JOINTS, elements=st.floats(0.0, 1.0)))
    return kin.LIMITS[:, 0] + u * (kin.LIMITS[:, 1] - kin.LIMITS[:, 0])


def same_rotation(p, q, tol=1e-9):
    return abs(abs(float(np.dot(p, q))) - 1.0) < tol


# ---- quaternions -------------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(unit_quats())
def test_q_times_conj_is_identity(q):
    np.testing.assert_allclose(quat.mul(q, quat.conj(q)), quat.IDENTITY, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(unit_quats(), vec3)
def test_rotate_preserves_norm_and_matches_matrix(q, v):
    r = quat.rotate(q, v)
    assert np.linalg.norm(r) == pytest.approx(np.linalg.norm(v), abs=1e-9)
    np.testing.assert_allclose(r, quat.to_matrix(q) @ v, atol=1e-9)
    # rotating by q p equals rotating by p then by q
    p = quat.normalize(np.array([0.3, -0.2, 0.9, 0.1]))
    np.testing.assert_allclose(quat.rotate(quat.mul(q, p), v), quat.rotate(q, quat.rotate(p, v)), atol=1e-9)


def test_mul_known_products():
    i, j, k = np.eye(4)[1:]
    np.testing.assert_allclose(quat.mul(i, j), k)
    np.testing.assert_allclose(quat.mul(j, i), -k)
    np.testing.assert_allclose(quat.mul(i, i), -quat.IDENTITY)


def test_rotate_quarter_turn_about_z():
    q = quat.from_axis_angle([0, 0, 1], np.pi / 2)
    np.testing.assert_allclose(quat.rotate(q, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(arrays(float, 3, elements=st.floats(-1.8, 1.8, allow_nan=False)))
def test_rotvec_round_trip(rv):
    np.testing.assert_allclose(quat.to_rotvec(quat.from_rotvec(rv)), rv, atol=1e-9)
    axis, angle = quat.to_axis_angle(quat.from_rotvec(rv))
    np.testing.assert_allclose(axis * angle, rv, atol=1e-9)


def test_rotvec_tiny_angles_are_stable():
    rv = np.array([1e-14, -2e-14, 3e-15])
    np.testing.assert_allclose(quat.to_rotvec(quat.from_rotvec(rv)), rv, rtol=1e-6, atol=0)


@settings(max_examples=60, deadline=None)
@given(unit_quats(), unit_quats(), st.floats(0.0, 1.0))
def test_slerp_endpoints_and_constant_speed(q0, q1, t):
    assert same_rotation(quat.slerp(q0, q1, 0.0), q0)
    assert same_rotation(quat.slerp(q0, q1, 1.0), q1)
    total = quat.angle_between(q0, q1)
    qt = quat.slerp(q0, q1, t)
    assert quat.angle_between(q0, qt) == pytest.approx(t * total, abs=1e-6)
    assert quat.angle_between(qt, q1) == pytest.approx((1 - t) * total, abs=1e-6)


def test_slerp_takes_the_short_way():
    q0 = quat.IDENTITY
    q1 = -quat.from_axis_angle([0, 0, 1], 0.2)  # same rotation as +0.2 rad, opposite sign
    mid = quat.slerp(q0, q1, 0.5)
    assert quat.angle_between(q0, mid) == pytest.approx(0.1, abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(vec3, vec3)
@example(np.array([2.0, 2**-14, 2**-14]), np.array([-1.0, 0.0, 0.0]))  # nearly opposite: 1 + u.v cancelled to 1e-9
@example(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]))  # exactly opposite
def test_from_two_vectors(u, v):
    if np.linalg.norm(u) < 1e-3 or np.linalg.norm(v) < 1e-3:
        return
    q = quat.from_two_vectors(u, v)
    np.testing.assert_allclose(quat.rotate(q, u / np.linalg.norm(u)), v / np.linalg.norm(v), atol=1e-7)


def test_from_two_vectors_opposite():
    q = quat.from_two_vectors([0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
    np.testing.assert_allclose(quat.rotate(q, [0.0, 0.0, 1.0]), [0.0, 0.0, -1.0], atol=1e-12)


def test_broadcasting_over_leading_dims():
    q = quat.from_rotvec(np.random.default_rng(0).normal(size=(5, 16, 3)))
    v = np.array([1.0, 2.0, 3.0])
    assert quat.mul(q, quat.IDENTITY).shape == (5, 16, 4)
    assert quat.rotate(q, v).shape == (5, 16, 3)
    assert quat.slerp(q[0], q[1], np.linspace(0, 1, 16)).shape == (16, 4)
    assert quat.angle_between(q, q[0]).shape == (5, 16)


# ---- hand model --------------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(joint_angles(), unit_quats())
def test_joint_angle_round_trip(angles, palm):
    g, _, _ = kin.forward(angles, palm)
    rel = kin.relative_quats(g)
    np.testing.assert_allclose(kin.joint_angles_from_relative(rel), angles, atol=1e-6)
    assert same_rotation(rel[0], palm)
    np.testing.assert_allclose(kin.global_from_relative(rel), g, atol=1e-12)


def test_round_trip_vectorised():
    rng = np.random.default_rng(1)
    a = rng.uniform(kin.LIMITS[:, 0], kin.LIMITS[:, 1], (7, 3, kin.N_JOINTS))
    palm = quat.from_rotvec(rng.normal(size=(7, 3, 3)))
    g, pos, tips = kin.forward(a, palm)
    assert g.shape == (7, 3, 16, 4) and pos.shape == (7, 3, 16, 3) and tips.shape == (7, 3, 5, 3)
    np.testing.assert_allclose(kin.joint_angles_from_relative(kin.relative_quats(g)), a, atol=1e-9)


def test_open_hand_relative_quats_are_identity():
    g, pos, tips = kin.forward(np.zeros(kin.N_JOINTS), quat.IDENTITY)
    rel = quat.positive(kin.relative_quats(g))
    thumb_base = FINGER_SEGMENTS["thumb"][0]
    for s in range(N_SEGMENTS):
        expected = kin.REST[s] if s == thumb_base else quat.IDENTITY
        np.testing.assert_allclose(rel[s], quat.positive(expected), atol=1e-12)
    assert not same_rotation(kin.REST[thumb_base], quat.IDENTITY, tol=1e-3)


def test_open_hand_fingertips_ahead_of_the_palm():
    _, pos, tips = kin.forward(np.zeros(kin.N_JOINTS), quat.IDENTITY)
    mcp = pos[[FINGER_SEGMENTS[f][0] for f in ("index", "middle", "ring", "pinky")]]
    assert np.all(tips[1:, 0] > mcp[:, 0] + 0.05)  # > 5 cm beyond the knuckles, along palm x
    np.testing.assert_allclose(tips[1:, 2], 0.0, atol=1e-12)  # flat in the palm plane
    assert tips[2, 0] == max(tips[1:, 0])  # the middle finger is the longest
    assert tips[0, 1] > tips[1, 1]  # the thumb is on the +y side of the index


def test_fist_brings_fingertips_toward_the_palm():
    open_a = np.zeros(kin.N_JOINTS)
    fist = open_a.copy()
    for f in ("index", "middle", "ring", "pinky"):
        fist[kin.JOINTS.index(f"{f}_mcp_flex")] = np.radians(85)
        fist[kin.JOINTS.index(f"{f}_pip")] = np.radians(100)
    fist = kin.interpolate_dip(fist)
    _, _, t_open = kin.forward(open_a, quat.IDENTITY)
    _, _, t_fist = kin.forward(fist, quat.IDENTITY)
    palm_centre = np.array([0.04, 0.0, 0.0])
    d_open = np.linalg.norm(t_open[1:] - palm_centre, axis=1)
    d_fist = np.linalg.norm(t_fist[1:] - palm_centre, axis=1)
    assert np.all(d_fist < 0.5 * d_open)
    assert np.all(t_fist[1:, 2] < 0)  # curled to the palmar side


def test_flexion_is_palmar_and_abduction_radial():
    a = np.zeros(kin.N_JOINTS)
    _, _, t0 = kin.forward(a, quat.IDENTITY)
    a[kin.JOINTS.index("index_mcp_flex")] = np.radians(30)
    _, _, t1 = kin.forward(a, quat.IDENTITY)
    assert t1[1, 2] < t0[1, 2] - 0.02
    a[:] = 0
    a[kin.JOINTS.index("index_mcp_abd")] = np.radians(15)
    _, _, t2 = kin.forward(a, quat.IDENTITY)
    assert t2[1, 1] > t0[1, 1] + 0.01
    assert t2[1, 2] == pytest.approx(t0[1, 2], abs=1e-12)


def test_palm_rotation_rotates_everything():
    rng = np.random.default_rng(2)
    a = rng.uniform(kin.LIMITS[:, 0], kin.LIMITS[:, 1])
    palm = quat.from_rotvec([0.3, -1.0, 0.5])
    _, pos0, tips0 = kin.forward(a, quat.IDENTITY)
    _, pos1, tips1 = kin.forward(a, palm)
    np.testing.assert_allclose(pos1, quat.rotate(palm, pos0), atol=1e-12)
    np.testing.assert_allclose(tips1, quat.rotate(palm, tips0), atol=1e-12)


def test_segment_lengths_are_respected_and_scale():
    rng = np.random.default_rng(3)
    a = rng.uniform(kin.LIMITS[:, 0], kin.LIMITS[:, 1])
    size = kin.HandSize(scale=1.1)
    _, pos, tips = kin.forward(a, quat.IDENTITY, size)
    lengths = size.lengths()
    seg = FINGER_SEGMENTS["ring"]
    assert np.linalg.norm(pos[seg[1]] - pos[seg[0]]) == pytest.approx(lengths[seg[0]], rel=1e-12)
    assert np.linalg.norm(tips[3] - pos[seg[2]]) == pytest.approx(lengths[seg[2]], rel=1e-12)
    _, pos_1, _ = kin.forward(a, quat.IDENTITY)
    np.testing.assert_allclose(pos, 1.1 * pos_1, atol=1e-12)
    # a 190 mm hand: the middle fingertip lies 15-19 cm from the wrist when straight
    _, _, t_open = kin.forward(np.zeros(kin.N_JOINTS), quat.IDENTITY)
    assert 0.15 < np.linalg.norm(t_open[2]) < 0.19


def test_interpolate_dip_eq_3_3():
    a = np.zeros((2, kin.N_JOINTS))
    a[0, list(kin.PIP)] = np.radians([115, 50, 0, 10])
    a[1, list(kin.PIP)] = np.radians([-5, -1, 20, 115])
    a[:, list(kin.DIP)] = 9.0  # overwritten
    out = kin.interpolate_dip(a)
    np.testing.assert_allclose(np.degrees(out[0, list(kin.DIP)]), [65, 50 * 65 / 115, 0, 10 * 65 / 115])
    np.testing.assert_allclose(np.degrees(out[1, list(kin.DIP)]), [0, 0, 20 * 65 / 115, 65])
    others = [i for i in range(kin.N_JOINTS) if i not in kin.DIP]
    np.testing.assert_array_equal(out[:, others], a[:, others])
    assert a[0, kin.DIP[0]] == 9.0  # input untouched


def test_limits_and_clip():
    assert kin.LIMITS.shape == (kin.N_JOINTS, 2) and len(set(kin.JOINTS)) == 20
    assert np.all(kin.LIMITS[:, 0] < kin.LIMITS[:, 1])
    assert np.all(np.abs(kin.LIMITS) < np.radians(120))
    big = np.full(kin.N_JOINTS, 10.0)
    np.testing.assert_array_equal(kin.clip(big), kin.LIMITS[:, 1])
    np.testing.assert_array_equal(kin.clip(-big), kin.LIMITS[:, 0])
    # eq. 3.3 keeps the DIP inside its range over the whole PIP range
    dip_of_max_pip = kin.DIP_PER_PIP * kin.LIMITS[list(kin.PIP), 1]
    assert np.all(dip_of_max_pip <= kin.LIMITS[list(kin.DIP), 1])


def test_dorsal_mounts_on_the_back_of_each_segment():
    m = kin.dorsal_mounts()
    assert m.shape == (N_SEGMENTS, 3)
    assert np.all(m[:, 2] > 0) and np.all(m[:, 0] > 0)
