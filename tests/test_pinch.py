"""HandPinch (envs/tasks/hand_pinch.py): a precision pick between the thumb and a named finger. Its scene and names
on every robot and its success rule (the named finger and the thumb, nothing else); what every dexterous task owes
(trivial policies fail, `gloverec record` records it) is in test_dexterous.py."""

import pytest

from envs.tasks.hand_pinch import HandPinchEnv
from recorder.demonstrator import make_demonstrator
from recorder.retarget.retargeter import Retargeter

ROBOTS = ("glovehand", "shadow", "leap")


@pytest.mark.parametrize("robot", ROBOTS)
def test_each_episode_names_its_object_and_finger_in_the_task_s_own_names(robot):
    env = HandPinchEnv(robot)
    assert set(env.fingers) <= {"index", "middle"} and env.fingers
    names = env.environment_state_names
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        assert env.instruction() in env.instructions()
        assert f"thumb and {env.finger} finger" in env.instruction()
        state = dict(zip(names, obs["observation.environment_state"]))
        assert state[f"pinch.finger.is_{env.finger}"] == 1 and sum(v for k, v in state.items() if ".finger." in k) == 1
        assert state[f"pinch.object.is_{env.object_shape}"] == 1
        assert 0.014 <= 2 * env.object_half[0] <= 0.026  # a marble 8-12 mm in radius, a coin, a 16-20 mm cube


def _run(env, seed, policy) -> tuple[bool, HandPinchEnv]:
    obs, _ = env.reset(seed=seed)
    done = False
    while not done:
        obs, _, term, trunc, info = env.step(policy(env.t))
        done = term or trunc
    return info["is_success"], env


def test_a_pinch_counts_only_with_the_named_finger_and_the_thumb():
    env = HandPinchEnv("glovehand")
    demo = make_demonstrator("pinch")
    rt = Retargeter("glovehand", "joint")
    for seed in range(20):
        env.reset(seed=seed)
        motion = demo.plan(env, seed)
        rt.reset()

        def policy(t, motion=motion):
            block = motion.at(t)
            return rt(block.angles[0], block.palm_quat[0])[0]

        ok, env = _run(env, seed, policy)
        if ok:
            break
    assert ok, "the demonstrator pinched none of 20 scenes"
    assert env.pinched()
    named = env.finger
    env.finger = "middle" if named == "index" else "index"  # the same hold, asked of the other finger
    assert not env.pinched()
    env.finger = named
    env.object_start[2] += env.config.lift_m  # the same hold, not lifted far enough
    assert not env.pinched()
