"""Retargeting: config validation, known poses, fingertip IK, palm rotation, speed-relevant pieces."""

import numpy as np
import pytest
import yaml

from envs.robots import JointMap, load_robot
from envs.robots.config import retarget_section
from recorder import quat
from recorder.config import ConfigError
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS
from recorder.hand.motion import Motion
from recorder.paths import config_file
from recorder.retarget import Retargeter
from recorder.retarget.fit import mean_tip_error, sample_poses


def _raw(robot):
    """The robot's ``retarget`` section as written in its yaml."""
    return yaml.safe_load(config_file("robots", robot).read_text())["retarget"]


def _load(robot, raw):
    return JointMap.compile(retarget_section(raw, "test.yaml"), load_robot(robot).model, "test.yaml")


def _one_line_error(robot, raw, *fragments):
    with pytest.raises(ConfigError) as exc:
        _load(robot, raw)
    msg = str(exc.value)
    assert "\n" not in msg, msg
    for f in fragments:
        assert f in msg, msg


def test_configs_load():
    for robot in ("glovehand", "shadow"):
        cfg = _load(robot, _raw(robot))
        assert cfg.A.shape == (20, 20)


def test_rejects_unknown_actuator():
    raw = _raw("glovehand")
    raw["joints"]["index_knuckle"] = {"source": "index_pip"}
    _one_line_error("glovehand", raw, "unknown actuator", "index_knuckle", "thumb_cmc_flex")


def test_rejects_unknown_human_joint():
    raw = _raw("shadow")
    raw["joints"]["robot0:A_FFJ2"] = {"source": "index_mcp"}
    _one_line_error("shadow", raw, "unknown human joint", "index_mcp", "index_mcp_flex")


def test_rejects_out_of_range_limits():
    raw = _raw("shadow")
    raw["joints"]["robot0:A_FFJ2"]["limits"] = [-0.5, 1.0]  # FFJ2's range starts at 0
    _one_line_error("shadow", raw, "out of the actuator's ctrl range", "robot0:A_FFJ2")
    raw["joints"]["robot0:A_FFJ2"]["limits"] = [0.2, 0.1]
    _one_line_error("shadow", raw, "must be below")


def test_rejects_missing_actuator_and_unknown_keys():
    raw = _raw("glovehand")
    del raw["joints"]["pinky_dip"]
    _one_line_error("glovehand", raw, "missing actuator", "pinky_dip")
    raw = _raw("glovehand")
    raw["joints"]["pinky_dip"]["gain"] = 2
    _one_line_error("glovehand", raw, "unknown key", "retarget.joints.pinky_dip.gain")
    raw = _raw("glovehand")
    raw["smoothing"] = 0.5
    _one_line_error("glovehand", raw, "unknown key", "smoothing")
    raw = _raw("glovehand")
    raw["joints"]["pinky_dip"]["scale"] = "big"
    _one_line_error("glovehand", raw, "test.yaml: retarget.joints.pinky_dip.scale", "valid number")


def test_limits_clip_the_targets():
    raw = _raw("glovehand")
    raw["joints"]["index_pip"]["limits"] = [0.0, 0.5]
    r = Retargeter("glovehand")
    r.map = _load("glovehand", raw)
    assert r.joint_map(GESTURES["fist"])[JOINTS.index("index_pip")] == pytest.approx(0.5)


@pytest.mark.parametrize("gesture", list(GESTURES))
def test_glovehand_is_the_identity(gesture):
    r = Retargeter("glovehand", base_rotation=False)
    action, info = r(GESTURES[gesture], quat.IDENTITY)
    np.testing.assert_allclose(action, GESTURES[gesture], atol=1e-6)
    assert info["tip_error"].max() < 1e-5


def test_shadow_open_and_fist():
    r = Retargeter("shadow", base_rotation=False)
    names = r.robot.actuator_names
    open_, _ = r(GESTURES["open"])
    fist, _ = r(GESTURES["fist"])
    get = lambda a, j: a[names.index(f"robot0:A_{j}")]  # noqa: E731
    for f in "FMRL":
        assert get(open_, f"{f}FJ2") < 0.2 and get(open_, f"{f}FJ1") < 0.2  # straight fingers
        assert get(fist, f"{f}FJ2") > 1.0 and get(fist, f"{f}FJ1") > 0.6  # curled
    assert get(fist, "THJ3") > get(open_, "THJ3") + 0.3  # thumb brought in
    assert get(open_, "WRJ1") == 0 and get(fist, "WRJ0") == 0  # wrist held straight
    # the fist puts the robot's fingertips near the scaled human ones
    assert r(GESTURES["fist"])[1]["tip_error"][1:].max() < 0.03


def test_ik_reduces_the_fingertip_error():
    poses = sample_poses(30, seed=3)
    joint = mean_tip_error(Retargeter("shadow", "joint", base_rotation=False), poses)
    ik = mean_tip_error(Retargeter("shadow", "ik", base_rotation=False), poses)
    assert ik < 0.85 * joint


def test_ik_is_smooth_on_smooth_motion():
    r = Retargeter("shadow", "ik", base_rotation=False)
    block = Motion("gestures", seed=1, rate_hz=30.0).next_block(90)
    actions = np.array([r(a)[0] for a in block.angles])
    steps = np.abs(np.diff(actions, axis=0)).max(axis=1)
    human = np.abs(np.diff(block.angles, axis=0)).max(axis=1)
    assert steps.max() < 3 * human.max() + 0.05  # no jumps beyond the motion's own speed


def test_palm_rotation():
    r = Retargeter("glovehand")
    ref = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), 1.0)  # any heading
    a0, _ = r(GESTURES["open"], ref)
    np.testing.assert_allclose(a0[-3:], 0.0, atol=1e-7)
    tilted = quat.mul(ref, quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), 0.3))
    a1, _ = r(GESTURES["open"], tilted)
    np.testing.assert_allclose(a1[-3:], [0.3, 0.0, 0.0], atol=1e-6)
    r.reset()
    a2, _ = r(GESTURES["open"], tilted)
    np.testing.assert_allclose(a2[-3:], 0.0, atol=1e-7)
    assert a2.shape == (23,) and a2.dtype == np.float32


def test_bad_mode_and_shape():
    with pytest.raises(ValueError, match="valid modes"):
        Retargeter("glovehand", "magic")
    with pytest.raises(ValueError, match="20 joint angles"):
        Retargeter("glovehand")(np.zeros(16))
