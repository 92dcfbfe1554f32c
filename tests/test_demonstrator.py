"""Scripted demonstrators: they solve the tasks, vary between demos, and drive the synthetic glove."""

import numpy as np
import pytest

import envs
from recorder import GloverecError, quat
from recorder.demonstrator import DemoMotion, make_demonstrator
from recorder.demonstrator.performer import Performer
from recorder.emulator.glove import SyntheticGlove
from recorder.glove.config import GloveConfig
from recorder.glove.glove import make_glove
from recorder.hand.gestures import GESTURES
from recorder.retarget import Retargeter
from recorder.rig.rollout import run_episode


@pytest.mark.parametrize("robot", ["glovehand", "shadow"])
@pytest.mark.parametrize("task", ["pose", "grasp"])
def test_demonstrator_solves_the_task(task, robot):
    env = envs.make(task, robot)
    r = Retargeter(robot)
    results = [run_episode(env, r, seed) for seed in (0, 1)]
    assert all(x["success"] for x in results), results
    if task == "pose":  # terminates as soon as the pose is held
        assert all(x["steps"] < env.unwrapped.config.episode_s * env.unwrapped.config.control_hz for x in results)


def test_only_a_performer_makes_the_emulated_wearer_perform():
    """The emulated glove performs demonstrations when a Performer wears it (recorder/demonstrator/performer.py);
    opened on its own with that motion, or a performer on a glove with another: one-line errors."""
    with pytest.raises(GloverecError, match="performs demonstrations only for a demonstrator"):
        make_glove(GloveConfig.parse("emulator", motion="demonstrations"))
    with pytest.raises(GloverecError, match="only the emulated glove with motion=demonstrations performs"):
        Performer(GloveConfig.parse("emulator", motion="gestures"))


@pytest.mark.parametrize("task", ["pose", "grasp"])
def test_demonstrations_through_the_synthetic_glove(task):
    env = envs.make(task, "glovehand")
    r = Retargeter("glovehand")
    assert run_episode(env, r, 2, via="glove", latency_s=0.03, noise_deg=0.5)["success"]


def test_demonstrations_vary_and_repeat():
    env = envs.make("grasp", "glovehand")
    env.reset(seed=0)
    demo = make_demonstrator("grasp")
    t = np.linspace(0, 4, 50)
    a, b, c = (demo.plan(env, seed=s).at(t).angles for s in (1, 1, 2))
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > np.radians(2)


def test_a_slow_opening_is_finished_before_the_grasp_closes():
    env = envs.make("grasp")
    env.reset(seed=75)  # its preshape ends after the close would begin (keyframes out of order, before)
    plan = make_demonstrator("grasp").plan(env.unwrapped, seed=75)
    assert np.all(np.diff(plan.times) >= 0)


def test_demo_motion_is_human_like():
    env = envs.make("pose", "glovehand")
    env.reset(seed=0)
    m = make_demonstrator("pose").plan(env, seed=0)
    block = m.next_block(int(3 * m.rate_hz))
    v = np.diff(block.angles, axis=0) * m.rate_hz
    assert np.abs(v).max() < np.radians(400)  # no jumps
    assert np.abs(v[:10]).max() < np.radians(20)  # starts at rest (minimum jerk)
    assert np.abs(block.angles[-1] - env.unwrapped.goal_angles).max() < np.radians(6)
    nxt = m.next_block(5)  # blocks continue one trajectory
    assert nxt.t[0] == pytest.approx(block.t[-1] + 1 / m.rate_hz)


def test_synthetic_glove_takes_a_motion_object():
    env = envs.make("pose", "glovehand")
    env.reset(seed=0)
    motion = make_demonstrator("pose").plan(env, seed=0)
    glove = SyntheticGlove(motion, rate_hz=motion.rate_hz, seed=0)
    block = glove.next_block(100)
    ref = motion.at(np.arange(100) / motion.rate_hz)
    np.testing.assert_allclose(block.angles, ref.angles)
    assert block.raw.shape == (100, 12, 7) and block.pose.shape == (100, 16, 4)
    with pytest.raises(ValueError, match="Hz"):
        SyntheticGlove(DemoMotion([0, 1], [ref.angles[0]] * 2, np.random.default_rng(0), 100.0), rate_hz=200.0)
    with pytest.raises(ValueError, match="unknown task 'juggle'; valid tasks: grasp, keys, pick, pinch, pose, reloc"):
        make_demonstrator("juggle")


def test_a_correction_goes_into_a_hold_and_keeps_what_was_performed():
    """DemoMotion.revise, what a watching demonstrator (HandTurn's) does: a turn of the palm inserted in a hold
    shifts the rest of the plan, leaves the path before it as it was, and is refused inside a move."""
    open_, fist = GESTURES["open"], GESTURES["fist"]
    times, poses = [0.0, 0.5, 1.0, 2.0, 2.5], [open_, fist, fist, fist, open_]  # a hold from 0.5 to 2.0 s

    def motion():
        return DemoMotion(times, poses, np.random.default_rng(3), 100.0, palm_deg=0.0)

    plan, before = motion(), motion().at(np.arange(0, 150) / 100.0)
    with pytest.raises(ValueError, match="inside a move"):
        plan.revise(0.3, 0.4, (0, 0, 0.5))
    assert plan.revise(1.5, 0.4, (0.0, 0.0, 0.5))
    after = plan.at(np.arange(0, 150) / 100.0)
    np.testing.assert_array_equal(after.angles, before.angles)  # up to the correction: unchanged
    np.testing.assert_array_equal(after.palm_quat, before.palm_quat)
    assert plan.duration == pytest.approx(2.9)  # the release 0.4 s later
    turned = quat.mul(quat.conj(motion().at([2.9]).palm_quat[0]), plan.at([3.3]).palm_quat[0])
    assert np.degrees(2 * np.arccos(min(abs(turned[0]), 1.0))) == pytest.approx(np.degrees(0.5), abs=0.1)
    # after the plan's end (a watching demonstrator late under load): a move from where the plan ended
    plan = DemoMotion(times, poses, np.random.default_rng(3), 100.0, palm_deg=0.0, palm_pos=(0.0, 0.0, 0.1))
    assert plan.revise(3.0, 0.5, move=(0.02, 0.0, 0.0)) == 3.0
    np.testing.assert_allclose(plan.palm_positions[-1], (0.02, 0.0, 0.1))
    assert plan.duration == pytest.approx(3.5)
