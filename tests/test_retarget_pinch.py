"""Retargeting real wearers: fingertip targets scaled by the wearer's hand, the pinch-preserving mode (pinches close
on every robot, fingers never pass through each other), and the finger-finger geometry it rests on."""

import dataclasses

import mujoco
import numpy as np
import pytest

from envs.robots import load_robot
from envs.robots.config import load_robot_config
from recorder.config import ConfigError
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import REFERENCE_BREADTH_MM, HandSize
from recorder.hand.motion import Motion
from recorder.hand.pinch import pinch_motion, retarget_motions
from recorder.hand.skeleton import FINGER_SEGMENTS
from recorder.paths import config_file
from recorder.retarget import Retargeter
from recorder.retarget.contacts import FingerGeoms

ROBOTS = ("glovehand", "shadow", "leap")
PENETRATION_M = 0.002  # the bound the benchmark holds the pinch mode to
CLOSED_M = 0.005  # a pinch whose pads are this close is closed
RATE = 30.0
BENCH_SIZES = (
    HandSize(hand_length_mm=170.0, hand_breadth_mm=80.0),
    HandSize(),
    HandSize(hand_length_mm=210.0, hand_breadth_mm=90.0),
)


def _hand(length: float, breadth: float | None = None) -> HandSize:
    return HandSize(hand_length_mm=length, hand_breadth_mm=breadth or length * REFERENCE_BREADTH_MM / 190.0)


def test_wearers_of_any_size_ask_the_robot_for_the_same_gesture():
    """The same gesture by a small, a reference and a large hand of the same proportions: the wearers' own
    fingertips differ by their size, the robot's targets do not (each reaches the robot's whole range)."""
    angles = GESTURES["point"]
    rs = {L: Retargeter("shadow", base_rotation=False, hand_size=_hand(L)) for L in (170.0, 190.0, 210.0)}
    raw = {L: r.human.tips(angles) for L, r in rs.items()}
    np.testing.assert_allclose(raw[210.0], raw[190.0] * 210.0 / 190.0, atol=1e-9)
    np.testing.assert_allclose(raw[170.0], raw[190.0] * 170.0 / 190.0, atol=1e-9)
    for L in (170.0, 210.0):
        np.testing.assert_allclose(rs[L].human_tips(angles), rs[190.0].human_tips(angles), atol=1e-9)


