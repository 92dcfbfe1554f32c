"""HandPinch (envs/tasks/hand_pinch.py): a precision pick between the thumb and a named finger. Its scene and names
on every robot, its success rule (the named finger and the thumb, nothing else), trivial policies that must fail,
and two episodes recorded by `gloverec record` with the emulated glove."""

import json

import numpy as np
import pytest

import envs
from conftest import gloverec
from envs.tasks.hand_pinch import HandPinchEnv
from recorder.demonstrator import make_demonstrator
from recorder.hand.gestures import GESTURES
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
    others = [
        n for t in envs.task_names() if t != "pinch" for n in envs.make(t, robot).unwrapped.environment_state_names
    ]
    assert all(n.startswith("pinch.") for n in names)
    assert not any(a.startswith(b) or b.startswith(a) for a in names for b in others)


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


@pytest.mark.parametrize("name", ["zero", "open hand", "fist"])
def test_trivial_policies_do_not_pinch(name):
    env = HandPinchEnv("glovehand")
    rt = Retargeter("glovehand", "joint")
    action = {
        "zero": np.zeros(env.action_space.shape, np.float32),
        "open hand": rt(GESTURES["open"])[0],
        "fist": rt(GESTURES["fist"])[0],
    }[name]
    assert not any(_run(env, seed, lambda t: action)[0] for seed in range(3))


@pytest.mark.process
def test_gloverec_records_pinch_episodes_with_the_emulated_glove(tmp_path):
    root = tmp_path / "ds"
    r = gloverec("record", "--task", "pinch", "--episodes", "2", "--root", str(root), "--repo-id", "test/pinch",
                 "--json", timeout=240)  # fmt: skip
    assert r.returncode == 0, r.stderr
    info = json.loads((root / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 2
    assert info["features"]["observation.environment_state"]["names"] == list(HandPinchEnv.environment_state_names)
    import pandas as pd

    tasks = list(pd.read_parquet(root / "meta" / "tasks.parquet").index)
    assert tasks and all(t.startswith("pick up the ") and " between your thumb and " in t for t in tasks)
