"""Demonstrations as a person gives them (issue 41): a wearer who watches the robot hand close and corrects it, and
demonstrators that act from the state they find (a pushed object re-gripped, a take carried on from mid-way)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import envs
from conftest import cli
from recorder.demonstrator import make_demonstrator
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.relocate import RelocateMotion
from recorder.demonstrator.replan import in_hand
from recorder.record.sidecar import read_sidecar
from recorder.retarget import Retargeter
from recorder.rig.rollout import pushed, run_episode


def _run(task, seed, robot="glovehand", via="direct", watches=True, push=None, kind="scripted", bias=None):
    env = envs.make(task, robot)
    r = Retargeter.for_env(env, "joint")
    demo = make_demonstrator(task, kind, watches=watches)
    plans = []
    plan = demo.plan

    def planned(env, seed=None, **start):
        plans.append(plan(env, seed=seed, **start))
        return plans[-1]

    demo.plan = planned
    out = run_episode(env, r, seed, via=via, demonstrator=demo, push=push, bias=bias)
    env.close()
    return out, plans[0]


def test_the_watching_wearer_closes_a_pinch_the_open_loop_wearer_leaves_open():
    """Shadow, seed 8, through the glove's noisy pose with the fused thumb's standing error (10 degrees of abduction
    and IP, as the whole recording path gives some takes): the same plan, open loop, lifts without the pinch;
    watching, the wearer sees a pad stop short of the object and moves it on."""
    bias = {"thumb_cmc_abd": 10, "thumb_ip": 10}
    blind, plan = _run("pinch", 8, robot="shadow", via="glove", watches=False, bias=bias)
    assert not blind["success"] and plan.watcher is None, blind
    seen, plan = _run("pinch", 8, robot="shadow", via="glove", bias=bias)
    assert seen["success"], seen
    assert any(" onto the object" in line for line in plan.watcher.made), plan.watcher.made


def test_a_correction_leaves_what_was_performed_and_a_planned_release_as_planned():
    m = DemoMotion([0.0, 1.0, 2.0, 3.0, 4.0], [np.zeros(20)] * 2 + [np.full(20, 0.2)] * 2 + [np.zeros(20)],
                   np.random.default_rng(0))  # fmt: skip
    before = m.keyframe_angles(np.linspace(0, 2.2, 50))
    with pytest.raises(ValueError, match="inside a move"):
        m.revise(1.5, 0.2, pose_delta=np.full(20, 0.05))
    m.revise(2.2, 0.2, pose_delta=np.full(20, 0.05))
    np.testing.assert_allclose(m.keyframe_angles(np.linspace(0, 2.2, 50)), before)
    np.testing.assert_allclose(m.keyframe_angles([3.0])[0], np.full(20, 0.25))  # the hold goes on flexed
    np.testing.assert_allclose(m.keyframe_angles([4.2])[0], np.zeros(20))  # the release as planned, 0.2 s later


@pytest.mark.parametrize("seed", [1, 4, 6])
def test_after_the_object_is_pushed_the_relocate_wearer_regrips_and_succeeds(seed):
    push = pushed(seed, (2, 4))
    done, plan = _run("relocate", seed, push=push)
    assert done["success"] and plan.replanned == 1, done
    RelocateMotion.replans, kept = 0, RelocateMotion.replans  # the same take reaching where the object was
    try:
        blind, _ = _run("relocate", seed, push=push)
    finally:
        RelocateMotion.replans = kept
    assert not blind["success"], blind


def test_after_the_target_is_pushed_the_pick_wearer_reaches_where_it_lies():
    done, plan = _run("pick", 0, push=pushed(0, (2, 4)))
    assert done["success"] and plan.replanned == 1, done


def test_a_plan_from_mid_take_carries_on_with_the_object_in_hand():
    env = envs.make("relocate")
    u, r = env.unwrapped, Retargeter.for_env(env, "joint")
    demo = make_demonstrator("relocate")
    env.reset(seed=3)
    m = demo.plan(u, seed=3)
    while not (in_hand(u) and u.object_pose()[2] - u.object_start[2] > 0.03):  # lifted: the carry is ahead
        b = m.at([u.t])
        env.step(r(b.angles[0], b.palm_quat[0], b.palm_pos[0])[0])
    fresh = demo.plan(u, seed=99, start=(m.keyframe_angles([u.t])[0], m._keyframes([u.t], m.palm_positions)[0]))
    assert fresh.aim[2] == 0.0 and fresh.checks[0][2] == "carry"  # no reach: straight to the carry
    t0, done = u.t, False
    while not done:
        b = fresh.at([u.t - t0])
        _, _, terminated, truncated, info = env.step(r(b.angles[0], b.palm_quat[0], b.palm_pos[0])[0])
        done = terminated or truncated
    assert info["is_success"], u.failure()
    env.close()


def test_a_failed_take_says_why():
    out, _ = _run("relocate", 5, kind="human", push=None)
    assert out["success"]
    human = make_demonstrator("relocate", "human", failure_rate=1.0)
    env = envs.make("relocate")
    r = Retargeter.for_env(env, "joint")
    runs = [run_episode(env, r, seed, demonstrator=human) for seed in range(4)]
    env.close()
    why = {x["intent"]["failure"]: x["failed_because"] for x in runs}
    assert set(why) == {"too loose", "misplaces"}, runs
    assert why["misplaces"].startswith("put down") and "cm from the circle" in why["misplaces"], why


@pytest.mark.process
def test_record_relocate_with_the_human_like_wearer_and_a_free_wrist(tmp_path):
    root = tmp_path / "ds"
    r = cli("record", "--task", "relocate", "--wrist", "marker:emulated", "--demonstrator", "human", "--glove",
            "emulator", "--episodes", "2", "--root", str(root), "--repo-id", "test/relocate_human", "--view",
            "none", "--no-log", "--json")  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout.strip().splitlines()[-1])["episodes_saved"] == 2
    records = read_sidecar(root)
    assert [rec["demonstration"]["demonstrator"] for rec in records] == ["human", "human"]
    assert all(rec["success"] or rec["failed_because"] for rec in records), records