def test_a_longer_finger_moves_its_target_by_the_robots_ratio():
    """A wearer whose index is 20 mm longer, hand straight: the robot's index target moves 20 mm times the
    index's scale along the finger; a broader hand brings its fingertips' spread back to the robot's."""
    straight = np.zeros(20)
    ref = Retargeter("shadow", base_rotation=False)
    bones = HandSize().lengths()[list(FINGER_SEGMENTS["index"])] * 1000.0
    longer = dataclasses.replace(HandSize(), segments_mm=(("index", tuple(bones + [8.0, 6.0, 6.0])),))
    r = Retargeter("shadow", base_rotation=False, hand_size=longer)
    moved = r.human_tips(straight) - ref.human_tips(straight)
    scale, _ = ref.tips.of("index")
    np.testing.assert_allclose(moved[1], [scale * 0.020, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(np.delete(moved, 1, axis=0), 0.0, atol=1e-12)
    broad = Retargeter("shadow", base_rotation=False, hand_size=_hand(190.0, 100.0))
    spread = lambda rr: np.ptp(rr.reference_tips(straight)[1:, 1])  # noqa: E731  (index to pinky, across)
    assert spread(broad) == pytest.approx(spread(ref), rel=1e-7)
    assert np.ptp(broad.human.tips(straight)[1:, 1]) == pytest.approx(spread(ref) * 100.0 / 85.0, rel=1e-7)


def _pinch_frames(finger: str, size: HandSize = HandSize()) -> np.ndarray:
    """Open hand -> thumb tip on ``finger``'s tip, held (the benchmark's pinch without the opening again)."""
    angles, _ = pinch_motion([finger], size, RATE)
    return angles[: int(1.4 * RATE)]


def _pads_and_depth(r: Retargeter, geoms: FingerGeoms, q, k: int) -> tuple[float, float]:
    r.data.qpos[:] = q
    mujoco.mj_kinematics(r.model, r.data)
    return geoms.pad_distance(r.data, k), geoms.deepest(r.data)


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_human_pinch_closes_the_robots_pinch(robot):
    """Thumb on each finger the robot has, by a small and a large wearer: the robot's pads start apart and
    end touching, without passing through each other."""
    for size in (_hand(170.0, 80.0), _hand(210.0, 90.0)):
        r = Retargeter(robot, "pinch", base_rotation=False, hand_size=size)
        geoms = FingerGeoms(r.model, r.robot.tip_site_ids)
        for k, finger in enumerate(r.fingers[1:], start=1):
            r.reset()
            infos = [r(a)[1] for a in _pinch_frames(finger, size)]
            start, _ = _pads_and_depth(r, geoms, infos[0]["qpos"], k)
            end, depth = _pads_and_depth(r, geoms, infos[-1]["qpos"], k)
            assert start > 0.02, (robot, finger, start)
            assert end < CLOSED_M, (robot, finger, size.hand_length_mm, end)
            assert depth <= PENETRATION_M, (robot, finger, depth)


def test_the_joint_map_alone_leaves_shadows_pinches_open():
    """What the pinch mode is for: the joint map, and fingertip IK, leave a gap or overlap on some pinch."""
    worst = {}
    for mode in ("joint", "ik"):
        r = Retargeter("shadow", mode, base_rotation=False)
        geoms = FingerGeoms(r.model, r.robot.tip_site_ids)
        out = []
        for k, finger in enumerate(r.fingers[1:], start=1):
            info = [r(a)[1] for a in _pinch_frames(finger)][-1]
            out.append(abs(_pads_and_depth(r, geoms, info["qpos"], k)[0]))
        worst[mode] = max(out)
    assert worst["joint"] > 2 * CLOSED_M and worst["ik"] > CLOSED_M, worst


@pytest.mark.parametrize("robot", ["shadow", "leap"])
def test_no_pose_penetrates_beyond_the_bound(robot):
    """The benchmark's human motions (gestures, random motion, every pinch; bench/retarget.py) for its three
    wearers through the pinch mode: no two of the robot's fingers overlap by more than 2 mm in any frame;
    fingertip IK on the same frames does."""
    depth = {}
    for mode, sizes in [("pinch", BENCH_SIZES), ("ik", BENCH_SIZES[1:2])]:
        for size in sizes:
            r = Retargeter(robot, mode, base_rotation=False, hand_size=size)
            geoms = FingerGeoms(r.model, r.robot.tip_site_ids)
            d = []
            for angles, _ in retarget_motions(r.fingers[1:], size, RATE).values():
                r.reset()
                for a in angles:
                    r.data.qpos[:] = r(a)[1]["qpos"]
                    mujoco.mj_kinematics(r.model, r.data)
                    d.append(geoms.deepest(r.data))
            depth[mode, size.hand_length_mm] = max(d)
    worst = max(v for (mode, _), v in depth.items() if mode == "pinch")
    assert worst <= PENETRATION_M < depth["ik", 190.0], depth


def test_pinch_mode_is_within_limits_smooth_and_accurate_where_reachable():
    r = Retargeter("shadow", "pinch", base_rotation=False)
    block = Motion("gestures", seed=1, rate_hz=30.0).next_block(90)
    out = [r(a) for a in block.angles]
    actions = np.array([a for a, _ in out])
    lo, hi = r.map.lo, r.map.hi
    assert np.all(actions >= lo - 1e-6) and np.all(actions <= hi + 1e-6)
    steps = np.abs(np.diff(actions, axis=0)).max(axis=1)
    human = np.abs(np.diff(block.angles, axis=0)).max(axis=1)
    assert steps.max() < 3 * human.max() + 0.05
    assert np.mean([i["tip_error_mean"] for _, i in out]) < 0.008
    g = Retargeter("glovehand", "pinch", base_rotation=False)  # the hand model itself: its own fingertips
    g.reset()
    assert max(g(a)[1]["tip_error"].max() for a in block.angles[:30]) < 0.005  # the smoothing term lags a little


@pytest.mark.parametrize("robot", ["shadow", "leap"])
def test_contact_distances_and_gradients(robot):
    """FingerGeoms: pairs only between different fingers, none overlapping at rest, and distance gradients that
    match finite differences (the pinch solver's Jacobians)."""
    rb = load_robot(robot)
    m = rb.model
    g = FingerGeoms(m, rb.tip_site_ids)
    assert len(g.pairs) and np.all(g.finger[g.pairs[:, 0]] != g.finger[g.pairs[:, 1]])
    assert np.all(g.pads >= 0)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    assert g.deepest(d) == 0.0
    rng = np.random.default_rng(0)
    lo, hi = m.jnt_range.T
    for _ in range(3):
        q = rng.uniform(lo, hi)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        for g1, g2 in [g.pads[[0, 1]], g.pairs[rng.integers(len(g.pairs))]]:
            dist = g.distance(d, g1, g2, 1.0)
            _, grad = g.gradient(d, g1, g2)
            num = np.zeros(m.nv)
            for i in range(m.nv):
                d.qpos[:] = q
                d.qpos[i] += 1e-6
                mujoco.mj_kinematics(m, d)
                num[i] = (g.distance(d, g1, g2, 1.0) - dist) / 1e-6
            d.qpos[:] = q
            mujoco.mj_kinematics(m, d)
            np.testing.assert_allclose(grad, num, atol=2e-4)


def test_glovehand_fingers_do_not_collide():
    """The hand model has no volumes: no finger pairs, so its pinch mode never pushes fingers apart."""
    rb = load_robot("glovehand")
    assert len(FingerGeoms(rb.model, rb.tip_site_ids).pairs) == 0


def test_fingertip_config_errors_are_one_line(tmp_path):
    text = config_file("robots", "leap").read_text()
    for old, new, needle in [
        ("  index: {body: if_ds", "  pinky: {body: if_ds", "must map the thumb and the fingers"),
        ("thumb: {body: th_ds", "thumb: {body: th_nothing", "no body named 'th_nothing'"),
        ("thumb: {body: th_ds, pos:", "thumb: {body: th_ds, place:", "leap.yaml: fingertips.thumb"),
    ]:
        path = tmp_path / "leap.yaml"
        path.write_text(text.replace(old, new))
        with pytest.raises(ConfigError) as exc:
            from envs.robots import Robot

            Robot(load_robot_config(path))
        assert needle in str(exc.value) and "\n" not in str(exc.value), str(exc.value)
