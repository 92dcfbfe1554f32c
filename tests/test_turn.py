"""HandTurn (envs/tasks/hand_turn.py): grip a knob, turn it by a drawn angle with the palm, let go. The knob and target
per episode, the success rule on constructed states (held at the mark, released: success; short of the mark or
not yet held long enough: not), and the palm's turn about the knob's axis."""

import mujoco
import numpy as np
import pytest

from envs.tasks.hand_turn import HandTurnEnv
from recorder.demonstrator import make_demonstrator
from recorder.retarget.retargeter import Retargeter


@pytest.mark.parametrize("robot", ["glovehand", "shadow", "leap"])
def test_each_episode_draws_a_knob_and_a_target_either_way(robot):
    env = HandTurnEnv(robot)
    assert env.config.max_base_angle_deg >= 100  # a 90° turn is not clipped
    signs = set()
    for seed in range(8):
        obs, _ = env.reset(seed=seed)
        state = dict(zip(env.environment_state_names, obs["observation.environment_state"]))
        assert 0.020 <= state["turn.knob.radius"] <= 0.035
        assert 30 <= abs(np.degrees(state["turn.target.angle"])) <= 90
        assert state["turn.knob.angle"] == 0
        signs.add(np.sign(state["turn.target.angle"]))
        assert env.instruction() == f"turn the knob {'left' if env.target > 0 else 'right'} to the mark"
    assert signs == {-1.0, 1.0}


def _knob_at(env, angle):
    env.data.qpos[env._knob_qpos] = angle
    mujoco.mj_forward(env.model, env.data)


def _evaluate_for(env, seconds):
    out = []
    for _ in range(int(round(seconds * env.config.control_hz))):
        out.append(env._evaluate()[0])
    return out


def test_the_knob_held_at_the_mark_and_released_succeeds_short_of_it_fails():
    env = HandTurnEnv("glovehand")
    env.reset(seed=2)  # the hand hovers above the knob: nothing touches it
    tol = np.radians(env.config.tolerance_deg)
    _knob_at(env, env.target - np.sign(env.target) * (tol + np.radians(2)))  # left short of the mark
    assert not any(_evaluate_for(env, 2.0))
    env.t = env.schedule["grip"]  # the live view's line, once the hand is down
    way = "left" if env.target > 0 else "right"
    assert env.guidance() == f"turn {env.config.tolerance_deg + 2:.0f}° {way}"
    _knob_at(env, env.target + np.sign(env.target) * (tol + np.radians(2)))  # past it: back, against the instruction
    back = "right" if env.target > 0 else "left"
    assert env.guidance() == f"past the mark: turn {env.config.tolerance_deg + 2:.0f}° back {back}"
    _knob_at(env, env.target - np.sign(env.target) * 0.5 * tol)  # within the tolerance: after hold_s, not before
    held = _evaluate_for(env, env.config.hold_s + 0.1)
    hold_steps = int(round(env.config.hold_s * env.config.control_hz))
    assert not any(held[: hold_steps - 1]) and held[-1]
    _knob_at(env, -env.target)  # turned the other way
    assert not any(_evaluate_for(env, 1.0))


def _gripped(seed=4):
    """A glovehand closed on the knob as the demonstrator's grip closes it, before any turn: (env, the action)."""
    env = HandTurnEnv("glovehand")
    env.reset(seed=seed)
    motion = make_demonstrator("turn").plan(env, seed=seed)
    grip = Retargeter("glovehand", "joint")(motion.at([env.schedule["grip"] + 1.2]).angles[0])[0]
    for _ in range(int((env.schedule["grip"] + 1.2) * env.config.control_hz)):
        env.step(grip)
    assert env.touching(), "the grip does not reach the knob"
    return env, grip


def test_the_knob_still_gripped_at_the_mark_does_not_count():
    env, _ = _gripped()
    env.target = env.knob_angle()  # the mark where the knob is, still held
    assert not any(_evaluate_for(env, 1.0))


def test_the_palm_s_rotation_turns_the_gripped_knob():
    env, grip = _gripped()
    start = env.knob_angle()
    turned = grip.copy()
    for k in range(30):  # the palm turns 40° about the vertical in 1 s
        turned[-3:] = [0.0, 0.0, np.radians(40) * (k + 1) / 30]
        env.step(turned)
    assert np.degrees(env.knob_angle() - start) > 25


def test_the_inspect_plot_shows_the_palm_s_turn_and_the_knob_against_its_target():
    from recorder import quat
    from recorder.record.inspect import _extra_panels

    a_names = ["thumb_cmc_flex", "base.rx", "base.ry", "base.rz"]
    s_names = ["thumb_cmc_flex.pos", "palm.qw", "palm.qx", "palm.qy", "palm.qz"]
    turns = np.radians([[0, 0, 10], [0, 0, 40]])
    action = np.hstack([np.zeros((2, 1)), turns])
    state = np.hstack([np.zeros((2, 1)), [quat.from_rotvec(r) for r in turns]])
    env = np.array([[0.1, 0.0, 0.5], [0.1, 0.6, 0.5]])
    features = {"observation.environment_state": {"names": ["turn.knob.x", "turn.knob.angle", "turn.target.angle"]}}
    panels = _extra_panels(a_names, s_names, action, state, {"observation.environment_state": env}, features)
    titles = [t for t, _ in panels]
    assert titles == ["palm rotation about x", "palm rotation about y", "palm rotation about z", "the task's angles"]
    (_, target), (_, held) = panels[2][1]
    np.testing.assert_allclose(target, [10, 40])
    np.testing.assert_allclose(held, [10, 40], atol=1e-9)
    assert [label for label, _ in panels[3][1]] == ["turn.knob.angle", "turn.target.angle"]
    np.testing.assert_allclose(panels[3][1][0][1], np.degrees([0.0, 0.6]))
