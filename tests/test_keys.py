"""HandKeys (envs/tasks/hand_keys.py): a row of sprung keys under the fingertips, lit one at a time. The row on every
robot, the lit key in the scene and in environment_state, and the success rule on presses made by the robot's own
fingers: the lit key by its finger counts, any other key fails the episode."""

import mujoco
import numpy as np
import pytest

from envs.tasks.hand_keys import LIT, UNLIT, HandKeysEnv, press_angles, rest_angles
from recorder.retarget.retargeter import Retargeter


@pytest.mark.parametrize("robot, fingers", [("glovehand", 4), ("shadow", 4), ("leap", 3)])
def test_a_key_under_each_finger_that_can_press_one(robot, fingers):
    env = HandKeysEnv(robot)
    assert len(env.key_fingers) == fingers and "thumb" not in env.key_fingers
    for seed in range(6):
        obs, _ = env.reset(seed=seed)
        seq = env.sequence
        assert 3 <= len(seq) <= 5 and set(seq) <= set(env.key_fingers)
        assert all(a != b for a, b in zip(seq, seq[1:]))  # never the same key twice in a row
        state = dict(zip(env.environment_state_names, obs["observation.environment_state"]))
        assert state["keys.remaining"] == pytest.approx(len(seq) / 5)
        assert not any(state[f"keys.lit.{f}"] for f in env.key_fingers)  # nothing lit before first_key_s


def _hold(env, action, seconds, ramp_s=0.0):
    """Hold ``action`` for ``seconds``, reaching it in ``ramp_s`` from the last action, as a hand moves."""
    info, start = {}, np.zeros(env.action_space.shape)
    start[: env.model.nu] = env.data.ctrl  # the targets now (HandKeys' action has no palm turn)
    steps, ramp = int(round(seconds * env.config.control_hz)), max(int(round(ramp_s * env.config.control_hz)), 1)
    for k in range(steps):
        obs, _, terminated, _, info = env.step(start + (action - start) * min((k + 1) / ramp, 1.0))
        if terminated:
            break
    return obs, info


def _press(env, finger):
    return Retargeter.for_env(env)(press_angles(env.robot.config.name, finger, 0.014))[0]


@pytest.mark.parametrize("robot", ["glovehand", "leap"])
def test_the_lit_key_pressed_by_its_finger_counts_and_another_key_fails(robot):
    env = HandKeysEnv(robot)
    rest = Retargeter.for_env(env)(rest_angles())[0]
    env.reset(seed=3)
    obs, _ = _hold(env, rest, env.config.first_key_s + 0.1, ramp_s=0.5)
    first = env.lit()
    state = dict(zip(env.environment_state_names, obs["observation.environment_state"]))
    assert state[f"keys.lit.{first}"] == 1 and sum(state[f"keys.lit.{f}"] for f in env.key_fingers) == 1
    key_geom = env._keys[first][1]
    assert np.allclose(env.model.geom_rgba[key_geom], LIT)  # the cameras see which key
    assert env.guidance() == f"press with your {first}: key 1 of {len(env.sequence)}"  # the live view's line

    obs, info = _hold(env, _press(env, first), 0.5)  # the lit key, by its own finger
    state = dict(zip(env.environment_state_names, obs["observation.environment_state"]))
    assert env.done == 1 and info["failed"] is None, info
    assert state[f"keys.down.{first}"] >= env.config.threshold
    assert np.allclose(env.model.geom_rgba[key_geom], UNLIT) and env.lit() == env.sequence[1]

    _hold(env, rest, 0.4)
    wrong = next(f for f in env.key_fingers if f != env.lit())
    _, info = _hold(env, _press(env, wrong), 0.5)
    assert info["failed"] == f"{wrong} key pressed" and not info["is_success"]


def test_pressing_every_lit_key_in_order_succeeds_and_a_key_pressed_too_early_fails():
    env = HandKeysEnv("glovehand")
    rest = Retargeter.for_env(env)(rest_angles())[0]
    env.reset(seed=5)
    _hold(env, rest, env.config.first_key_s + 0.1, ramp_s=0.5)
    for k, finger in enumerate(env.sequence):
        _, info = _hold(env, _press(env, finger), 0.45)
        assert env.done == k + 1, info
        _, info = _hold(env, rest, 0.4)
    assert info["is_success"] and info["pressed"] == len(env.sequence)

    env.reset(seed=5)
    _, info = _hold(env, _press(env, env.sequence[0]), 0.5)  # the right key, before it lights
    assert info["failed"] and not info["is_success"]


def test_a_key_struck_by_a_neighbouring_finger_does_not_count():
    env = HandKeysEnv("glovehand")
    env.reset(seed=1)
    env.t = env.config.first_key_s
    lit = env.lit()
    jnt = env._keys[lit][0]  # the lit key pushed down with no finger near it: not its finger's press
    env.data.qpos[env.model.jnt_qposadr[jnt]] = env.config.travel_m / env._key_under[lit]
    mujoco.mj_forward(env.model, env.data)
    success, terminated, _ = env._evaluate()
    assert not success and terminated and env.failed == f"{lit} key pressed by another finger"


def test_the_live_view_s_copy_of_the_scene_lights_the_lit_key():
    from recorder.view.scene import Stage, frame_of

    env = HandKeysEnv("glovehand")
    rest = Retargeter.for_env(env)(rest_angles())[0]
    env.reset(seed=3)
    _hold(env, rest, env.config.first_key_s + 0.1, ramp_s=0.5)
    stage = Stage("keys", "glovehand")
    stage.apply(frame_of(env, status={"seed": 3}))
    for f in env.key_fingers:
        assert np.allclose(stage.model.geom_rgba[stage.env._keys[f][1]], LIT if f == env.lit() else UNLIT)
